"""Simulated roving-hammer surveys over the family of test structures (issue 26).

Each member is surveyed as a real modal test is: 3 fixed accelerometers, 40-60 hit points
spread over the structure, one of them at an accelerometer (the single driving point), three
hammer hits per point through ``sd.impact_frf`` (force window, exponential window), 1% noise
that rises near antiresonances and toward the band ends, data from the first line (0 Hz) so
the suspension modes lie in the data below the band (``sd.testbeds.survey``).  Checked
against the exact complex modes of each true structure:

- identification finds every in-band mode, MAC > 0.9 to the truth at the hit points;
- damping corrected for the exponential window within 5% of the truth, the uncorrected one
  off by more;
- the normal-mode model from the single driving point reproduces the survey (mean logLS)
  within 3x the identified model's.

Each member's figures are locked (measured values in comments).
"""

import warnings
from functools import lru_cache

import numpy as np
import pytest

import sdctrl as sd
from sdctrl.identification._complex_modes import frf_array
from sdctrl.updating import logls

FAMILY = sd.testbeds.family()
#: lines from 0 to the band's top: 1600 (0.125 Hz lines to 200 Hz, as the issue's survey);
#: the cluster's four blade modes lie 0.07 Hz apart and need 0.011 Hz lines, as a test
#: engineer would choose from a pre-test analysis
LINES = {"cluster": 4000}


#: the fit-quality warnings ``identify`` gave on each member's survey (filled by _surveyed)
FIT_WARNINGS = {}


@lru_cache(maxsize=None)
def _surveyed(name: str):
    sv = sd.testbeds.survey(name, noise=0.01, seed=1, lines=LINES.get(name, 1600))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        cm = sd.identify(sv.frf, band=sv.band, progress=False)
    FIT_WARNINGS[name] = [str(w.message) for w in caught if "relative fit error" in
                          str(w.message)]
    return sv, cm


def _match(cm, sv) -> np.ndarray:
    """Index of the identified pole nearest each true in-band pole."""
    return np.array([int(np.argmin(np.abs(cm.poles - p))) for p in sv.poles])


def _mac(a, b) -> float:
    return float(np.abs(np.vdot(a, b)) ** 2 / (np.vdot(a, a).real * np.vdot(b, b).real))


def _as_measured(model, sv) -> np.ndarray:
    """The model's accelerance in the band as the survey measured it, through the exponential
    window: ``A(s) = s^2 H(s)`` at ``s = j w + 1/tau`` (the FRF of ``a(t) exp(-t/tau)``), ``H``
    the displacement FRF of the complex-mode model (3.7) or of the normal-mode model (2.15),
    both with their ``E + F/s^2`` terms and the normal-mode model's residual dynamics."""
    f = sv.frf.band(*sv.band)
    s = 2j * np.pi * f.freq + 1 / f.exponential_tau
    if isinstance(model, sd.ComplexModeModel):
        E = np.zeros(f.H.shape[1:]) if model.E is None else model.E
        H = frf_array(model.poles, model.residues, E, model.F, s)
    else:
        n = model.Omega.shape[0]
        Z = model.Omega[None] + s[:, None, None] * model.Gamma[None] + \
            (s**2)[:, None, None] * np.eye(n)[None]
        H = model.cphi[None] @ np.linalg.solve(Z, np.broadcast_to(model.phib, (s.size,
                                                                              *model.phib.shape)))
        H = H if model.E is None else H + model.E[None]
        H = H if model.F is None else H + model.F[None] / (s**2)[:, None, None]
        if model.residual is not None:          # out-of-band poles kept as identified (3.7)
            r = model.residual
            H = H + frf_array(r.poles, r.residues, np.zeros(f.H.shape[1:]), None, s)
    return H * (s**2)[:, None, None]


