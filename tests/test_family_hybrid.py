"""Hybrid models over the family of test structures (issue 22), noise-free and 1% noise: the
nominal hybrid against the identified normal-mode model at the tested I/O, and its
predictions (a D-strut, a broken strut, an untested shaker, the closed-loop band RMS of the
D-strut design) against the truth and the deliberately wrong FE model
(:mod:`family_struts`).  Each member's figures are locked (measured / 1.5 for the ratios,
x1.5 for the errors), so that no change trades one structure for another; the issue's
targets (nominal no worse than the normal-mode model, >= 12x, >= 3x, RMS within 2%) are
asserted where the member reaches them and the gap is stated where it does not.  The
hybrids are built with :func:`sdctrl.hybrid`'s default, ``residual="auto"``: the
representation chosen by leave-one-out prediction on the test's own channels
(:mod:`sdctrl.hybrids._auto`), its choice and the scores that made it asserted per member.
The former default, ``residual="identified"``, keeps its own locked figures
(:data:`IDENTIFIED_MEASURED`).
"""

import functools
import warnings

import numpy as np
import pytest

import sdctrl as sd
from family_struts import figures, identified_models, pick_bar, with_strut
from sdctrl.hybrids._auto import TIE

#: measured figures per (member, noise), the default hybrid (``residual="auto"``): logLS of the
#: nominal hybrid and of the identified normal-mode model at the tested I/O; wrong-FE/hybrid
#: logLS ratios of a D-strut, a broken strut and an untested shaker; relative error of the
#: D-strut design's closed-loop band RMS by the hybrid and by the wrong FE (seed 1, 400 lines;
#: normal modes keep the out-of-band poles as residual dynamics; FE/test pairing within a
#: factor 2 in frequency).  Since a strut's static correction mode carries the FE's own
#: damping projected on it instead of critical damping (2.20), the RMS errors fell (truss
#: 1.6% -> 0.03%, truss_high 2.5% -> 0.28%: the critically damped static mode had added a
#: damping path to the 52.9 Hz mode, 0.0090 against the true 0.0082) and the broken strut
#: moved both ways (truss 7.4 -> 6.6x, truss_high 5.3 -> 4.7x, ladder 47 -> 622x).  The 1% rows
#: re-locked when "auto" became the default (the identification had moved since their last
#: lock: the normal-mode models' logLS truss 0.0135 -> 0.0186, truss_high 0.0041 -> 0.0037,
#: ladder 0.0018 -> 0.0024, plate 0.0014 -> 0.0006); at 1% every hybrid nominal is within
#: 1.4% of its normal-mode model's logLS or below it
MEASURED = {
    # the truss, truss_high and plate rows since an out-of-band test pole may give an appended
    # FE mode its frequency (sdctrl.hybrids._out_of_band: the fit at the tested I/O and the
    # held-out prediction both better): untested shaker truss 25.48 -> 26.92x (1% 24.56 ->
    # 25.8x), truss_high 20.52 -> 21.25x (19.69 -> 20.93x), plate 34.47 -> 43.65x (33.47 ->
    # 44.14x); every other figure within 1% (the truss's D-strut at 1% 148.24 -> 147.41x)
    ('truss', 0.0): (0.0048, 0.0048, 137.62, 6.6, 26.92, 0.0001, 0.0473),
    # the truss at 1% since the rows of phib of its close pair (15.8/15.9 Hz) are refitted to
    # the FRF (normal modes, issue 22): before (0.0135, 0.01354, 112.3, 6.51, 24.23, 0.0003)
    # the 1% rows since the normal modes keep the improper parts the logLS rule asks for
    # (identification._part_selection) and a passive out-of-band term may be placed
    # (identification._far_terms): before truss (0.00907, 0.00911, 133.43, 6.55, 24.57),
    # truss_high (0.00379, 0.00374, 124.61, 4.73, 19.77), ladder (0.00245, 0.00244, 635.22,
    # 325.14, 28.87), plate (0.0006, 0.00061, 1576.79, 12.8, 33.22), cluster shaker 0.084
    # the 1% rows since identify's default is "auto" (the level-weighted fit kept on the truss,
    # the ladder and the cluster; the unweighted one on truss_high and the plate, whose figures
    # move with the flexibility term's band error carried): before truss (0.00849, 0.00855,
    # 138.26, 6.53, 24.57, 0.0002), truss_high (0.00202, 0.00198, 124.92, 4.71, 19.77, 0.0028),
    # ladder (0.00241, 0.00239, 647.22, 327.76, 28.95, 0.0004), plate (0.00034, 0.00035,
    # 2741.49, 12.79, 33.22, 0.0001)
    ('truss', 0.01): (0.0081, 0.00806, 147.41, 6.57, 25.8, 0.0, 0.0473),
    ('truss_high', 0.0): (0.00088, 0.00088, 130.15, 4.73, 21.25, 0.0032, 0.1147),
    ('truss_high', 0.01): (0.00142, 0.00142, 128.08, 4.7, 20.93, 0.0031, 0.1147),
    # the noise-free ladder since identification's own solver (issue 27) ends at 15 poles,
    # logLS 7.7e-4 (an exact fit's pruning decided by round-off, tests/test_family_identify.py):
    # before (4e-05, 0.0, 42562.09, 622.04, 43.42, 0.0001) -- every target still met
    ('ladder', 0.0): (0.00086, 0.00087, 1799.13, 491.61, 44.76, 0.0, 0.0443),
    ('ladder', 0.01): (0.0006, 0.0006, 2596.9, 503.63, 29.34, 0.0003, 0.0443),
    # the noise-free plate since identify's default zeta_max is 0.25 (its identified model
    # 6.6e-4 -> 4.5e-12): before (0.00076, 0.00091, 1168.15, 12.81, 34.47, 0.0)
    ('plate', 0.0): (5e-08, 0.0, 34318.08, 12.91, 43.65, 0.0, 0.0255),
    ('plate', 0.01): (0.00036, 0.00035, 2666.93, 12.79, 44.14, 0.0001, 0.0255),
    # the cluster re-locked when identify's default became "auto" (the level-weighted fit
    # kept at 1%: it resolves the near-node and cross-axis lines the unweighted fit missed;
    # noise-free data get the unweighted fit) and the flexibility term's band error was
    # carried (the noise-free hybrid's nominal = nm's): before (0.00035, 8e-05, 599.47,
    # 117.19, 0.08, 0.0, 0.1113) and (0.03022, 0.03153, 7.03, 7.14, 0.0997, 0.0017, 0.1113);
    # the untested shaker at 1% is the one figure that fell (0.0997x -> 0.064x, both far
    # below 12x: a lock, not a target)
    ('cluster', 0.0): (8e-05, 8e-05, 2594.61, 128.31, 0.0765, 0.0, 0.1113),
    # identification finds the 5 modes at 1% since the pole search weighs each channel by its
    # noise level (before: 4, and 1.02908, 1.02822, 0.21, 0.21, 0.11, 0.0008); the blade mode
    # at 10.287 Hz, left residual by the normal-mode step (0.37521, 0.9417, 0.57, 0.58, 0.048,
    # 0.0025), is a normal mode since its scaling's phase is a proper mode's and the four
    # blade modes' improper parts are kept together (issue 22): D-strut and broken strut
    # 0.57x / 0.58x -> 7.0x / 7.1x, the D-strut RMS error 0.25% -> 0.17%
    ('cluster', 0.01): (0.00039, 0.00035, 542.42, 157.12, 0.0637, 0.0021, 0.1113),
}
#: the representation ``residual="auto"`` chose, per member (both noise levels, the hybrid of
#: every shaker and that of all but the last): on every member the held-out predictions of the
#: FE's own frequencies (``"fe"``) are worse than those of the appended modes scaled by
#: ``kappa`` (``"identified"``, which ``"tested"`` shares away from the tested I/O), e.g.
#: truss 0.47 / 0.19, truss_high 0.85 / 0.22, plate 0.14 / 0.05, ladder 0.064 / 0.060,
#: cluster 0.155 / 0.114 (noise-free, all shakers); among the two equal ones the test's own
#: residual dynamics, E and F reproduce the identified model at the tested I/O (nominal
#: 1e-5 against 0.008-0.34 for "identified"): "tested" everywhere
CHOSEN = {name: "tested" for name in ("truss", "truss_high", "ladder", "plate", "cluster")}
#: (the cluster at 1% with every shaker chose "fe" while one blade mode was left residual by
#: the normal-mode step, held-out 0.763 against 0.827; now "tested", 1.104 against 1.123)
CHOSEN_AT = {}
_ALL = {(n, x) for n in CHOSEN for x in (0.0, 0.01)}
#: where each (member, noise) stands against the issue's targets (asserted where met; the
#: gaps, locked above, are the open part of issue 22): the cluster's untested shaker, 4.5x
#: noise-free and 0.064x at 1% (on the unweighted fit 0.08x and 0.10x).  Its D-strut at 1%
#: reaches 610x since identify's default keeps the level-weighted fit (on the unweighted
#: fit 6.7x, the gap it was: 7.0x, 0.57x while a blade mode was left residual by the
#: normal-mode step).  The two tests at the end of this module measure and assert, on both
#: fits:
#: - the D-strut at 1% is the test's own floor: on the unweighted fit 88% of its logLS lies
#:   on the 4 cross-axis hub channels (H1/2/4/5.z from H3.y, below the cluster) that the
#:   identified model itself misses at 1% noise (0.305 there; 0.0042 elsewhere; 9e-4
#:   noise-free); the level-weighted fit reproduces them (0.0016) and the gap closes;
#: - the untested shaker: the remaining shaker H3.y is a near node of the blade modes
#:   (participation 4e-4 against 1.11 at T1.y); the unweighted test without T1.y resolves
#:   two composite blade modes (MAC 0.73/0.89), the level-weighted one all four (MAC 1.0,
#:   4.5x noise-free); the near-cancellation at the other blades is carried by the
#:   cluster's damping coupling (FE modes with the test's frequencies: 14.6x with the FE's
#:   coupled damping, 0.55x with its diagonal), which that test cannot measure and the
#:   hybrid's appended FE modes do not carry (mean damping, 5.1.1)
TARGETS = {
    "dstrut": _ALL,
    "broken": _ALL,
    "shaker": _ALL - {("cluster", 0.0), ("cluster", 0.01)},
    "rms": _ALL,
}
#: the nominal hybrid within 2% of the normal-mode model's logLS (+1e-4) on every member:
#: the test's E is carried by a term 30x above the band whose band error (<= 0.8% of E) is
#: carried by the test's poles above the band (sdctrl.hybrids._tested_io.carry_flexibility,
#: imaginary residues, realised exactly).  Before, the noise-free cluster was left out (the
#: hybrid 3.5e-4 against 8e-5, now 8e-5), and the level-weighted fits, whose E nearly
#: cancels their out-of-band poles, failed it: ladder 1% 0.00075 against 0.0006 (now
#: 0.0006); the cluster at 1% is 0.00039 against 0.00035 (within the +1e-4)
NOMINAL = _ALL


