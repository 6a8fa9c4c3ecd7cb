"""The second-order realisation (2.15) is one kernel: normal-mode models, uncertain models
and their perturbations realise ``p'' + Gamma p' + Omega p = phib u`` through it, and each
realisation reproduces the closed-form FRF of its matrices."""

import numpy as np
import pytest

import sdctrl as sd
from sdctrl._lib.statespace import correction_filter, modal_states, second_order, ss_frf

QUANTITIES = ("displacement", "velocity", "acceleration")


def _model(E=None, F=None, seed=3):
    """Five modes, non-proportional damping, three sensors, two actuators."""
    rng = np.random.default_rng(seed)
    n, ns, na = 5, 3, 2
    w = np.sort(rng.uniform(5.0, 400.0, n))
    G = 0.3 * rng.standard_normal((n, n))
    G = G @ G.T + np.diag(rng.uniform(0.1, 1.0, n))
    return sd.NormalModeModel(np.diag(w**2), G, rng.standard_normal((ns, n)),
                              rng.standard_normal((n, na)), E=E, F=F)


def _closed_form(Omega, Gamma, phib, cphi, w, k):
    """``(j w)^k cphi (Omega + j w Gamma - w^2 I)^-1 phib`` per frequency (2.15)."""
    n = Omega.shape[0]
    Z = Omega[None] + 1j * w[:, None, None] * Gamma[None] - w[:, None, None] ** 2 * np.eye(n)
    return (1j * w[:, None, None]) ** k * (cphi @ np.linalg.solve(Z, phib))


@pytest.mark.parametrize("k", [0, 1, 2])
def test_kernel_matches_the_closed_form(k):
    m = _model()
    w = np.linspace(1.0, 450.0, 700)
    A, B, C, D = second_order(m.Omega, m.Gamma, m.phib, m.cphi, k)
    assert A.shape == (10, 10) and B.shape == (10, 2) and C.shape == (3, 10) and D.shape == (3, 2)
    H = ss_frf(A, B, C, D, w)
    ref = _closed_form(m.Omega, m.Gamma, m.phib, m.cphi, w, k)
    assert np.abs(H - ref).max() < 1e-12 * np.abs(ref).max()
    assert modal_states(2) == ["p0", "p1", "dp0", "dp1"]


def test_correction_filter_matches_its_transfer_function():
    """One kernel (2.20) for normal- and complex-mode models: ``(P1 s + P2 s^2) wc^2/(s+wc)^2``,
    which tends to ``P1 s + P2 s^2`` well below ``wc`` (relative error ~ 2 w / wc)."""
    rng = np.random.default_rng(4)
    P1, P2, wc = rng.standard_normal((3, 2)), rng.standard_normal((3, 2)), 2e3
    w = np.linspace(1.0, 5e3, 400)
    H = ss_frf(*correction_filter(P1, P2, wc), w)
    s = 1j * w[:, None, None]
    ref = (P1 * s + P2 * s**2) * wc**2 / (s + wc) ** 2
    assert np.abs(H - ref).max() < 1e-12 * np.abs(ref).max()
    low = w < 10.0
    exact = P2 * s[low] ** 2 + P1 * s[low]
    assert np.abs(H[low] - exact).max() < 4 * 10.0 / wc * np.abs(exact).max()


def test_kernel_refuses_a_fourth_derivative():
    with pytest.raises(ValueError, match="k must be 0, 1 or 2"):
        second_order(np.eye(1), np.eye(1), np.ones((1, 1)), np.ones((1, 1)), k=3)


@pytest.mark.parametrize("with_F", [False, True])
@pytest.mark.parametrize("quantity", QUANTITIES)
def test_normal_mode_statespace_is_the_kernel_plus_exact_static_terms(quantity, with_F):
    """E is realised exactly for displacement, F (residual mass) for every quantity with
    rigid_body=True (2.24): the StateSpace FRF equals the model's own FRF (2.15).  With F the
    state matrix holds double integrators (a defective A), whose evaluation loses a few
    digits: 1e-9 there."""
    rng = np.random.default_rng(0)
    E = 1e-4 * rng.standard_normal((3, 2)) if quantity == "displacement" else None
    m = _model(E=E, F=1e-2 * rng.standard_normal((3, 2)) if with_F else None)
    freq = np.linspace(0.5, 70.0, 600)
    G = m.to_statespace(quantity, rigid_body=True)
    H = sd.FRF.from_system(G, freq, quantity).H
    ref = m.frf(freq, quantity).H
    assert np.abs(H - ref).max() < (1e-9 if with_F else 1e-12) * np.abs(ref).max()
    # the modal block of the realisation is the kernel's, unchanged
    k = QUANTITIES.index(quantity)
    A, B, C, _ = second_order(m.Omega, m.Gamma, m.phib, m.cphi, k)
    assert np.array_equal(G.A[:10, :10], A) and np.array_equal(G.B[:10], B)
    assert np.array_equal(G.C[:, :10], C)
    assert list(G.state_labels[:10]) == modal_states(5)


def test_uncertain_nominal_and_perturbed_are_the_model_realisation():
    rng = np.random.default_rng(1)
    m = _model(E=1e-4 * rng.standard_normal((3, 2)))
    um = m.uncertain(dGamma=0.1 * np.abs(m.Gamma), dOmega=np.diag(0.02 * np.diag(m.Omega)),
                     db=0.1 * np.abs(m.phib), dc=0.1 * np.abs(m.cphi))
    ref = m.to_statespace()
    for X in "ABCD":
        assert np.array_equal(getattr(um.nominal, X), getattr(ref, X))
    assert um.nominal.state_labels == ref.state_labels
    # a perturbation: the realisation of the perturbed matrices, built here entry by entry
    d = rng.uniform(-1.0, 1.0, len(um.blocks))
    mats = {"Omega": m.Omega.copy(), "Gamma": m.Gamma.copy(), "b": m.phib.copy(),
            "c": m.cphi.copy()}
    for (_name, (kind, i, j), rep, beta), dk in zip(um.params, d):
        mats[kind][i, j] += beta * dk
        if rep == 2:
            mats[kind][j, i] += beta * dk
    w = np.linspace(1.0, 450.0, 500)
    H = ss_frf(*(getattr(um.perturbed(d), X) for X in "ABCD"), w)
    Hp = _closed_form(mats["Omega"], mats["Gamma"], mats["b"], mats["c"], w, 0) + m.E
    assert np.abs(H - Hp).max() < 1e-12 * np.abs(Hp).max()
    assert np.abs(H - ss_frf(ref.A, ref.B, ref.C, ref.D, w)).max() > 1e-3 * np.abs(Hp).max()