def test_survey_is_a_roving_hammer_test():
    sv = sd.testbeds.survey("plate", noise=0.0, averages=1, lines=400, seed=3)
    frf, (lo, hi) = sv.frf, sv.band
    assert frf.quantity == "acceleration" and len(frf.sensors) == 3
    assert 40 <= len(frf.actuators) <= 80 and len(set(frf.actuators)) == len(frf.actuators)
    # one hit point at an accelerometer: the single driving point, collocated by its label
    assert set(frf.sensors) & set(frf.actuators) == {sv.driving_point}
    assert frf.collocated == ((0, frf.actuators.index(sv.driving_point)),)
    # data from the first line to 2 fmax: the 2.7 and 6.9 Hz modes below the band are in it
    assert frf.freq[0] == pytest.approx(hi / 400) and frf.freq[-1] == pytest.approx(2 * hi)
    assert frf.exponential_tau == pytest.approx((1600 - 1) / (4 * hi) / np.log(100))
    # noise-free: H1 is the exact windowed accelerance s^2 c (K + s C + s^2 M)^-1 b at
    # s = j w + 1/tau, solved on the FE matrices (independent of the modal sum over the
    # 2N complex modes: measured 1.1e-5 of the line's largest entry, the eigensolver's
    # round-off on the stiff rotational modes)
    fe = sd.testbeds.structure("plate").fe()
    M, K, C = (x.toarray() for x in (fe.M, fe.K, fe.C))
    dofs = list(fe.dofs)
    ci = [dofs.index(d) for d in frf.sensors]
    bi = [dofs.index(d) for d in frf.actuators]
    for k in (10, 140, 333):
        s = 2j * np.pi * frf.freq[k] + 1 / frf.exponential_tau
        X = np.linalg.solve(K + s * C + s**2 * M, np.eye(len(dofs))[:, bi])
        A = s**2 * X[ci]
        assert np.abs(frf.H[k] - A).max() < 1e-4 * np.abs(A).max()
    # the truth it carries: every in-band mode, complex shapes at the hit points
    f = np.abs(sv.poles) / (2 * np.pi)
    assert np.all((f > lo) & (f < hi)) and sv.shapes.shape == (len(frf.actuators), f.size)
    np.testing.assert_allclose(f, [26.32, 28.25, 45.26, 49.55, 59.64], atol=0.01)


def test_survey_noise_varies_by_line():
    exact = sd.testbeds.survey("ladder", noise=0.0, seed=2, lines=800)
    noisy = sd.testbeds.survey("ladder", noise=0.01, seed=2, lines=800)
    assert noisy.frf.actuators == exact.frf.actuators       # same plan, same pulses
    H, H0 = noisy.frf.H, exact.frf.H
    rel = np.abs(H - H0) / np.abs(H0)
    size = np.abs(H0) / np.median(np.abs(H0), axis=(0, 2), keepdims=True)
    band = (exact.frf.freq > exact.band[0]) & (exact.frf.freq < exact.band[1])
    mid = np.median(rel[band][(size[band] > 0.5) & (size[band] < 2)])
    low = np.median(rel[band][size[band] < 0.05])           # near antiresonances
    peak = np.median(rel[band][size[band] > 20])            # at resonances
    top = np.median(rel[exact.frf.freq > 1.8 * exact.band[1]])
    lo, hi = exact.band
    f = exact.frf.freq
    first = np.median(rel[(f > lo) & (f < lo + 0.1 * (hi - lo))])
    below = np.median(rel[f < lo / 2])                      # small accelerance
    # measured: 0.55% at the median level (three hits averaged), 10% near antiresonances,
    # 0.03% at resonances, 1.7% near 2 fmax where the hammer's force falls, 3.0% in the
    # band's first tenth and 7% below half its lower end
    assert 0.003 < mid < 0.01
    assert low > 10 * mid and peak < mid / 5 and top > 2 * mid
    assert first > 3 * mid and below > 5 * mid
    assert np.all(noisy.frf.coherence <= 1) and noisy.frf.coherence[band].min() < 0.5


