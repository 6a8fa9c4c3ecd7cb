"""Scaling of complex modes whose collocated residues are noise (thesis 3.24, 3.40, 3.58;
issue 22): the phase of a proper mode, the magnitude of the least-squares scaling."""

import warnings

import numpy as np
import pytest

from sdctrl.identification._collocated_scaling import proper_phase, unscaled_poles
from sdctrl.identification._complex_modes import scale_residues
from test_family_normal_modes import _chain    # one cached chain per member for both files


def _proper_residues(seed=0):
    """Residues of two lightly damped proportional modes, mu = I (2.6): psi = phi/sqrt(2 i w_d)."""
    rng = np.random.default_rng(seed)
    lam = np.array([-0.3 + 60j, -0.5 + 95j])
    phi = rng.normal(size=(5, 2))                     # c phi, sensors 0 and 1 collocated
    psi = phi / np.sqrt(2j * lam.imag)
    b = phi[[0, 1]].T                                 # phi^T b, c_s = b_a^T
    R = np.einsum("sj,ja->jsa", psi, b / np.sqrt(2j * lam.imag)[:, None])
    return lam, R, psi


def test_proper_phase_recovers_a_proper_mode_from_a_noisy_phase():
    lam, R, psi = _proper_residues()
    pairs = ((0, 0), (1, 1))
    cpsi, psib, k = scale_residues(R, pairs)
    # exact data: the scaling is already that of the proper mode (up to the sign of psi)
    assert np.allclose(np.abs(np.sum(cpsi * psi.conj(), axis=0)),
                       np.sum(np.abs(psi) ** 2, axis=0), rtol=1e-10)
    # a scaling whose phase the noise turned by 70 degrees, magnitude kept
    z_bad = k["z"] * np.exp(1j * np.deg2rad([70.0, -40.0]))
    r = np.sqrt(z_bad) / np.sqrt(k["z"])
    cpsi_bad, psib_bad = cpsi * r, psib / r[:, None]
    c2, p2 = proper_phase(cpsi_bad, psib_bad, z_bad, np.array([True, False]))
    # mode 0 restored (cpsi up to its sign), mode 1 untouched; inputs not modified
    s = np.sign(np.real(c2[0, 0] / cpsi[0, 0]))
    assert np.allclose(c2[:, 0], s * cpsi[:, 0], rtol=1e-10)
    assert np.array_equal(c2[:, 1], cpsi_bad[:, 1]) and np.array_equal(p2[1], psib_bad[1])
    assert np.allclose(cpsi_bad, cpsi * r)
    # the dyads (the residues) are unchanged for every mode
    assert np.allclose(np.einsum("sj,ja->jsa", c2, p2),
                       np.einsum("sj,ja->jsa", cpsi_bad, psib_bad), rtol=1e-12)
    # the restored mode is proper on its own and of positive mass (3.40, 3.45)
    P = c2[:, 0, None] * c2[None, :, 0]
    assert np.abs(P.real).max() < 1e-12 * np.abs(P).max()
    assert np.all(np.linalg.eigvalsh(2 * (lam[0] * P).real) > -1e-12 * np.abs(P).max())


def test_cluster_blade_modes_far_from_the_shakers_are_reported_at_1_percent_only():
    """Noise-free every collocated residue is exact (z > 1e4); at 1% the blade modes at
    10.151 and 10.287 Hz have collocated residues of 0.2-1.0 standard deviations."""
    _, cm0, _ = _chain("cluster", 0.0)
    _, cm, _ = _chain("cluster", 0.01)
    pairs = tuple(cm.collocated)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert unscaled_poles(cm0, pairs, np.arange(cm0.n)).size == 0
    with pytest.warns(RuntimeWarning, match="mass scale is not measured"):
        idx = unscaled_poles(cm, pairs, np.flatnonzero(cm.in_band))
    assert np.round(cm.frequency[idx], 2).tolist() == [10.15, 10.29]
    std = cm.residue_std()
    for j in idx:
        z = [abs(cm.residues[j][s, a]) / std[j][s, a] for s, a in pairs]
        assert max(z) <= 3.0
    # without statistics nothing tells the noise: nothing is reported
    assert unscaled_poles(cm.replace(statistics=None), pairs, np.arange(cm.n)).size == 0


def test_unscaled_mode_keeps_its_residue_at_the_tested_io():
    """The phase changes cphi and phib of the mode, not what it contributes at the tested
    I/O: with its improper part (kept with its group) the model reproduces the identified
    residue at its pole (3.7 = 2.15 + improper part)."""
    _, cm, nm = _chain("cluster", 0.01)
    j = int(np.argmin(np.abs(cm.frequency - 10.287)))
    r = nm.residual
    k = int(np.flatnonzero(r.source == j)[0])
    lam = cm.poles[j]
    n = nm.n
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-nm.Omega, -nm.Gamma]])
    w, V = np.linalg.eig(A)
    i = int(np.argmin(np.abs(w - lam)))
    Rn = np.outer(nm.cphi @ V[:n, i], np.linalg.inv(V)[i, n:] @ nm.phib)
    R = cm.residues[j]
    assert np.abs(Rn + r.residues[k] - R).max() <= 1e-8 * np.abs(R).max()
    assert np.abs(Rn).max() > 0.5 * np.abs(R).max()          # the normal mode carries it
