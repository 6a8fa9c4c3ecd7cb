"""Non-proportional damping found by sd.diagnose against truth (issue 23, point a).

A normal-mode model (2.15) of six modes, two close pairs (15.8/16.0 Hz and 30.0/30.3 Hz, 1%
damping), 4 sensors x 2 actuators.  The true ``Gamma`` couples the first close pair
(``Gamma_23 = 0.5 sqrt(Gamma_22 Gamma_33)``); the model diagnosed is the same with that
coupling removed (diagonal ``Gamma``).  No FE model: the candidates are the global ones
(delay, residual terms, an extra mode, the coupling terms of every close pair).  Each case is
one small diagnosis (about a second).
"""

from __future__ import annotations

import functools

import numpy as np
import pytest

import sdctrl as sd
from sdctrl.diagnosis._global_effects import fit_nonproportional
from sdctrl.diagnosis._placed_data import place
from sdctrl.testbeds._measurement_noise import relative_noise

FREQ = np.linspace(5.0, 35.0, 200)


@functools.cache
def models():
    """(true model with the coupling, model without it, true Gamma_23 in rad/s)."""
    f = np.array([8.0, 15.8, 16.0, 24.0, 30.0, 30.3])
    w = 2 * np.pi * f
    rng = np.random.default_rng(1)
    cphi, phib = rng.standard_normal((4, 6)), rng.standard_normal((6, 2))
    G = np.diag(2 * 0.01 * w)
    Gt = G.copy()
    g = 0.5 * np.sqrt(G[1, 1] * G[2, 2])
    Gt[1, 2] = Gt[2, 1] = g
    true = sd.NormalModeModel(np.diag(w**2), Gt, cphi, phib, sensors=["s0", "s1", "s2", "s3"],
                              actuators=["a0", "a1"])
    return true, true.replace(Gamma=G), float(g)


def _data(model, noise=0.0, seed=0):
    frf = model.frf(FREQ, "acceleration")
    if not noise:
        return frf
    return sd.FRF(FREQ, relative_noise(frf.H, noise, seed), quantity="acceleration",
                  sensors=frf.sensors, actuators=frf.actuators)


def test_the_fit_evaluates_the_models_own_response():
    """With zero coupling change the fit's response is the model's ``C Z^-1 B`` (2.15): on
    the model's own data its cost is round-off and the fitted terms are zero."""
    _, base, _ = models()
    placed = place(base, _data(base))
    p = fit_nonproportional(placed, base, placed.rows, placed.cols)
    assert p["k"] == 3                       # pairs (2, 3), (4, 5), (5, 6): 1-based
    assert sorted(p["parameters"]) == ["Gamma_2_3", "Gamma_4_5", "Gamma_5_6"]
    assert p["cost"] < 1e-24
    assert max(abs(v) for v in p["parameters"].values()) < 1e-9


def test_coupling_recovered_noise_free():
    true, base, g = models()
    d = sd.diagnose(base, _data(true), progress=False)
    assert [e.kind for e in d.effects] == ["nonproportional_damping"]
    par = d.effects[0].parameters
    assert par["Gamma_2_3"] == pytest.approx(g, rel=1e-3)
    assert abs(par["Gamma_4_5"]) < 1e-3 * g and abs(par["Gamma_5_6"]) < 1e-3 * g
    assert d.error_after < 1e-6 * d.error_before
    # the corrected model is the truth
    assert np.allclose(d.model.Gamma, true.Gamma, rtol=0, atol=1e-3 * g)


def test_coupling_recovered_at_one_percent_noise_within_three_std():
    true, base, g = models()
    d = sd.diagnose(base, _data(true, 0.01, 0), progress=False)
    assert [e.kind for e in d.effects] == ["nonproportional_damping"]
    e = d.effects[0]
    assert d.noise == pytest.approx(1e-4, rel=0.1)
    for name, v in (("Gamma_2_3", g), ("Gamma_4_5", 0.0), ("Gamma_5_6", 0.0)):
        # std of the noise's size: 1% noise on 200 x 4 x 2 entries, a few 1e-3 rad/s
        assert 0 < e.std[name] < 0.01 * g
        assert abs(e.parameters[name] - v) <= 3 * e.std[name], (name, e.parameters, e.std)
    assert d.error_after == pytest.approx(1e-4, rel=0.1)


@pytest.mark.parametrize("coupled", [False, True])
def test_null_case_adds_nothing(coupled):
    """The model's own response with 1% noise, with and without coupling in the model: no
    effect (the coupling terms of three pairs fitted to noise are not significant)."""
    true, base, _ = models()
    model = true if coupled else base
    for seed in (1, 2):
        d = sd.diagnose(model, _data(model, 0.01, seed), progress=False)
        assert d.effects == []
        assert d.error_after == d.error_before == pytest.approx(1e-4, rel=0.1)
        cands = {c["kind"]: c for c in d.steps[0]["candidates"]}
        npd = cands["nonproportional_damping"]
        assert npd["k"] == 3 and npd["false_alarm"] > 1e-3


def test_with_effects_rebuilds_the_corrected_model():
    """``Diagnosis.with_effects``: every effect gives :attr:`model`, none the input model; a
    bad index is refused."""
    true, base, _ = models()
    d = sd.diagnose(base, _data(true), progress=False)
    f = FREQ[::7]
    assert np.allclose(d.with_effects([0]).frf(f).H, d.model.frf(f).H, rtol=1e-12, atol=0)
    assert np.array_equal(d.with_effects([]).Gamma, base.Gamma)
    with pytest.raises(ValueError, match="which"):
        d.with_effects([1])
