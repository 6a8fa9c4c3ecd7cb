"""A plain normal-mode model placed on its FE model: its static-correction states take the
shapes of the FE's static correction of its inputs (:mod:`sdctrl.diagnosis._static_states`).

The expansion of a hybrid model (4.7) fits each state's ``cphi`` with FE modes: exact for
the states that are FE modes, wrong for the static states an FE reduction appends (on a
held-out aircraft model relative shape errors of 0.27 to 7.9, a dashpot biased by 0.8-1.2%
and a mass by -1.5% noise-free).  MEASURED with the rule: the static states' shapes within
2e-13 (truss_high, 6 states) and 1e-13 (ladder, 3 states) of the reduction's own, and the
diagnosis of the plain model equal to the shaped model's.  (1.4e-4 and 1.7e-5, and up to
2.4e-3 with other BLAS threads, while the static correction subtracted the retained modes'
part from ``K^-1 B``: :func:`sdctrl.fe._static.static_correction`.)
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import sdctrl as sd
from sdctrl.diagnosis._loop import _on_fe
from test_diagnose_family import case, diagnosis, member, nominal, planted


def _plain(nm):
    return sd.NormalModeModel(nm.Omega, nm.Gamma, nm.cphi, nm.phib, E=nm.E,
                              sensors=nm.sensors, actuators=nm.actuators)


@pytest.mark.parametrize("name, tol", [("truss_high", 1e-9), ("ladder", 1e-9)])
def test_static_states_take_the_static_correction_shapes(name, tol):
    nm, fe = nominal(name), member(name)[1]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        placed, built = _on_fe(_plain(nm), fe)
    S0, S1 = np.asarray(nm.shapes), np.asarray(placed.shapes)
    err = np.linalg.norm(S1 - S0, axis=0) / np.linalg.norm(S0, axis=0)
    k = nm.n_static
    assert k > 0 and f"{k} static-correction states" in built
    assert err[:-k].max() < 1e-9                             # the modes: FE modes
    assert err[-k:].max() < tol                              # 2e-13 / 1e-13
    # the response at the tested channels is the plain model's
    f = np.linspace(*sd.testbeds.structure(name).band, 7)
    np.testing.assert_allclose(placed.frf(f).H, nm.frf(f).H, rtol=1e-9,
                               atol=1e-12 * np.abs(nm.frf(f).H).max())


def test_the_plain_model_diagnosis_is_the_shaped_models():
    """truss_high, a dashpot (the family's rule), noise-free: the same effect and size as
    with the reduction's own shapes (before the rule: -0.22% against -0.16%)."""
    c = case("truss_high", "added_damper", 0)
    model, data = planted("truss_high", (c,))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        d = sd.diagnose(_plain(model), data, member("truss_high")[1], max_effects=1,
                        progress=False)
    ref = diagnosis("truss_high", (c,))
    e, r = d.effects[0], ref.effects[0]
    assert (e.kind, e.location) == (r.kind, r.location) == ("added_damper", c[1])
    assert e.parameters["c"] == pytest.approx(r.parameters["c"], rel=1e-5)