@pytest.mark.parametrize("name", FAMILY)
def test_identification_finds_every_mode(name):
    sv, cm = _surveyed(name)
    j = _match(cm, sv)
    assert len(set(j)) == sv.poles.size and np.all(cm.in_band[j])
    np.testing.assert_allclose(np.abs(cm.poles[j]), np.abs(sv.poles), rtol=2e-4)
    # shape at the hit points: the residue's dominant right factor (R = c psi psi^T b)
    mac = [_mac(np.linalg.svd(cm.residues[i])[2][0], sv.shapes[:, k]) for k, i in enumerate(j)]
    # measured: every MAC >= 0.9999; fit error (cost) 0.15% truss and truss_high, 0.11%
    # ladder, 0.072% plate, 0.39% cluster (ladder 0.43% and plate 0.89% before the windowed
    # rules tried a side again once the pole set changed)
    assert min(mac) > 0.99, mac
    assert cm.cost < 0.02
    # no spurious in-band mode
    assert cm.in_band.sum() == sv.poles.size


@pytest.mark.parametrize("name", FAMILY)
def test_damping_corrected_for_the_window(name):
    sv, cm = _surveyed(name)
    j = _match(cm, sv)
    zeta = -sv.poles.real / np.abs(sv.poles)
    err = np.abs(cm.damping[j] / zeta - 1)
    # the data's poles are the structure's shifted by -1/tau: uncorrected damping
    raw = cm.poles[j] - 1 / cm.exponential_tau
    raw_err = np.abs(-raw.real / np.abs(raw) / zeta - 1)
    # measured: corrected within 0.36% (ladder's 86 Hz mode) and 0.08% elsewhere; the
    # uncorrected damping 3.3% (ladder, 78 Hz, zeta 1.6%) to 142% (truss, 9.5 Hz) off
    assert err.max() < 0.01, err
    assert np.all(raw_err > 5 * err) and raw_err.max() > 0.25, raw_err


def _normal_modes(cm, modes=None):
    """``sd.normal_modes`` on the survey's model, saying it transposed the test when it has
    more modes than sensors.  The
    statistics are dropped first: with them ``normal_modes`` of a transposed survey fails
    (``std['cphi'] must be ... of shape (3, n), got shape (n_hits, n)``: the statistics are
    not transposed back, sdctrl/identification, reported)."""
    from dataclasses import replace

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        nm = sd.normal_modes(replace(cm, statistics=None), modes=modes)
    said = " ".join(str(w.message) for w in caught)
    inb = np.asarray(cm.in_band, bool)
    n = (int(inb.sum()) if inb.any() and not inb.all() else cm.n) if modes is None else len(modes)
    assert ("roving-hammer survey" in said and "transposed test" in said) == (n > cm.ns)
    return nm


#: members whose every identified mode is made proper from the single driving point
PROPER = ("truss", "ladder", "plate")


@pytest.mark.parametrize("name", PROPER)
def test_normal_modes_from_the_single_driving_point(name):
    sv, cm = _surveyed(name)
    f = sv.frf.band(*sv.band)
    nm = _normal_modes(cm)
    # the in-band poles become normal modes, the out-of-band ones stay residual dynamics
    n = int(np.sum(cm.in_band))
    assert nm.cphi.shape == (3, n) and nm.phib.shape == (n, len(f.actuators))
    kept = np.concatenate([nm.poles, [] if nm.residual is None else nm.residual.poles])
    np.testing.assert_allclose(np.sort_complex(kept), np.sort_complex(cm.poles), rtol=1e-6)
    ident = logls(_as_measured(cm, sv), f.H)
    normal = logls(_as_measured(nm, sv), f.H)
    # measured (logLS identified, normal, ratio; one BLAS thread): truss 0.0549, 0.0601,
    # 1.09; ladder 0.0187, 0.0213, 1.14 (before its 9.1 Hz pole below the band: 0.0354,
    # 0.0419); plate 0.0518, 0.0552, 1.07 (before its 18.7 Hz pole: 0.106, 0.118)
    assert normal <= 1.4 * ident, (normal, ident)


