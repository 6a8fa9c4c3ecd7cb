"""The improper part of an in-band residue kept at its pole (issue 22; thesis 3.3).

Properness (3.40) enforced on the in-band modes alone (3.51-3.52) changes their residues; where
the structure couples the in-band modes with modes outside the band (section 3.3's assumption
fails: the ladder's dashpots), the change is significant against the residue's standard
deviation (3.58), and ``normal_modes`` keeps the identified residue minus the normal mode's
(3.7 against 2.15) as a complex-mode term at the same pole in ``nm.residual``.  Where it is
noise (1% truss) or where the identified model has no out-of-band poles (cluster), nothing is
added -- but where the normal modes would then miss the identified model by more than it
misses the data (mean logLS, 3.12), the parts significant entry by entry that bring them
closest are kept, the fewest that do (:mod:`sdctrl.identification._part_selection`).
"""

import warnings
from dataclasses import replace

import numpy as np
import pytest

import sdctrl as sd
from sdctrl.identification._close_modes import close_groups, summed_residue_std
from sdctrl.identification._mode_split import (
    IMPROPER,
    OUT_OF_BAND,
    residues_at,
    improper_terms,
    modal_factors,
)
from sdctrl.identification._proper_terms import phib_from_residues
from sdctrl.updating import logls
from test_family_normal_modes import _chain    # one cached chain per member for both files


def _improper(nm):
    r = nm.residual
    k = np.array([why == IMPROPER for why in r.reasons], bool)
    return r.source[k], r.poles[k], r.residues[k]


def test_noise_free_ladder_reproduces_the_identified_model_at_the_tested_io():
    frf, cm, nm = _chain("ladder", 0.0)
    src, poles, D = _improper(nm)
    assert src.tolist() == np.flatnonzero(cm.in_band).tolist()      # all significant (z > 5e4)
    # the normal modes' residue plus the kept part is the identified residue (3.7 = 2.15 + D)
    Rn = residues_at(nm, poles)
    R = cm.residues[src]
    assert np.abs(Rn + D - R).max() <= 1e-9 * np.abs(R).max()
    # the largest improper parts are on the most damped modes (23.8, 78.4, 64.2 Hz)
    rel = np.linalg.norm(D, axis=(1, 2)) / np.linalg.norm(R, axis=(1, 2))
    top = np.sort(np.round(cm.frequency[src[np.argsort(-rel)[:3]]], 1)).tolist()
    assert top == [23.8, 64.2, 78.4]
    assert rel.max() > 0.03                                            # measured 4.1% (23.8 Hz)
    H = nm.frf(frf.freq, quantity=frf.quantity).H
    assert logls(H, cm.frf(frf.freq, quantity=frf.quantity).H) < 1e-8  # measured 4e-11
    # without the improper parts: the properness error of the in-band modes (0.0108)
    bare = nm.replace(residual=nm.residual.__class__(
        nm.residual.poles[: -src.size], nm.residual.residues[: -src.size],
        sensors=nm.sensors, actuators=nm.actuators))
    assert logls(bare.frf(frf.freq, quantity=frf.quantity).H, frf.H) > 0.01


def test_noisy_ladder_keeps_the_most_damped_modes_only():
    """1% noise: the improper parts above three standard deviations are those of the modes the
    dashpots couple out of band (z = 8.6, 9.6, 5.7; the next is 2.2), and, since close modes
    are judged together, that of 79.9 Hz, close to 78.4 Hz (their contributions correlate by
    0.65 > 1/2)."""
    # the mechanism as shown on the unweighted fit (weighting="none"); the default (auto)
    # keeps the level-weighted fit here, whose residues differ within their noise
    frf, cm, nm = _chain("ladder", 0.01, "none")
    src, _, _ = _improper(nm)
    assert np.round(cm.frequency[src], 1).tolist() == [23.8, 64.2, 78.4, 79.9]
    e_nm = logls(nm.frf(frf.freq, quantity=frf.quantity).H, frf.H)
    assert e_nm < 0.005                                # measured 0.00198 (0.00195 with 79.9)