@functools.lru_cache(maxsize=None)
def _models(name, noise, weighting=None):
    """The member, its normal-mode models with every shaker and without the last one
    (``sd.identify``'s default fit, or the given ``weighting``)."""
    st = sd.testbeds.structure(name)
    return (st,) + identified_models(st, noise, weighting)


@functools.lru_cache(maxsize=None)
def _build(name, noise, residual=None, weighting=None):
    """The member's hybrids with every shaker and without the last one: ``sd.hybrid``'s
    default (``residual=None``) or the given representation (on :func:`_models`)."""
    st, nm, nm_minus = _models(name, noise, weighting)
    SH, SE = list(st.shakers), list(st.sensors)
    kw = {} if residual is None else {"residual": residual}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        h = sd.hybrid(st.wrong(), nm, SE, SH, **kw)
        h_minus = sd.hybrid(st.wrong(), nm_minus, SE, SH[:-1], **kw)
    return st, nm, h, h_minus


def _check(got, ref, key, targets):
    if key in targets["dstrut"]:
        assert got.dstrut >= 12
    if key in targets["broken"]:
        assert got.broken >= 3
    if key in targets["shaker"]:
        assert got.shaker >= 12
    if key in targets["rms"]:
        assert got.rms_hybrid <= 0.02 and got.rms_fe > got.rms_hybrid
    assert got.nominal <= 1.5 * ref[0] + 1e-4
    assert got.dstrut >= ref[2] / 1.5 and got.broken >= ref[3] / 1.5
    assert got.shaker >= ref[4] / 1.5
    assert got.rms_hybrid <= 1.5 * ref[5] + 1e-3