@pytest.mark.parametrize("name", sorted(set(FAMILY) - set(PROPER)))
def test_normal_modes_with_complex_residual_dynamics(name):
    """Where a mode cannot be made proper from the one driving point, the others become
    normal modes and it stays a complex mode (residual dynamics).  truss_high: the pole
    fitted below the band absorbs six modes (9.5-18.6 Hz); made proper with the others it
    moves the residues by 39% (``properness.residue_error``) and the model's logLS is 92x
    the identified one's.  cluster: the local resonator (37 Hz) moves at 0.1% of its
    largest amplitude at the best DOF of the structure, its driving-point residue was noise
    and every set holding it failed (3.45: mass not positive definite) -- until a434751,
    whose fit keeps a pole above the band and makes it proper alone too.  Kept as normal
    modes: the in-band modes that can be made proper one by one."""
    sv, cm = _surveyed(name)
    f = sv.frf.band(*sv.band)
    keep = np.zeros(cm.n, bool)
    for j in np.flatnonzero(cm.in_band):
        try:
            _normal_modes(cm, modes=[j])
            keep[j] = True
        except ValueError as exc:                # named, with the thesis's equation
            assert "(3.45" in str(exc) or "(3.52" in str(exc), exc
    # measured: truss_high keeps its six in-band modes; the cluster all five since a434751
    # (before: all but the resonator, 36.978 Hz; its fit now keeps a pole above the band,
    # 71.26 Hz, and the resonator's residues are made proper alone)
    assert np.abs(cm.frequency[cm.in_band & ~keep]).tolist() == pytest.approx(
        {"truss_high": [], "cluster": []}[name], abs=0.01)
    nm = _normal_modes(cm, modes=np.flatnonzero(keep))
    # measured: 0.0017, 0.0035 (one BLAS thread, as the suite runs); the cluster 0.0108 with
    # two: its four blade modes 0.07 Hz apart make the properness fit sensitive to round-off
    assert nm.properness.residue_error < 0.015
    rest = ~keep
    z = 2j * np.pi * f.freq + 1 / f.exponential_tau
    residual = frf_array(cm.poles[rest], cm.residues[rest], np.zeros(f.H.shape[1:]), None, z)
    model = _as_measured(nm, sv) + residual * (z**2)[:, None, None]
    ident = logls(_as_measured(cm, sv), f.H)
    mixed = logls(model, f.H)
    # measured: truss_high 0.00227, 0.00236 (1.04x); cluster 0.580, 0.682 (1.18x)
    assert mixed <= 1.4 * ident, (mixed, ident)


def test_cli_identify_on_a_survey_file(tmp_path, capsys):
    """``sdctrl identify`` on a survey written to UFF: exit 0, no traceback in the report,
    the normal-modes step's status stated (ok, or failed with its reason)."""
    import json

    from sdctrl.cli import main

    sv = sd.testbeds.survey("plate", noise=0.01, seed=4, lines=800)
    path = tmp_path / "survey.uff"
    sd.write_uff(sv.frf, str(path))
    out = tmp_path / "out"
    rc = main(["identify", str(path), "--band", *map(str, sv.band), "--out", str(out),
               "--quiet"])
    assert rc == 0
    assert capsys.readouterr().err == ""
    report = {ext: (out / f"report.{ext}").read_text(encoding="utf-8") for ext in ("md", "html")}
    for text in report.values():
        assert "Traceback" not in text and 'File "' not in text
    steps = json.loads((out / "summary.json").read_text())["steps"]
    assert steps["identification"]["status"] == "ok"
    nm = steps["normal_modes"]
    assert nm["status"] in ("ok", "failed") and (nm["status"] == "ok" or nm["message"])
    section = report["md"].split("## Normal modes", 1)[1]
    assert ("failed" in section) == (nm["status"] == "failed")
    # the identified model saved next to the report has every in-band mode
    cm = sd.load(str(out / "identified.npz"))
    f = cm.frequency[cm.in_band]
    assert f.size == sv.poles.size
    np.testing.assert_allclose(np.sort(f), np.abs(sv.poles) / (2 * np.pi), rtol=2e-4)