def test_close_modes_improper_parts_are_kept_together():
    """The cluster at 1%: the four blade modes (10.15-10.29 Hz) form one group; the improper
    part of 10.287 Hz is significant (3.8 sigma), the others are not (0.5-0.7 sigma), and all
    four are kept.  Keeping one without the others upsets the cluster's balance."""
    # the mechanism as shown on the unweighted fit (weighting="none"); the default (auto)
    # keeps the level-weighted fit here, whose residues differ within their noise
    frf, cm, nm = _chain("cluster", 0.01, "none")
    sel = nm.properness.poles_used
    blades = sel[cm.frequency[sel] < 11.0]
    assert blades.size == 4
    assert close_groups(cm.poles[blades]).tolist() == [0, 0, 0, 0]
    src, poles, _ = _improper(nm)
    assert src.tolist() == blades.tolist()
    # judged on step 5's phib, the residue fit over every mode (step 6 refits it to the FRF)
    Xs, Ys = modal_factors(nm, cm.poles[sel])
    step5 = nm.replace(phib=phib_from_residues(cm.residues[sel], Xs, Ys))
    R = cm.residues[src]
    X, Y = modal_factors(nm, poles)
    D = R - np.einsum("ij,jk->jik", X, Y.T @ step5.phib)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        std = cm.residue_std()[src]
    z = np.linalg.norm(D, axis=(1, 2)) / np.linalg.norm(std, axis=(1, 2))
    assert (z > 3).sum() == 1 and z.max() > 3                       # 10.287 Hz alone
    assert abs(cm.frequency[src[np.argmax(z)]] - 10.287) < 0.005

    # the parts against step 5's model, kept for a subset of the group (the other poles of
    # the residual dynamics as they are)
    r = nm.residual
    other = np.array([why != IMPROPER for why in r.reasons])

    def error(keep):
        k = np.isin(src, keep)
        sub = r.__class__(np.concatenate([r.poles[other], poles[k]]),
                          np.concatenate([r.residues[other], D[k]]),
                          sensors=nm.sensors, actuators=nm.actuators)
        return logls(step5.replace(residual=sub).frf(frf.freq, quantity=frf.quantity).H, frf.H)

    e_id = logls(cm.frf(frf.freq, quantity=frf.quantity).H, frf.H)
    e_all, e_none, e_one = error(blades), error(()), error((src[np.argmax(z)],))
    assert e_all <= 1.1 * e_id                                      # measured 0.0310 / 0.0299
    assert e_none > 5 * e_all                                       # measured 0.339
    assert e_one > e_none                                           # measured 0.997
    # every part of the group kept: step 6 refits nothing, the model is step 5's
    assert np.abs(nm.phib - step5.phib).max() <= 1e-6 * np.abs(nm.phib).max()


def test_close_pair_rows_of_phib_refitted_to_the_frf():
    """The truss at 1%: its close pair (15.79/15.87 Hz) nearly cancels in the transfers
    between N33.x and N41.y; its improper parts are not kept (0.5, 1.0 sigma, summed 2.1), and
    step 6 refits the pair's rows of phib to the identified FRF relative to its level -- those
    two rows only -- bringing the model within the acceptance bound."""
    # the mechanism as shown on the unweighted fit (weighting="none"); the default (auto)
    # keeps the level-weighted fit here, whose residues differ within their noise
    frf, cm, nm = _chain("truss", 0.01, "none")
    sel = nm.properness.poles_used
    Xs, Ys = modal_factors(nm, cm.poles[sel])
    step5 = nm.replace(phib=phib_from_residues(cm.residues[sel], Xs, Ys))
    changed = np.flatnonzero(np.abs(nm.phib - step5.phib).max(axis=1)
                             > 1e-6 * np.abs(step5.phib).max())
    f = np.sqrt(np.diag(nm.Omega)) / (2 * np.pi)
    # the pair's normal modes (15.6 and 16.0 Hz undamped: its damping is non-proportional)
    assert changed.size == 2 and np.all(np.abs(f[changed] - 15.8) < 0.3)
    H = frf.H
    e5 = logls(step5.frf(frf.freq, quantity=frf.quantity).H, H)       # measured 0.0183
    e6 = logls(nm.frf(frf.freq, quantity=frf.quantity).H, H)          # measured 0.0089
    e_id = logls(cm.frf(frf.freq, quantity=frf.quantity).H, H)        # 0.0057
    assert e6 < 0.6 * e5 and e6 <= 3 * e_id < e5
    # the collocation of the other modes (what hybrids build on) is step 5's
    keep = np.setdiff1d(np.arange(nm.n), changed)
    assert np.array_equal(nm.phib[keep], step5.phib[keep]) or np.allclose(
        nm.phib[keep], step5.phib[keep], rtol=0, atol=1e-9 * np.abs(step5.phib).max())