def _check_choice(model, name, how, expected=None):
    """The recorded choice follows the rule of :func:`sdctrl.hybrids._auto.choose_residual`
    and its scores."""
    expected = CHOSEN[name] if expected is None else expected
    r = model.construction.residual
    print(f"  {how}: {r.representation}, held-out logLS "
          f"{ {k: round(v, 4) for k, v in r.loo_scores.items()} }, nominal "
          f"{ {k: round(v, 5) for k, v in r.nominal_scores.items()} }")
    assert r.chosen_by == how and r.representation == expected
    assert set(r.loo_scores) == set(r.nominal_scores) == {"identified", "tested", "fe"}
    assert np.all(np.isfinite(list(r.loo_scores.values())))
    low = min(r.loo_scores.values())
    ties = [k for k, v in r.loo_scores.items() if v <= (1 + TIE) * low]
    assert r.representation in ties
    assert r.nominal_scores[r.representation] == min(r.nominal_scores[k] for k in ties)
    # away from the tested I/O "tested" is "identified" (same modes): one score
    assert r.loo_scores["tested"] == r.loo_scores["identified"]
    # the FE's own frequencies predict the held-out channels worse than kappa-scaled ones
    assert (r.loo_scores["fe"] >= r.loo_scores["identified"]) == (expected != "fe")
    assert r.held_out.size == min(6, model.na if how.endswith("actuator-out") else model.ns)