def test_survey_bad_input_named():
    with pytest.raises(ValueError, match="structure must be a TestStructure or one of"):
        sd.testbeds.survey("bridge")
    with pytest.raises(ValueError, match="structure must be"):
        sd.testbeds.survey(["plate"])
    with pytest.raises(ValueError, match="noise"):
        sd.testbeds.survey("plate", noise=-0.01)
    with pytest.raises(ValueError, match="band must hold at least one mode"):
        sd.testbeds.survey("plate", band=(30.0, 40.0))
    with pytest.raises(ValueError, match="n_hits"):
        sd.testbeds.survey("plate", n_hits=500)
    with pytest.raises(ValueError, match="sensors"):
        sd.testbeds.survey("plate", sensors=0)
    with pytest.raises(ValueError, match="lines"):
        sd.testbeds.survey("plate", lines=4)
    # the same seed gives the same survey; another seed other noise, the same plan
    a, b = (sd.testbeds.survey("plate", lines=200, seed=5) for _ in range(2))
    c = sd.testbeds.survey("plate", lines=200, seed=6)
    assert np.array_equal(a.frf.H, b.frf.H) and not np.array_equal(a.frf.H, c.frf.H)
    assert a.frf.actuators == c.frf.actuators and a.frf.sensors == c.frf.sensors


def test_survey_drift_shifts_the_poles_between_hit_points():
    """``drift=``: hit point ``a`` sees the structure with stiffness ``(1 + d)^2 K`` and
    damping ``(1 + d) C``, ``d`` from ``-drift`` (first hit point) to ``+drift`` (last):
    noise-free, its column is the exact windowed accelerance of those matrices, solved on the
    FE model (independent of the modal sum), and not that of the structure itself."""
    drift = 0.003
    sv = sd.testbeds.survey("plate", noise=0.0, averages=1, lines=400, seed=3, drift=drift)
    frf = sv.frf
    fe = sd.testbeds.structure("plate").fe()
    M, K, C = (x.toarray() for x in (fe.M, fe.K, fe.C))
    dofs = list(fe.dofs)
    ci = [dofs.index(x) for x in frf.sensors]
    na = len(frf.actuators)
    for k in (10, 169, 291):                      # 1.7 Hz, the 26.3 and 45.3 Hz peaks
        s = 2j * np.pi * frf.freq[k] + 1 / frf.exponential_tau
        A, A0 = np.zeros((2, len(ci), na), complex)
        for a, x in enumerate(frf.actuators):
            d = drift * (2 * a / (na - 1) - 1)
            e = np.eye(len(dofs))[:, dofs.index(x)]
            A[:, a] = s**2 * np.linalg.solve((1 + d) ** 2 * K + s * (1 + d) * C + s**2 * M,
                                             e)[ci]
            A0[:, a] = s**2 * np.linalg.solve(K + s * C + s**2 * M, e)[ci]
        # measured: 3e-6, 2.5e-6, 1.6e-5 of the line's largest entry (round-off, as in the
        # test above); the undrifted structure 0.35% (below the band, quasi-static: 0.8%
        # with the mirror layout of sensors the eigenvectors' rounding chose on another
        # machine), 30% and 55% off
        off = np.abs(frf.H[k] - A0).max() / np.abs(A).max()
        print(f"\nline {k}: drifted / undrifted {off:.3g}")
        assert np.abs(frf.H[k] - A).max() < 1e-4 * np.abs(A).max()
        assert off > (1e-3 if k == 10 else 5e-3)
    with pytest.raises(ValueError, match="drift"):
        sd.testbeds.survey("plate", drift=-0.001)
    with pytest.raises(ValueError, match="drift"):
        sd.testbeds.survey("plate", drift=0.2)


@pytest.mark.parametrize("name", FAMILY)
def test_no_drift_warning_on_a_steady_survey(name):
    """True close modes (the truss's pair, the cluster's blades 0.002 Hz apart with one shape
    at the three accelerometers) are not taken for a drifting mode."""
    from sdctrl.identification._quality import drift_multiplets

    _, cm = _surveyed(name)
    assert drift_multiplets(cm) == []