def test_close_groups_closed_form():
    """gamma = 1/sqrt(1 + (dw / 2s)^2) for equal damping: linked below dw = 2 sqrt(3) s."""
    s = 0.3
    for dw, linked in ((2 * np.sqrt(3) * s * 0.99, True), (2 * np.sqrt(3) * s * 1.01, False)):
        lam = np.array([-s + 100j, -s + (100 + dw) * 1j, -s + 200j])
        assert close_groups(lam).tolist() == ([0, 0, 2] if linked else [0, 1, 2])
    # chains: a-b and b-c close, a-c not, one group; input order does not matter
    lam = np.array([-s + 100.9j, -s + 100j, -s + 200j, -s + 101.8j])
    assert close_groups(lam).tolist() == [0, 0, 2, 0]


@pytest.mark.parametrize("name", ["cluster", "truss"])
def test_summed_residue_std_against_each_modes(name):
    """A group of one is the mode's own standard deviation (3.58); a pair's lies between the
    difference and the sum of its two (the covariance enters with its sign)."""
    frf, cm, nm = _chain(name, 0.01)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        std = cm.residue_std()
    shape = np.shape(cm.residues)
    for j in range(3):
        one = summed_residue_std(cm.statistics, [j], shape)
        assert np.allclose(one, np.abs(std[j]), rtol=1e-9, atol=0)
    sel = nm.properness.poles_used
    g = close_groups(cm.poles[sel])
    pair = sel[g == g[np.flatnonzero(g != np.arange(g.size))[0]]][:2]   # two close modes
    two = summed_residue_std(cm.statistics, pair, shape)
    a, b = np.abs(std[pair[0]]), np.abs(std[pair[1]])
    tol = 1e-9 * (a + b)
    # the real and imaginary parts combine separately: bound by sqrt of the parts' bounds
    assert np.all(two <= a + b + tol)
    indep = np.sqrt(a**2 + b**2)                              # were they independent
    assert np.any(np.abs(two - indep) > 0.1 * indep)          # they are not: covariances count


#: the improper parts the logLS rule keeps at 1% (:mod:`sdctrl.identification._part_selection`;
#: their norms are within three standard deviations of the residue, z = 0.5-1.6, but their
#: entries are not): the normal modes' logLS against the identified model before -> after,
#: and the identified model's own against the data (the target), seed 1
LOGLS_RULE = {"truss": ([43.8], 0.00604, 0.00523, 0.00571),
              "truss_high": ([27.6, 43.8], 0.00189, 0.00045, 0.00052)}


@pytest.mark.parametrize("name", sorted(LOGLS_RULE))
def test_noise_level_improper_parts_are_kept_only_where_the_logls_rule_needs_them(name):
    """The norm test keeps no part at 1% (within three standard deviations), the logLS rule
    the fewest that bring the normal modes as close to the identified model as it is to the
    data: without the last one they are farther."""
    # the mechanism as shown on the unweighted fit (weighting="none"); the default (auto)
    # keeps the level-weighted fit here, whose residues differ within their noise
    frf, cm, nm = _chain(name, 0.01, "none")
    freqs, before, after, target = LOGLS_RULE[name]
    old = sd.normal_modes(cm.replace(search=replace(cm.search, logls=None)), std=False)
    assert old.residual.reasons == (OUT_OF_BAND,) * old.residual.m      # the norm test alone
    src, _, _ = _improper(nm)
    assert sorted(np.round(cm.frequency[src], 1).tolist()) == freqs
    lines = np.linspace(*cm.band, cm.search.lines)
    ref = cm.frf(lines).H
    assert cm.search.logls == pytest.approx(target, abs=5e-6)
    assert logls(old.frf(lines).H, ref) == pytest.approx(before, abs=5e-6)
    assert logls(nm.frf(lines).H, ref) == pytest.approx(after, abs=5e-6)
    assert after <= target < before
    # minimal: without any one of its kept parts the model is farther than the target
    r = nm.residual
    for k in np.flatnonzero([why == IMPROPER for why in r.reasons]):
        keep = np.arange(r.m) != k
        short = nm.replace(residual=r.__class__(r.poles[keep], r.residues[keep],
                                                sensors=nm.sensors, actuators=nm.actuators))
        assert logls(short.frf(lines).H, ref) > target


