"""The hybrid's default residual representation chosen from the test itself (issue 22):
``residual="auto"`` scores each candidate by leave-one-out prediction on the test's channels
(:mod:`sdctrl.hybrids._auto`), and ``io_kept`` gives the test without some channels.

A cheap exact test: the plate member's FE modes up to the band's top as the normal-mode
model of the test, with the exact residual flexibility ``E`` of the modes above (so that the
``"tested"`` candidate exists), against the member's deliberately wrong FE model.
"""

import functools
import warnings

import numpy as np
import pytest

import sdctrl as sd
from sdctrl.hybrids._auto import MAX_FOLDS, TIE, pick
from sdctrl.hybrids._hybrid_basis import band_lines
from sdctrl.modal import ResidualDynamics
from sdctrl.modal._operations import io_kept
from sdctrl.updating import logls


@functools.cache
def _plate():
    st = sd.testbeds.structure("plate")
    true, wrong = st.fe(), st.wrong()
    SH, SE = list(st.shakers), list(st.sensors)
    f, phi = true.modes(true.N)
    n = int(np.flatnonzero(f < st.band[1])[-1]) + 1
    w2 = (2 * np.pi * f[n:]) ** 2
    E = true.point(SE).T @ phi[:, n:] @ (phi[:, n:].T / w2[:, None]) @ true.point(SH)
    nm = true.normal_mode_model(SH, SE, n).replace(E=E)
    return st, wrong, nm