def test_drift_between_hit_points_is_said():
    """A survey whose frequencies drift by +-0.2% from the first hit point to the last (as
    temperature does in a real test): the one-pole-set model (3.7) splits each of the plate's
    five modes into a multiplet of poles; ``identify`` says so, with the multiplets, the
    drift's size and what to try, instead of presenting 20 modes."""
    sv = sd.testbeds.survey("plate", noise=0.01, seed=1, lines=1600, drift=0.002)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        cm = sd.identify(sv.frf, band=sv.band, progress=False)
    said = [str(w.message) for w in caught if "multiplets" in str(w.message)]
    assert len(said) == 1, [str(w.message) for w in caught]
    # measured: 20 poles in the band, 5 multiplets (one per true mode), spread 0.27%
    assert cm.in_band.sum() > sv.poles.size
    assert "5 multiplets" in said[0] and "about 5 modes" in said[0]
    assert "drift between actuators (hit points)" in said[0] and "poles=" in said[0]
    spread = float(said[0].split("spread ")[1].split("%")[0]) / 100
    assert 0.001 < spread < 0.004


def test_a_mode_just_below_the_band_of_a_survey_is_fitted():
    """The plate survey's fit error (3.11) within 2x of the fit with the structure's mode
    just below the band given as a starting pole.

    Before: 0.0089 against 0.00072 (68% of the error at 20-22 Hz).  The windowed rules
    (``_rules.WINDOWED``) try one pole per side; the side below was tried before the mode
    above the band (64.7 Hz) was fitted, its trial pole absorbed that mode's tail, slid to
    the far bound (5 Hz) and was rejected, and the side was not tried again since the
    in-band poles had not changed.  A side is now tried again once the pole set has changed
    (as with independent noise): 18.72 Hz is found, 0.00072; the ladder's survey 0.0043 ->
    0.0011 likewise (a 9.1 Hz pole below its band); the other members' surveys unchanged."""
    sv, cm = _surveyed("plate")
    f, _ = sd.testbeds.structure("plate").fe().modes(30)
    below = float(f[f < sv.band[0]].max())                               # 18.76 Hz
    other = (cm.frequency > sv.band[0])                                  # all but the pole below
    w0 = 2 * np.pi * np.append(cm.frequency[other], below)
    z0 = np.append(cm.damping[other], 0.002)
    given = w0 * (-z0 + 1j * np.sqrt(1 - z0**2))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ref = sd.identify(sv.frf, poles=given, band=sv.band, progress=False)
    assert abs(below - 18.76) < 0.01 and ref.cost < 0.002                # 0.00072
    low = cm.frequency[~cm.in_band & (cm.frequency < sv.band[0])]
    assert low.size == 1 and abs(low[0] - below) < 0.1                  # 18.72 Hz
    assert cm.cost <= 2 * ref.cost                                       # 0.00072


#: fit error over the error the survey's noise alone leaves (coherence, 3.59), measured:
#: the modes just outside the band that the one-pole-per-side windowed rules leave (the
#: plate's above 62 Hz and below 18.7 Hz at its edges, the cluster's on both sides: no
#: out-of-band pole is kept there)
#: the cluster 46.5 -> 2.91 since the automatic selection no longer rescans a pole set it
#: already scanned (a434751; its windowed survey is fitted unweighted either way): it now
#: keeps a pole above the band (71.26 Hz) for the tail at the band's top edge, the five
#: modes' poles within 2e-5 of the truth (before 3.2e-5); below FLOOR_WARN, so silent
FLOOR_RATIO = {"truss": 1.25, "truss_high": 1.41, "ladder": 2.34, "plate": 5.61,
               "cluster": 2.91}


@pytest.mark.parametrize("name", FAMILY)
def test_fit_above_the_noise_floor_is_said(name):
    """issue 26, honest quality: ``identify`` warns when its fit error exceeds
    ``FLOOR_WARN`` (3) times the error the data's noise alone would leave, from the
    coherence (3.59), saying how many times, where and what to try; silent below."""
    from sdctrl.identification._quality import FLOOR_WARN, coherence_floor

    sv, cm = _surveyed(name)
    ratio = cm.cost / coherence_floor(sv.frf.band(*sv.band))
    assert ratio == pytest.approx(FLOOR_RATIO[name], rel=0.05)
    said = FIT_WARNINGS[name]
    assert len(said) == int(ratio > FLOOR_WARN)
    if said:
        assert f"{ratio:.1f} times the" in said[0] and "noise alone" in said[0]
        assert "the band leaves its tail at the edge" in said[0]
    # (the cluster, at 46.5 before, was said with the band's two edges, 6.008- and -45 Hz,
    # carrying most of it; now silent, the len(said) check above)


