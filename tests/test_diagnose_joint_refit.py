"""The joint refit of a diagnosis's effects (issue 23: several effects, nothing invented).

A six-mode normal-mode model (2.15), two close pairs, 4 sensors x 2 actuators, no FE model.
Checked against closed forms and truth:

- the closed-form Jacobian columns of a free mode (``phi c b^T``) and of the coupling terms
  of a non-proportional damping effect applied last equal central differences of the
  corrected model (the refit and the effects' standard deviations use them);
- the refit keeps a free mode in its region (frequency 0.8-1.2 times the band's ends,
  damping ratio below 0.5): a "mode" proposed to explain a broadband misfit (a constant
  residual flexibility) is driven onto the region's edge by the joint refit and passed over,
  and the step takes its next candidate;
- a free mode accepted early that a later effect makes redundant is dropped (the residual
  terms are refitted with the others);
- a real missing mode refitted jointly with a second effect stays a mode, at its true
  frequency and damping.
"""

from __future__ import annotations

import copy
import functools

import numpy as np
import pytest

import sdctrl as sd
from sdctrl.diagnosis._apply import DelayedModel, apply_effect
from sdctrl.diagnosis._effect_statistics import Evaluator, coordinates, stacked_jacobian
from sdctrl.diagnosis._global_effects import (
    fit_delay,
    fit_free_mode,
    fit_nonproportional,
    free_mode_region,
    leaves_region,
    proposal,
)
from sdctrl.diagnosis._joint_fit import refit
from sdctrl.diagnosis._loop import _extended
from sdctrl.diagnosis._placed_data import place
from sdctrl.diagnosis._residual_map import cost

FREQ = np.linspace(5.0, 35.0, 200)


@functools.cache
def base():
    f = np.array([8.0, 15.8, 16.0, 24.0, 30.0, 30.3])
    w = 2 * np.pi * f
    rng = np.random.default_rng(1)
    return sd.NormalModeModel(np.diag(w**2), np.diag(2 * 0.01 * w),
                              rng.standard_normal((4, 6)), rng.standard_normal((6, 2)),
                              sensors=["s0", "s1", "s2", "s3"], actuators=["a0", "a1"])


def _mode_model(f=20.0, zeta=0.02, scale=1.0):
    """``base`` with a seventh mode at ``f`` Hz (the truth of a missing mode)."""
    m, w = base(), 2 * np.pi * f
    rng = np.random.default_rng(7)
    Om = np.diag(np.r_[np.diag(m.Omega), w * w])
    Ga = np.diag(np.r_[np.diag(m.Gamma), 2 * zeta * w])
    return m.replace(Omega=Om, Gamma=Ga,
                     cphi=np.hstack([m.cphi, scale * rng.standard_normal((4, 1))]),
                     phib=np.vstack([m.phib, scale * rng.standard_normal((1, 2))]))


def _central_jacobian(evaluate, x, h=1e-4):
    cols = []
    for k in range(x.size):
        xp, xm = x.copy(), x.copy()
        d = h * max(abs(x[k]), 1e-12)
        xp[k] += d
        xm[k] -= d
        q = np.log(evaluate(xp)[0] / evaluate(xm)[0]).ravel() / (2 * d)
        cols.append(np.r_[q.real, q.imag])
    return np.array(cols).T


def test_closed_form_columns_equal_differences():
    """A free mode (its frequency, damping and modal vectors) after a delay, and coupling
    terms applied last: the closed-form columns equal central differences of the corrected
    model to 1e-5 (a free mode followed by coupling terms, which may tie it to the other
    modes, is differenced instead)."""
    data = _mode_model().frf(FREQ, "acceleration")
    placed = place(base(), data)
    H = placed.response(base())
    mode = fit_free_mode(placed, H)
    assert mode is not None and abs(mode["parameters"]["frequency"] - 20.0) < 0.05
    delay = fit_delay(placed, H)
    with_mode = apply_effect(base(), mode, placed)
    gamma = fit_nonproportional(placed, with_mode, placed.rows, placed.cols)
    assert gamma is not None and gamma["cost"] < 1e-20      # the data have no coupling
    k = gamma["k"]                  # close pairs, the free mode's with 15.8/16 Hz among them
    for props, closed in (([delay, mode], slice(1, None)), ([mode, gamma], slice(-k, None))):
        coords = [coordinates(p) for p in props]
        x = np.array([c[1] for cs in coords for c in cs], float)
        if props[0] is delay:
            x[0] = 1e-3
        else:
            x[-k:] = np.linspace(-0.05, 0.05, k)    # couplings away from zero: a real check
        ev = Evaluator(base(), props, coords, placed, placed)
        J = stacked_jacobian(ev, x)
        Jd = _central_jacobian(ev, x)
        assert J.shape == Jd.shape == (2 * H.size, x.size)
        err = np.linalg.norm(J - Jd, axis=0) / np.linalg.norm(Jd, axis=0)
        assert np.all(err[closed] < 1e-5), err
        assert np.all(err < 1e-3), err
        # forward differences (the refit's) within 1e-3 of the central ones
        Jf = stacked_jacobian(ev, x, central=False)
        errf = np.linalg.norm(Jf - J, axis=0) / np.linalg.norm(J, axis=0)
        assert np.all(errf < 1e-3) and np.array_equal(Jf[:, closed], J[:, closed])


def _broadband_case():
    """Data: ``base`` delayed by 2 ms plus a constant residual flexibility on every channel
    (a broadband misfit, no mode missing)."""
    m = base()
    E = 2e-4 * np.ones((4, 2))
    truth = DelayedModel(m.replace(E=E), 2e-3, FREQ[-1])
    return truth.frf(FREQ, "acceleration")