def _hybrid(*args, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")            # fewer sensors than modes (1 x 1 test)
        return sd.hybrid(*args, **kw)


def test_io_kept_is_the_test_without_the_channels():
    rng = np.random.default_rng(3)
    n, ns, na = 3, 4, 3
    w2 = np.array([100.0, 400.0, 900.0])
    res = ResidualDynamics(np.array([-2.0 + 80j]), rng.standard_normal((1, ns, na)) + 0j,
                           sensors=("s0", "s1", "s2", "s3"), actuators=("a0", "a1", "a2"))
    nm = sd.NormalModeModel(np.diag(w2), np.diag(0.02 * np.sqrt(w2)),
                            rng.standard_normal((ns, n)), rng.standard_normal((n, na)),
                            E=rng.standard_normal((ns, na)), F=rng.standard_normal((ns, na)),
                            residual=res)
    before = {k: np.array(getattr(nm, k)) for k in ("cphi", "phib", "E", "F")}
    f = np.linspace(1.0, 30.0, 40)
    H = nm.frf(f).H
    s, a = [0, 2, 3], [1]
    sub = io_kept(nm, sensors=s, actuators=a)
    np.testing.assert_allclose(sub.frf(f).H, H[:, s][:, :, a], rtol=1e-12, atol=0)
    assert sub.sensors == ("s0", "s2", "s3") and sub.actuators == ("a1",)
    assert sub.residual.residues.shape == (1, 3, 1)
    for k, v in before.items():                                   # inputs never modified
        assert np.array_equal(getattr(nm, k), v)


def test_auto_is_the_chosen_candidate_and_follows_its_rule():
    st, wrong, nm = _plate()
    SH, SE = list(st.shakers), list(st.sensors)
    h = _hybrid(wrong, nm, SE, SH, residual="auto")
    r = h.construction.residual
    assert r.chosen_by == "leave-one-actuator-out" and r.held_out.tolist() == [0, 1]
    assert set(r.loo_scores) == {"identified", "tested", "fe"}
    # the plate's FE errors leave kappa at 1 here: every candidate predicts the held-out
    # shaker alike (measured 0.035), and the one closest to the test at its I/O is kept --
    # "tested", which reproduces nm there (E carried 30x above the band: measured 8e-7)
    assert max(r.loo_scores.values()) <= 1.02 * min(r.loo_scores.values())
    assert 0.01 < r.loo_scores["tested"] < 0.1
    assert r.representation == "tested" and r.nominal_scores["tested"] < 1e-5
    assert r.nominal_scores["identified"] > 100 * r.nominal_scores["tested"]
    explicit = _hybrid(wrong, nm, SE, SH, residual="tested")
    f = np.linspace(*st.band, 50)
    np.testing.assert_array_equal(h.frf(f).H, explicit.frf(f).H)
    assert explicit.construction.residual.chosen_by is None
    assert explicit.construction.residual.representation == "tested"


def test_a_lower_mean_the_folds_do_not_agree_on_is_a_tie():
    """The rule of :func:`~sdctrl.hybrids._auto.pick` on the fold scores measured on a
    held-out structure at 1% noise (three actuators held out in turn): ``"fe"``'s mean is
    3.8% below ``"identified"``'s (beyond TIE) but it is worse on one fold and equal on
    another; the old rule (means alone) kept ``"fe"``, whose nominal model was 3.7x the
    identified one's (1.22 against 0.33), and the D-strut and broken strut fell with it
    (1.1x, against 4.2x and 4.0x with ``"tested"``)."""
    per = {"identified": [1.1484, 0.7995, 0.8219], "tested": [1.1484, 0.7995, 0.8219],
           "fe": [1.1484, 0.8094, 0.7081]}
    nominal = {"identified": 0.495, "tested": 3e-5, "fe": 0.872}
    mean = {k: np.mean(v) for k, v in per.items()}
    assert mean["fe"] < mean["identified"] / (1 + TIE)         # the old rule's choice: "fe"
    assert pick(per, nominal) == "tested"
    # better on every fold and beyond TIE: it wins, whatever its nominal score
    per["fe"] = [1.0, 0.7, 0.7]
    assert pick(per, nominal) == "fe"
    # within TIE: a tie, whatever the folds say
    per["fe"] = [1.1484, 0.7995, 0.80]
    assert pick(per, nominal) == "tested"
    # one fold (one sensor, one shaker has none): the sign test is that fold's
    assert pick({"a": [0.3], "b": [0.5]}, {"a": 0.2, "b": 0.1}) == "a"


def test_one_actuator_leaves_one_sensor_out_and_the_scores_are_the_held_out_errors():
    st, wrong, nm = _plate()
    SH, SE = list(st.shakers), list(st.sensors)
    nm1 = io_kept(nm, actuators=[0])
    h = _hybrid(wrong, nm1, SE, SH[:1], residual="auto")
    r = h.construction.residual
    folds = r.held_out.tolist()
    assert r.chosen_by == "leave-one-sensor-out"
    assert len(folds) == MAX_FOLDS and folds[0] == 0 and folds[-1] == len(SE) - 1
    # the recorded score is the held-out prediction's logLS, recomputed here by hand
    hz = band_lines(nm1, np.sqrt(np.diag(nm1.Omega))) / (2 * np.pi)
    Href = nm1.frf(hz).H
    c = wrong.point(SE).T
    errs = []
    for j in folds:
        rest = [i for i in range(len(SE)) if i != j]
        hj = _hybrid(wrong, io_kept(nm1, sensors=rest), c[rest], SH[:1], residual="fe")
        errs.append(logls(hj.with_io(c=c[[j]]).frf(hz).H[:, 0, :], Href[:, j, :]))
    assert r.loo_scores["fe"] == pytest.approx(np.mean(errs), rel=1e-9)
    assert r.representation == "tested"


def test_one_sensor_one_actuator_keeps_the_closest_to_the_test():
    st, wrong, nm = _plate()
    SH, SE = list(st.shakers), list(st.sensors)
    h = _hybrid(wrong, io_kept(nm, sensors=[0], actuators=[0]), SE[:1], SH[:1],
                residual="auto")
    r = h.construction.residual
    assert r.chosen_by == "nominal" and r.held_out.size == 0 and r.loo_scores == {}
    assert r.representation == min(r.nominal_scores, key=r.nominal_scores.get) == "tested"


def test_auto_without_residual_terms_chooses_between_identified_and_fe():
    st, wrong, nm = _plate()
    h = _hybrid(wrong, nm.replace(E=None), list(st.sensors), list(st.shakers),
                residual="auto")
    r = h.construction.residual
    assert set(r.loo_scores) == {"identified", "fe"}
    assert r.representation in ("identified", "fe")
    with pytest.raises(ValueError, match="residual must be one of.*'auto'"):
        sd.hybrid(wrong, nm, list(st.sensors), list(st.shakers), residual="automatic")


def _exact_test(st):
    """A structure's true FE modes in its band as the test's normal modes, with the exact
    residual flexibility ``E`` of the modes above (static correction 2.21 at the I/O)."""
    true = st.fe()
    SH, SE = list(st.shakers), list(st.sensors)
    f, phi = true.modes(min(true.N - 2, 60))
    n = int(np.flatnonzero(f < st.band[1])[-1]) + 1
    E = true.point(SE).T @ true.static_correction(true.point(SH), phi[:, :n])
    return true.normal_mode_model(SH, SE, n).replace(E=E)


@pytest.mark.parametrize("name", ["plate", "lattice"])
def test_auto_sharing_one_static_solve_is_the_model_of_a_solve_per_build(name):
    """``sd.hybrid`` solves ``K^-1`` of the test inputs once and hands its columns to every
    build and fold of ``residual="auto"`` (the expansion basis, the model's static
    correction, the held-out input's); built straightforwardly (each build and each
    held-out prediction solving for its own loads: ``_auto(..., response=None)``, and the
    held-out input through ``with_io`` itself) the model is the same to round-off, and so
    is the choice.  The lattice (1,500 DOFs) takes the sparse path, the plate the dense one."""
    from sdctrl.hybrids import _auto as auto_mod
    from sdctrl.hybrids import _build as b

    st = (sd.testbeds.lattice(1500) if name == "lattice" else sd.testbeds.structure(name))
    wrong, nm = st.wrong(), _exact_test(st)
    SH, SE = list(st.shakers), list(st.sensors)
    h = _hybrid(wrong, nm, SE, SH)
    c, bb = b.placed_io(wrong, nm, SE, SH)
    w2, fmax, mac_min = b.measured_w2(nm, None, b.MAC_POOR)
    f_fe, phi_fe = b.fe_modes_upto(wrong, max(fmax, 1.05 * np.sqrt(w2.max()) / (2 * np.pi)),
                                   nm.n)
    setup = b._Setup(wrong, f_fe, phi_fe, mac_min, "regularised")
    loads, _ = b.placed_loads(wrong, nm, bb)
    calls = []

    def held_out(m, loads, response, j):        # the plain with_io, no shared column
        calls.append(response)
        return m.with_io(b=loads[:, [j]])

    orig, auto_mod._held_out_input = auto_mod._held_out_input, held_out
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ref = b._auto(setup, nm, c, loads, None, None)
    finally:
        auto_mod._held_out_input = orig
    assert calls and all(r is None for r in calls)
    r, r0 = h.construction.residual, ref.construction.residual
    assert r.representation == r0.representation and r.variant == r0.variant
    assert r.chosen_by == r0.chosen_by and r.held_out.tolist() == r0.held_out.tolist()
    for k, v in r0.loo_scores.items():
        assert r.loo_scores[k] == pytest.approx(v, rel=1e-9, abs=0)
    assert r.nominal_scores == pytest.approx(r0.nominal_scores, rel=1e-9, abs=0)
    assert h.kind.tolist() == ref.kind.tolist()
    for k in ("Omega", "Gamma", "cphi", "phib", "shapes"):
        a, x = getattr(h, k), getattr(ref, k)
        np.testing.assert_allclose(a, x, rtol=0, atol=1e-9 * np.abs(x).max(), err_msg=k)
