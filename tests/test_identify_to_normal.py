"""End to end, thesis chapter III: FRFs of a known normal-mode model with a full damping
matrix -> ``identify`` (no poles given) -> ``normal_modes``: the identified Omega, Gamma and
cphi are the true ones (issue acceptance: frequencies 1e-5, Gamma 1e-3 Frobenius, cphi 1e-4,
noise-free)."""

import numpy as np
import pytest
from test_normal_modes import _errors, _truth

import sdctrl as sd
from sdctrl.updating import _costs as costs


@pytest.mark.parametrize("ns", [12, 6], ids=["more-sensors-than-modes", "as-many-as-modes"])
@pytest.mark.parametrize("quantity", ["displacement", "acceleration"])
def test_identify_then_normal_modes_recovers_the_true_model(ns, quantity):
    true, col = _truth(ns)
    f = np.linspace(4.0, 40.0, 1500)
    frf = true.frf(f, quantity)
    frf = sd.FRF(f, frf.H, quantity, sensors=frf.sensors, actuators=frf.actuators,
                 collocated=col)
    cm = sd.identify(frf, progress=False)
    assert cm.n == true.n and cm.in_band.all()                  # every mode, no spurious one
    nm = sd.normal_modes(cm)
    ef, eG, ec, eb = _errors(nm, true)
    assert ef < 1e-5 and eG < 1e-3 and ec < 1e-4 and eb < 1e-4
    # the identified poles are kept by the transformation
    assert np.allclose(np.sort_complex(nm.poles), np.sort_complex(cm.poles), rtol=1e-9)
    # the close, strongly coupled pair keeps its coupling
    def rho(G):
        return abs(G[2, 3]) / np.sqrt(G[2, 2] * G[3, 3])

    assert rho(true.Gamma) > 0.8 and rho(nm.Gamma) == pytest.approx(rho(true.Gamma), rel=1e-3)
    # and the model reproduces the measurement, as does its StateSpace
    assert costs.relative_error(nm.frf(f, quantity), frf) < 1e-6
    G = nm.to_statespace(quantity)
    Hs = np.moveaxis(G(2j * np.pi * f), -1, 0)
    assert np.abs(Hs - nm.frf(f, quantity).H).max() < 1e-8 * np.abs(frf.H).max()