def test_refit_keeps_a_free_mode_in_its_region_and_passes_it_over():
    data = _broadband_case()
    placed = place(base(), data)
    H = placed.response(base())
    delay = fit_delay(placed, H)
    current = apply_effect(base(), delay, placed)
    Hc = placed.response(current)
    # a free mode standing for the broadband residual left by the delay, inside its region
    # (34 Hz, 30% damping): what a step may propose when nothing else explains the misfit
    w, z = 2 * np.pi * 34.0, 0.3
    mode = proposal("missing_mode", 34.0, {"frequency": 34.0, "damping": z,
                                           "cphi": np.ones(4), "phib": np.ones(2)},
                    0.0, 7, FREQ.size, "mode",
                    {"omega": w, "zeta": z, "c": np.ones(4), "b": np.ones(2)})
    lo, hi, zlo, zhi = free_mode_region(placed.omega)
    props = refit(base(), [delay, mode], placed).props
    q = props[1]["payload"]
    assert lo <= q["omega"] <= hi and zlo <= q["zeta"] <= zhi       # bounded refit
    assert leaves_region(props[1], placed.omega)                    # onto the edge
    # the step passes it over and takes the next candidate
    other = copy.deepcopy(delay)
    other["cost"], other["false_alarm"] = 0.0, 0.0
    mode.update(false_alarm=0.0, cost=0.0)
    J = cost(Hc, placed.Hd)
    ext = _extended(base(), current, [delay], [mode, other], (J, J, 0.0), placed)
    assert [r["kind"] for r in ext.rejected] == ["missing_mode"]
    assert ext.trial is not None and [p["kind"] for p in ext.trial] == ["delay", "delay"]



def test_a_generic_effect_made_redundant_is_dropped():
    """Data: the model delayed, plus a constant residual flexibility (no mode missing).  The
    residual flexibility comes first; a free mode then fits part of what the delay explains
    (step 2); once the delay is accepted (step 3) and the residual term refitted with it, the
    mode is no longer significant and is dropped: the diagnosis reports exactly the two
    effects, to round-off."""
    data = _broadband_case()
    d = sd.diagnose(base(), data, progress=False)
    assert sorted(e.kind for e in d.effects) == ["delay", "residual_flexibility"]
    by_kind = {e.kind: e for e in d.effects}
    assert by_kind["delay"].parameters["tau"] == pytest.approx(2e-3, rel=1e-3)
    assert np.allclose(by_kind["residual_flexibility"].parameters["E"], 2e-4, rtol=1e-3)
    assert d.error_after < 1e-7 * d.error_before
    dropped = [x["kind"] for st in d.steps for x in st.get("dropped", [])]
    assert dropped == ["missing_mode"]
    assert "dropped: missing_mode" in d.report()


@pytest.mark.parametrize("noise", [0.0, 0.01])
def test_a_missing_mode_refitted_with_a_delay_stays_a_mode(noise):
    """A mode missing at 20 Hz (2% damping) and a 1 ms delay: both found; the joint refit
    keeps the mode at its true frequency (0.5%) and damping (20%)."""
    from sdctrl.testbeds._measurement_noise import relative_noise

    truth = DelayedModel(_mode_model(), 1e-3, FREQ[-1])
    frf = truth.frf(FREQ, "acceleration")
    if noise:
        frf = sd.FRF(FREQ, relative_noise(frf.H, noise, 3), quantity="acceleration",
                     sensors=frf.sensors, actuators=frf.actuators)
    d = sd.diagnose(base(), frf, progress=False)
    by_kind = {e.kind: e for e in d.effects}
    assert set(by_kind) == {"missing_mode", "delay"}
    mode = by_kind["missing_mode"].parameters
    assert mode["frequency"] == pytest.approx(20.0, rel=5e-3)
    assert mode["damping"] == pytest.approx(0.02, rel=0.2)
    assert by_kind["delay"].parameters["tau"] == pytest.approx(1e-3, rel=0.03 + 0.07 * bool(noise))
    assert not any(st.get("rejected") for st in d.steps)


def test_a_mode_coupled_by_a_later_damping_is_not_pruned():
    """A free mode, then non-proportional damping fitted on the model with that mode (its
    ``dGamma`` has the mode's row and column), then a delay: the mode is not taken out by
    the pruning (the damping's couplings refer to it; taking it out crashed applying a 7 x 7
    ``dGamma`` to the 6 modes left)."""
    from sdctrl.diagnosis._joint_fit import corrected, pruned

    data = _broadband_case()
    placed = place(base(), data)
    w, z = 2 * np.pi * 31.0, 0.05
    mode = proposal("missing_mode", 31.0, {"frequency": 31.0, "damping": z,
                                           "cphi": 1e-3 * np.ones(4), "phib": np.ones(2)},
                    0.0, 7, FREQ.size, "mode",
                    {"omega": w, "zeta": z, "c": 1e-3 * np.ones(4), "b": np.ones(2)})
    with_mode = apply_effect(base(), mode, placed)
    gamma = fit_nonproportional(placed, with_mode, placed.rows, placed.cols,
                                placed.response(with_mode))
    assert gamma is not None and gamma["payload"]["dGamma"].shape == (7, 7)
    delay = fit_delay(placed, placed.response(apply_effect(with_mode, gamma, placed)))
    fit = corrected(base(), [mode, gamma, delay], placed)
    out, dropped = pruned(base(), fit, placed, 1e-6)
    assert dropped == [] and [p["action"] for p in out.props] == ["mode", "gamma", "delay"]