@pytest.mark.parametrize("noise", [0.0, 0.01])
@pytest.mark.parametrize("name", sd.testbeds.family())
def test_hybrid_predictions_locked_per_member(name, noise):
    st, nm, h, h_minus = _build(name, noise)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        got = figures(st, nm, h, h_minus)
    print(f"\n{name} {noise}: {got}")
    chosen = CHOSEN_AT.get((name, noise, "all"), CHOSEN[name])
    _check_choice(h, name, "leave-one-actuator-out", chosen)
    _check_choice(h_minus, name, "leave-one-actuator-out" if h_minus.na >= 2
                  else "leave-one-sensor-out", CHOSEN_AT.get((name, noise, "minus")))
    _check(got, MEASURED[(name, noise)], (name, noise), TARGETS)
    if (name, noise) in NOMINAL:                              # no worse than the normal-mode model
        assert got.nominal <= 1.02 * got.nm + 1e-4
    if chosen == "tested":
        # the tested I/O keeps the test: nm's residual dynamics bit for bit, E, F
        if nm.residual is not None:
            m = nm.residual.m
            assert np.array_equal(h.residual.poles[:m], nm.residual.poles)
            assert np.array_equal(h.residual.residues[:m], nm.residual.residues)
        assert (h.F is None) == (nm.F is None) and h.E is None
        assert np.all(h.cphi[:, ~h.measured] == 0)


#: the former default, ``residual="identified"`` (FE modes and fitted residual terms at the
#: tested I/O), at 1% noise, figures as above (re-locked on the same state as MEASURED's 1%
#: rows): its nominal is 1.2x (truss) to 45x (plate) the normal-mode model's (7.3x
#: truss_high, 8.0x ladder) -- the gap of issue 22 that the default ``"auto"`` closes.  What
#: the default changed, per member (1%, MEASURED against these): nominal logLS truss 0.0216
#: -> 0.0185, truss_high 0.0274 -> 0.0038, ladder 0.0196 -> 0.0025, plate 0.0273 -> 0.0006;
#: D-strut truss 86 -> 94x, truss_high 57 -> 125x, ladder 79 -> 635x, plate 36 -> 1577x;
#: broken strut truss_high 4.64 -> 4.73x, ladder 69 -> 325x, plate 9.6 -> 12.8x; RMS error
#: truss 0.24% -> 0.02%, truss_high 0.67% -> 0.28%, ladder 0.05% -> 0.04%, plate 0.07% ->
#: 0.01%.  Worse: the truss's broken strut 6.81 -> 6.46x, and (on that state) the cluster at
#: 1%, where "auto" chose "fe" while a blade mode was left residual by the normal-mode step:
#: nominal 0.314 -> 0.375, D-strut 0.68 -> 0.57x.  Since every blade mode is a normal mode
#: (issue 22) "auto" chooses "tested" there too and the default is the better one on every
#: member: cluster 1% nominal 0.343 -> 0.030, D-strut 0.62 -> 7.0x, broken strut 0.64 ->
#: 7.1x; the truss rows below were re-locked after the close pair's phib rows were refitted
#: (identified: before 0.02165, 0.01855, 86.46, 6.81, 24.57, 0.0024)
IDENTIFIED_MEASURED = {
    'truss': (0.0127, 0.00911, 121.54, 6.89, 24.57, 0.0024),
    'truss_high': (0.02743, 0.00374, 56.67, 4.64, 19.77, 0.0067),
    'ladder': (0.01963, 0.00244, 79.22, 68.74, 28.87, 0.0005),
    'plate': (0.02727, 0.00061, 36.02, 9.6, 33.22, 0.0007),
    'cluster': (0.31365, 0.9417, 0.68, 0.68, 0.048, 0.0024),   # before 5 modes: 0.6769,
    # 1.02822, 0.31, 0.32, 0.11, 0.003; since every blade mode is a normal mode (issue 22):
    # 0.3426, 0.0315, 0.62, 0.64, 0.084, 0.0009 (within the locks, kept)
}
_MET = {"truss", "truss_high", "ladder", "plate"}
IDENTIFIED_TARGETS = {"dstrut": _MET, "broken": _MET, "shaker": _MET, "rms": _MET}