def test_the_fit_records_its_logls_against_the_data():
    """``cm.search.logls`` is the mean logLS (3.12) of the model against its lines."""
    frf, cm, _ = _chain("truss", 0.01)
    H = cm.frf(frf.freq, quantity=frf.quantity).H
    assert cm.search.logls == pytest.approx(logls(H, frf.H), rel=1e-12)


def test_no_residual_pole_no_improper_part():
    """The rule's first condition: without poles kept as residual dynamics (nothing outside
    the normal-mode set the in-band modes could couple to) the improper parts are
    identification error and none is kept -- the noise-free ladder's, kept with its
    out-of-band poles, are dropped when no pole is residual; a pole residual for another
    reason than being out of band (its properness failed) counts as one."""
    frf, cm, nm = _chain("ladder", 0.0)
    sel = nm.properness.poles_used
    oob = {int(j): OUT_OF_BAND for j in np.flatnonzero(~np.asarray(cm.in_band))}
    idx0, D0 = improper_terms(cm, nm, sel, oob)
    assert idx0.size > 0
    idx, D = improper_terms(cm, nm, sel, {})
    assert idx.size == 0 and D.shape == (0, cm.ns, cm.na)
    idx, D = improper_terms(cm, nm, sel, {j: "another reason" for j in oob})
    assert np.array_equal(idx, idx0) and np.array_equal(D, D0)


@pytest.fixture(scope="module")
def cluster_8_30():
    """The cluster tested over 8-30 Hz (a band of no test of the family; its hub mode at
    36.98 Hz just above it), 1% noise, seed 1."""
    st = sd.testbeds.structure("cluster")
    frf = st.frf(n=400, noise=0.01, seed=1, band=(8.0, 30.0))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        # unweighted: the case (no out-of-band pole, a blade mode left residual) is that of
        # the unweighted fit; the level-weighted one finds two poles out of band
        cm = sd.identify(frf, progress=False, weighting="none")
        nm = sd.normal_modes(cm, std=False)
    return frf, cm, nm


def test_a_pole_left_residual_in_band_keeps_the_improper_parts(cluster_8_30):
    """No out-of-band pole found and the 10.29 Hz blade mode left residual (the identified
    mass is not positive definite with it): the parts were keyed on out-of-band poles, none
    was kept and the normal modes missed the data by 11.7x the identified model's logLS
    (1.16 against 0.099, seed 1; seeds 2/3 unchanged, 1.00x and 2.25x); now 1.00x."""
    frf, cm, nm = cluster_8_30
    assert not np.any(~np.asarray(cm.in_band))                    # no out-of-band pole
    reasons = nm.residual.reasons
    assert sum(why.startswith("properness cannot be enforced") for why in reasons) == 1
    assert sum(why == IMPROPER for why in reasons) >= 1
    q = frf.quantity
    e_cm = logls(cm.frf(frf.freq, quantity=q).H, frf.H)
    e_nm = logls(nm.frf(frf.freq, quantity=q).H, frf.H)
    print(f"\ncluster 8-30 Hz 1%: identified {e_cm:.4f}, normal modes {e_nm:.4f}")
    assert e_nm <= 1.01 * e_cm                                      # 0.0989 / 0.0989


def test_no_statistics_no_improper_part():
    frf, cm, nm = _chain("ladder", 0.0)
    bare = cm.replace(statistics=None)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        nm0 = sd.normal_modes(bare, std=False)
    assert nm0.residual.reasons == (OUT_OF_BAND,) * nm0.residual.m
    # the normal modes themselves are the same with or without the kept parts (but the rows
    # of phib of close modes whose parts are not kept, refitted to the FRF, step 6)
    assert np.array_equal(nm0.Omega, nm.Omega) and np.array_equal(nm0.cphi, nm.cphi)
    assert np.array_equal(nm0.Gamma, nm.Gamma)


def test_statespace_realises_the_improper_parts():
    frf, cm, nm = _chain("plate", 0.01)
    src, _, _ = _improper(nm)
    assert np.round(cm.frequency[src], 1).tolist() == [28.3, 59.6]     # 59.6: the logLS rule
    f = frf.freq
    G = nm.to_statespace(omega_c=1e3 * 2 * np.pi * f.max(), rigid_body=True)
    H = nm.frf(f).H
    Hs = np.moveaxis(G(2j * np.pi * f), -1, 0)
    assert np.abs(Hs - H).max() <= 1e-9 * np.abs(H).max()