#: the floor from the residual's second differences over the coherence's, measured on the
#: surveys read without their coherence, window not recorded / recorded
DIFFERENCE_FLOOR = {"truss": (0.97, 1.02), "truss_high": (0.90, 1.00), "ladder": (0.95, 1.01),
                    "plate": (0.73, 0.90)}


@pytest.mark.parametrize("window", [False, True])
@pytest.mark.parametrize("name", list(DIFFERENCE_FLOOR))
def test_fit_above_the_noise_floor_is_said_without_coherence(name, window):
    """The same surveys read from a file without their coherence, window recorded or not: the
    floor is the residual's second differences over the gain of noise correlated by the
    window (the recorded one, or the one of the decay the selection measured), within 5% of
    its measured ratio to the coherence's floor (0.73-1.02).  Without the correlation the
    differences over two lines were 2.7-3 times those over one and no floor was taken: the
    plate's fit error 5.5 times its noise floor was not said.  Said on the plate (7.5 and 6.2
    times), silent on the others (1.25-2.34)."""
    from sdctrl.identification._quality import FLOOR_WARN, coherence_floor, difference_floor

    sv = sd.testbeds.survey(name, noise=0.01, seed=1, lines=1600)
    f = sv.frf
    frf = sd.FRF(f.freq, f.H, quantity=f.quantity, sensors=f.sensors, actuators=f.actuators,
                 collocated=f.collocated, averages=f.averages,
                 exponential_tau=f.exponential_tau if window else None)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        cm = sd.identify(frf, band=sv.band, progress=False)
    said = [str(w.message) for w in caught if "relative fit error" in str(w.message)]
    data = frf.band(*sv.band)
    windowed = cm if not window else cm.replace(poles=cm.poles - 1.0 / cm.exponential_tau,
                                                 exponential_tau=None)
    R = data.H - windowed.frf(data.freq, quantity=data.quantity).H
    from sdctrl.identification._line_correlation import noise_correlation
    floor = difference_floor(R, data.H, noise_correlation(cm, data))
    assert difference_floor(R, data.H) is None                    # independent lines: none
    ratio = floor / coherence_floor(f.band(*sv.band))
    assert ratio == pytest.approx(DIFFERENCE_FLOOR[name][window], rel=0.05)
    assert len(said) == int(cm.cost > FLOOR_WARN * floor)
    assert len(said) == (name == "plate")
    if said:
        assert f"{cm.cost / floor:.1f} times the" in said[0]
        assert "for lines correlated by the window" in said[0]


@pytest.mark.parametrize("name", ["plate", "ladder"])
def test_coherence_floor_is_the_noise_of_the_survey(name):
    """The floor is what the noise does: the survey's FRF against the same survey without
    noise (the same hits), relative error, over ``coherence_floor`` -- measured 1.07 (plate)
    and 1.05 (ladder)."""
    from sdctrl.identification._quality import coherence_floor

    a = sd.testbeds.survey(name, noise=0.01, seed=1, lines=800)
    b = sd.testbeds.survey(name, noise=0.0, seed=1, lines=800)
    fa, fb = a.frf.band(*a.band), b.frf.band(*b.band)
    realised = np.linalg.norm(fa.H - fb.H) / np.linalg.norm(fa.H)
    assert 0.9 < realised / coherence_floor(fa) < 1.2