@pytest.mark.parametrize("name", sd.testbeds.family())
def test_identified_hybrid_locked_per_member(name):
    st, nm, d, d_minus = _build(name, 0.01, "identified")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        got = figures(st, nm, d, d_minus)
    print(f"\n{name} identified: {got}")
    assert d.construction.residual.representation == "identified"
    assert d.construction.residual.chosen_by is None          # given, not chosen
    _check(got, IDENTIFIED_MEASURED[name], name, IDENTIFIED_TARGETS)
    # the default (MEASURED) is no worse at the tested I/O wherever "auto" keeps the test's
    # own residual terms ("tested"): all but the cluster at 1%, stated above
    if CHOSEN_AT.get((name, 0.01, "all"), CHOSEN[name]) == "tested":
        assert MEASURED[(name, 0.01)][0] <= got.nominal


def _log_err(H, ref):
    """Per line and channel ``|ln|H| - ln|ref||^2`` (the terms of logLS, 3.12)."""
    return np.abs(np.log(np.abs(H)) - np.log(np.abs(ref))) ** 2


@pytest.mark.parametrize("weighting", ["none", None])
def test_cluster_dstrut_gap_is_the_tests_own_floor(weighting):
    """The cluster's D-strut at 1% is bounded by the test's own model: below 12x on the
    unweighted fit (6.7x, 7.0x before the flexibility term's band error was carried), 610x
    on the default's (``sd.identify``'s ``"auto"`` keeps the level-weighted fit there).

    Measured on the unweighted fit: 88% of the hybrid's D-strut logLS lies on 4 of the 44
    channels, the cross-axis hub channels H1.z, H2.z, H4.z, H5.z driven by H3.y, mostly
    below the cluster (6-9.5 Hz), where the true response (2e-12 m/N at 7 Hz on H5.z) is
    a cancellation of out-of-band hub-mode terms of 1e-9 to 7e-9 (1 part in 3000).  The
    identified model's
    own error there is 0.305 at 1% noise (8e-5 overall noise-free), the hybrid's D-strut
    0.291 (it keeps the test at the tested I/O, ``"tested"``); on every other channel the
    D-strut is 49x better than the wrong FE.  Not the carrier: the mass scale of the two
    blade modes whose collocated residues are within their noise (scaling them by the FE
    expansion, unit FE modal mass, moved the D-strut 7.03x -> 5.6x, the nominal 0.030 ->
    0.038), nor the expansion of the close modes (the true shapes of the four blade modes
    put in the hybrid with its identified Omega/Gamma: 0.71x, and a nominal of 0.30: the
    identified Gamma couples the identified shapes).
    """
    st, nm, h, _ = _build("cluster", 0.01, None, weighting)
    nm0 = _models("cluster", 0.0, weighting)[1]
    true, wrong = st.fe(), st.wrong()
    SH, SE = list(st.shakers), list(st.sensors)
    freq = np.linspace(*st.band, 300)
    bar = pick_bar(st, true)
    s = wrong.strut(bar.a, bar.b)
    kp, kv = -0.4 * bar.k_bar, bar.kv
    ref = with_strut(true, s, kp, kv).frf(freq, SH, SE, "acceleration").H
    e_fe = _log_err(with_strut(wrong, s, kp, kv).frf(freq, SH, SE, "acceleration").H, ref)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        e_h = _log_err(h.with_feedback(s, s.T, kp=kp, kv=kv).frf(freq, "acceleration").H, ref)
    nominal = true.frf(freq, SH, SE, "acceleration").H
    e_nm = _log_err(nm.frf(freq, "acceleration").H, nominal)
    e_nm0 = _log_err(nm0.frf(freq, "acceleration").H, nominal)
    cross = np.zeros((len(SE), len(SH)), bool)
    cross[[SE.index(f"H{i}.z") for i in (1, 2, 4, 5)], SH.index("H3.y")] = True
    print(f"\nD-strut ratio {e_fe.mean() / e_h.mean():.2f}, without the cross-axis channels "
          f"{e_fe[:, ~cross].mean() / e_h[:, ~cross].mean():.2f}; their share "
          f"{e_h[:, cross].sum() / e_h.sum():.3f}; nm there {e_nm[:, cross].mean():.4f} (1%), "
          f"{e_nm0[:, cross].mean():.2e} (0%), elsewhere {e_nm[:, ~cross].mean():.4f}")
    # the hybrid's D-strut there is no worse than the test's own nominal model (0.305 /
    # 0.0016; the default's hybrid 1.06x it since the flexibility term's band error is carried
    # by imaginary residues only)
    assert e_h[:, cross].mean() <= 1.1 * e_nm[:, cross].mean()
    assert e_nm0[:, cross].mean() <= 0.01 and e_nm[:, ~cross].mean() <= 0.01
    if weighting is None:                                     # the default: the gap closed
        assert e_fe.mean() / e_h.mean() >= 542 / 1.5          # 542.4x (MEASURED)
        assert e_nm[:, cross].mean() <= 0.01                  # 0.0016
        return
    assert e_fe.mean() / e_h.mean() < 12                      # 6.7x: the gap
    assert e_fe[:, ~cross].mean() / e_h[:, ~cross].mean() >= max(12, 49.4 / 1.5)   # 48.8
    assert e_h[:, cross].sum() >= 0.8 * e_h.sum()             # 0.88
    below = freq < 9.5                                        # below the cluster
    assert e_h[below][:, cross].sum() >= 0.8 * e_h[:, cross].sum()
    # the test's own model misses those channels at 1% (0.305) and not noise-free
    assert e_nm[:, cross].mean() >= 0.2                       # 0.0042 elsewhere


