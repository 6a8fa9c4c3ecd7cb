"""Scale-free numerics (issue 25): identification, normal modes and FRF costs are invariant
to the unit of H.  An FRF in micrometres per kilonewton or in metres per meganewton is the
same test: scaling H by ``s`` (1e-155 to 1e155, and 1e-300 to 1e300 for the transformation
alone) must give the same poles, the same costs, residues times ``s`` and normal-mode
observabilities times ``sqrt(s)`` -- never an underflow to 0, an overflow to inf or a
refusal (``|H|^2`` of 1e-155 is below the smallest double)."""

import warnings

import numpy as np
import pytest

import sdctrl as sd
from sdctrl.updating._costs import logls, relative_error

W = 2 * np.pi * np.array([10.0, 14.0, 25.0])
CPHI = np.array([[1.0, 0.5, 0.2], [0.3, -1.0, 0.4], [0.5, 0.2, -0.8], [0.1, 0.7, 0.6]])
LABELS = ("a", "b", "c", "d")
FREQ = np.linspace(5.0, 40.0, 300)
SCALES = [1e-155, 1e-150, 1e-100, 1e100, 1e150, 1e155]


def _truth():
    G = np.diag(0.04 * W)
    G[0, 1] = G[1, 0] = 0.3                     # non-proportional: complex modes
    return sd.NormalModeModel(np.diag(W**2), G, CPHI, CPHI[:2].T.copy(), sensors=LABELS,
                              actuators=LABELS[:2])


def _noisy_frf(scale=1.0):
    H = _truth().frf(FREQ).H
    rng = np.random.default_rng(0)
    H = H * (1 + 0.01 * (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape)))
    return sd.FRF(FREQ, H * scale, sensors=LABELS, actuators=LABELS[:2])


@pytest.fixture(scope="module")
def reference():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        cm = sd.identify(_noisy_frf())
        return cm, sd.normal_modes(cm)


@pytest.mark.parametrize("scale", SCALES)
def test_identify_and_normal_modes_do_not_depend_on_the_unit_of_H(reference, scale):
    cm0, nm0 = reference
    frf = _noisy_frf(scale)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        cm = sd.identify(frf)
        nm = sd.normal_modes(cm)
    # the reference itself is right: three modes at the true frequencies
    assert cm0.poles.size == 3
    np.testing.assert_allclose(np.sort(nm0.frequency), W / (2 * np.pi), rtol=2e-3)
    # ... and the scaled test gives the same fit
    assert cm.poles.size == cm0.poles.size
    np.testing.assert_allclose(cm.poles, cm0.poles, rtol=1e-8)
    np.testing.assert_allclose(cm.residues / scale, cm0.residues, rtol=1e-6,
                               atol=1e-6 * np.abs(cm0.residues).max())
    assert cm.cost == pytest.approx(cm0.cost, rel=1e-6) and 0.005 < cm.cost < 0.05
    np.testing.assert_allclose(nm.Omega, nm0.Omega, rtol=1e-8)
    np.testing.assert_allclose(nm.Gamma, nm0.Gamma, rtol=1e-6, atol=1e-6 * np.abs(
        nm0.Gamma).max())
    np.testing.assert_allclose(nm.cphi / np.sqrt(scale), nm0.cphi, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(nm.phib / np.sqrt(scale), nm0.phib, rtol=1e-6, atol=1e-9)
    # the costs of the model against the test: same numbers, finite
    model = nm.frf(FREQ)
    assert logls(model, frf) == pytest.approx(logls(nm0.frf(FREQ), _noisy_frf()), rel=1e-6)
    assert relative_error(model, frf) == pytest.approx(
        relative_error(nm0.frf(FREQ), _noisy_frf()), rel=1e-8)


def _exact_cm(scale):
    """Complex modes of an exactly proper 2-mode model (closed form), residues times scale."""
    lam = np.array([-0.5 + 60j, -0.8 + 90j])
    phi = np.array([[1.0, 0.5], [0.4, -1.0]])
    R = np.einsum("ij,kj->jik", phi, phi) / (2j * lam.imag)[:, None, None] * scale
    return sd.ComplexModeModel(lam, R, collocated=[(0, 0), (1, 1)]), lam, phi


@pytest.mark.parametrize("exponent", [-300, -250, -200, -155, 0, 155, 200, 250, 300])
def test_normal_modes_of_exact_complex_modes_at_any_scale(exponent):
    """Closed form: ``Omega = |lambda|^2``, ``Gamma = -2 Re(lambda)``, ``cphi = phi sqrt(s)``
    (up to sign), the poles kept -- from 1e-300 to 1e300."""
    s = 10.0**exponent
    cm, lam, phi = _exact_cm(s)
    nm = sd.normal_modes(cm)
    np.testing.assert_allclose(np.diag(nm.Omega), np.abs(lam) ** 2, rtol=1e-10)
    np.testing.assert_allclose(np.diag(nm.Gamma), -2 * lam.real, rtol=1e-8)
    assert np.abs(nm.Gamma[0, 1]) < 1e-8
    np.testing.assert_allclose(np.abs(nm.cphi) / np.sqrt(s), np.abs(phi), rtol=1e-8)
    np.testing.assert_allclose(nm.poles, lam, rtol=1e-10)
    # the record of the construction is in the units of the data
    p = nm.properness
    np.testing.assert_allclose(np.abs(p.cpsi) / np.sqrt(s), np.abs(
        sd.normal_modes(_exact_cm(1.0)[0]).properness.cpsi), rtol=1e-8)
    assert np.all(np.isfinite(nm.cphi)) and np.all(np.isfinite(nm.phib))