def test_coherence_floor_closed_form():
    """``sqrt(sum |H|^2 (1 - g) / (n_d - 1) / sum |H|^2)``; None without a coherence below 1."""
    from sdctrl.identification._quality import coherence_floor

    rng = np.random.default_rng(0)
    H = rng.standard_normal((50, 2, 3)) + 1j * rng.standard_normal((50, 2, 3))
    freq = np.linspace(1.0, 50.0, 50)
    g = np.full(H.shape, 0.99)
    f = sd.FRF(freq, H, coherence=g, averages=5)
    assert coherence_floor(f) == pytest.approx(np.sqrt(0.01 / 4), rel=1e-12)
    g2 = g.copy()
    g2[:25] = 0.96                               # weighted by |H|^2
    w = np.abs(H) ** 2
    want = np.sqrt(np.sum(w * (1 - g2)) / 4 / w.sum())
    assert coherence_floor(sd.FRF(freq, H, coherence=g2, averages=5)) == pytest.approx(want)
    assert coherence_floor(sd.FRF(freq, H, coherence=g)) == pytest.approx(0.1)   # n_d unknown
    assert coherence_floor(sd.FRF(freq, H)) is None
    assert coherence_floor(sd.FRF(freq, H, coherence=np.ones(H.shape))) is None


@pytest.mark.parametrize("name", ["ladder", "plate"])
def test_noise_free_survey_with_a_coherence_of_round_off(name):
    """A noise-free survey through ``sd.impact_frf`` has a coherence of one up to round-off
    (1e-16 below it): no measure of its noise.  It is identified as without a coherence (the
    ladder's said "no mode found" when the round-off was taken for the point variance, 3.59):
    every mode's pole within 3e-5 of the truth, relative (measured 1.5e-5 ladder, 9.6e-6
    plate: the asymptotic terms' truncation of the modes outside the band), the same model
    as with the coherence left out, statistics from the residual."""
    from sdctrl.data._coherence import measured_coherence
    sv = sd.testbeds.survey(name, noise=0.0, seed=0, n_hits=20, lines=400, averages=2)
    f = sv.frf
    assert 0 < np.max(1.0 - f.coherence) <= 1e-14
    assert measured_coherence(f) is None
    bare = sd.FRF(f.freq, f.H, quantity=f.quantity, sensors=f.sensors, actuators=f.actuators,
                  collocated=f.collocated, averages=f.averages,
                  exponential_tau=f.exponential_tau)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cm = sd.identify(f, band=sv.band, progress=False)
        cm0 = sd.identify(bare, band=sv.band, progress=False)
    assert cm.statistics.noise == "residual"
    np.testing.assert_allclose(cm.poles, cm0.poles, rtol=1e-12)
    assert int(cm.in_band.sum()) == sv.poles.size
    j = [int(np.argmin(np.abs(cm.poles - p))) for p in sv.poles]
    assert np.max(np.abs(cm.poles[j] - sv.poles) / np.abs(sv.poles)) <= 3e-5
    noisy = sd.FRF(f.freq, f.H, coherence=np.full(f.H.shape, 1.0 - 1e-6))
    assert measured_coherence(noisy) is noisy.coherence       # 60 dB is a measurement


@pytest.mark.parametrize("name,seed,kw,found,cost", [
    ("truss_high", 6, {"lines": 400, "n_hits": 20}, 6, 0.0018),
    ("cluster", 0, {}, 3, 0.0989),
])
def test_windowed_pruning_does_not_cascade(name, seed, kw, found, cost):
    """Two surveys whose poles meet the window's second differences in their significance
    (``_rules`` module notes): against the direct field alone, the smooth misfit a removed
    pole left raised the noise at the others -- truss_high seed 6 (400 lines, 20 hits) kept
    a spurious 7th in-band pole at a fit error of 2.69%, the cluster's seed 0 lost a mode
    (2 of 5, 27.7%).  Measured now: 6 poles, 0.18%; 3 of 5 (its four blade modes within
    0.14 Hz, 1.4 lines at 400 lines), 9.89%."""
    sv = sd.testbeds.survey(name, noise=0.01, seed=seed, **kw)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cm = sd.identify(sv.frf, band=sv.band, progress=False)
    assert int(cm.in_band.sum()) == found
    assert cm.cost <= 1.2 * cost