def _fe_with_test_frequencies(st, model, kappa, coupled=True, n=60):
    """The wrong FE's ``n`` modes (modal model, no static correction) with the frequencies
    of its modes paired to a measured mode at MAC >= 0.99 taken from the test and the others
    scaled by ``kappa``; damping the FE's ``phi^T C phi`` (times the frequency scale), whole
    or its diagonal."""
    wrong = st.wrong()
    f, phi = wrong.modes(n)
    scale = np.full(n, kappa)
    pr = model.construction.pairing
    good = pr.mac >= 0.99
    scale[pr.fe_mode[good]] = pr.test_hz[good] / f[pr.fe_mode[good]]
    G = (phi.T @ (wrong.C @ phi)) * np.sqrt(np.outer(scale, scale))
    G = G if coupled else np.diag(np.diag(G))
    return sd.NormalModeModel(np.diag((2 * np.pi * f * scale) ** 2), G,
                              wrong.point(list(st.sensors)).T @ phi,
                              phi.T @ wrong.point([st.shakers[-1]]))


@pytest.mark.parametrize("weighting", ["none", "level"])
def test_cluster_shaker_gap_what_carries_it(weighting):
    """Why the cluster's untested shaker (T1.y) stays below 12x (MEASURED 0.077x noise-free,
    unweighted as the default fits noise-free data, 4.5x level-weighted; 0.064x at 1%).

    Measured, noise-free, on the unweighted fit: the remaining shaker H3.y (hub centre)
    is a near node of the four blade modes (participation 4e-4 against 1.11 at T1.y), so
    the test without T1.y
    resolves two of them, composites of the true ones (MAC 0.73 and 0.89 with their FE
    pairs, 1.0 with every shaker).  63% of the hybrid's error lies at 11-30 Hz, above the
    cluster, where at the other blades' sensors the four modes' tails must cancel (at 20
    Hz on T2.y the hybrid's cluster gives 1.8e-5 m/N, the truth -2.7e-7).  The
    expansion is not the carrier (the true shapes of the four blade modes put in the
    hybrid: 0.51x; Lowdin-orthonormal cluster shapes in the FE's mass: 0.72x), nor the
    two modes' mass scale (unit FE modal mass: 0.11x).  The carrier is the cluster's
    damping coupling (the dashpot between two blade tips), which a test that does not
    excite the blades cannot measure: the wrong FE's modes with the test's frequencies
    where the test has the mode (the local mode) and ``kappa`` elsewhere predict the
    shaker 14.6x better than the wrong FE with the FE's whole damping matrix, 0.55x with
    its diagonal (the hybrid's appended modes carry the mean damping, 5.1.1).  The same
    steps inside the hybrid (the two composite modes absorbed, the FE modes of the cluster
    at kappa with the FE's projected damping, every appended mode likewise) reached 9.7x
    (at 1%, where that test's four blade modes are the ones whose mass scale is not
    measured, absorbing them likewise: 8.3x): an open route, short of 12x and not taken
    (no rule found that tells composite modes from measured ones noise-free, and it
    changes every member's appended modes).
    On the level-weighted fit (``weighting="level"``, noise-free; the default fits
    noise-free data unweighted, as measurable noise is what the weights are for) the test
    without T1.y
    resolves all four blade modes (MAC 1.0 with their FE pairs: the near-node lines weigh
    as much as the peaks) and the shaker rises 0.077x -> 4.5x; what is left is the same
    carrier: 81% of the error at 11-30 Hz, the FE modes with the test's frequencies 14.8x
    with the coupled damping, 0.55x with its diagonal.
    """
    st, nm, h, h_minus = _build("cluster", 0.0, None, weighting)
    true, wrong = st.fe(), st.wrong()
    SH, SE = list(st.shakers), list(st.sensors)
    f, phi = true.modes(5)
    part = np.abs(true.point(SH).T @ phi[:, :4])              # blade modes, per shaker
    assert part[0].max() <= 1e-3 * part[1].max()              # 4e-4 against 1.11
    pr, pr_all = h_minus.construction.pairing, h.construction.pairing
    blade = pr.test_hz < 11
    if weighting == "level":                         # every blade mode resolved, MAC 1.0
        assert blade.sum() == 4 and np.all(pr.mac >= 0.999)
    else:                                            # two composites, MAC 0.73 / 0.89
        assert blade.sum() == 2 and np.all(pr.mac[blade] < 0.95)
    assert (pr_all.test_hz < 11).sum() == 4 and np.all(pr_all.mac >= 0.999)
    freq = np.linspace(*st.band, 300)
    u = SH[-1]
    ref = true.frf(freq, [u], SE, "acceleration").H
    e_fe = _log_err(wrong.frf(freq, [u], SE, "acceleration").H, ref).mean()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        e_h = _log_err(h_minus.with_io(b=[u]).frf(freq, "acceleration").H, ref)
    above = (freq > 11) & (freq < 30)
    assert e_h[above].sum() >= 0.5 * e_h.sum()                # 0.67 unweighted, 0.81
    assert e_fe / e_h.mean() < 12                              # 0.077x unweighted, 4.5x
    kappa = h_minus.construction.residual.kappa
    ratios = [e_fe / _log_err(_fe_with_test_frequencies(st, h_minus, kappa, coupled).frf(
        freq, "acceleration").H, ref).mean() for coupled in (True, False)]
    print(f"\nshaker: hybrid {e_fe / e_h.mean():.3f}x; wrong FE with the test's frequencies "
          f"and kappa {kappa:.4f}: coupled damping {ratios[0]:.2f}x, diagonal {ratios[1]:.2f}x")
    assert ratios[0] >= 12 and ratios[1] < 1                 # 14.6x, 0.55x (14.8, 0.55)
