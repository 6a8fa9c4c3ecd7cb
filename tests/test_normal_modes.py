"""Normal modes with non-proportional damping from complex modes (thesis 3.3) and the
state-space form of normal-mode models with correction terms (2.19)-(2.24).

The complex-mode models are built *exactly* from known normal-mode models (eigenvectors
of the first-order form 2.3, scaled mu = I by 2.6), so these tests do not depend on the
identification code."""

import warnings

import numpy as np
import pytest

import sdctrl as sd
from sdctrl.identification._proper import scaled_modes
from sdctrl.identification._properness import proper_modes
from sdctrl.updating import _costs as costs

FREQ_HZ = np.array([8.0, 13.0, 20.0, 20.5, 27.0, 34.0])   # close pair 20 / 20.5 Hz
ZETA = np.array([0.01, 0.015, 0.02, 0.008, 0.012, 0.01])


def _truth(ns=12, seed=1, coupling=0.8, E=None, F=None):
    """Exact truncated normal-mode model, full Gamma (strong coupling of the close pair),
    3 actuators collocated with sensors (``phib[:, a] = cphi[s, :]``)."""
    rng = np.random.default_rng(seed)
    w = 2 * np.pi * FREQ_HZ
    n = w.size
    d = 2 * ZETA * w
    G = np.diag(d)
    G[2, 3] = G[3, 2] = coupling * np.sqrt(d[2] * d[3])
    L = 0.05 * rng.standard_normal((n, n)) * np.sqrt(np.outer(d, d))
    G = G + 0.5 * (L + L.T) * (1 - np.eye(n))
    assert np.linalg.eigvalsh(G).min() > 0
    cphi = rng.standard_normal((ns, n))
    col = [(0, 0), (4, 1), (8, 2)] if ns > 8 else [(0, 0), (2, 1), (4, 2)]
    phib = np.stack([cphi[s] for s, _ in col], axis=1)
    sensors = [f"N{i + 1}.y" for i in range(ns)]
    actuators = [f"N{s + 1}.y:in" for s, _ in col]
    nm = sd.NormalModeModel(np.diag(w**2), G, cphi, phib, E=E, F=F, sensors=sensors,
                            actuators=actuators)
    return nm, col


def _complex_modes(nm, col, **kw):
    """ComplexModeModel of a normal-mode model: eigen-decomposition of (2.3), mu = I (2.6),
    residues ``R_j = cphi psi_j psi_j^T phib`` (2.9)."""
    n = nm.n
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-nm.Omega, -nm.Gamma]])
    lam, X = np.linalg.eig(A)
    keep = lam.imag > 0
    lam, psi = lam[keep], X[:n, keep]
    mu = np.einsum("ij,ik,kj->j", psi, nm.Gamma, psi) + 2 * lam * np.einsum("ij,ij->j", psi, psi)
    psi = psi / np.sqrt(mu)
    R = np.einsum("ij,kj->jik", nm.cphi @ psi, nm.phib.T @ psi)
    E = np.zeros((nm.ns, nm.na)) if nm.E is None else nm.E
    return sd.ComplexModeModel(lam, R, E=E, F=nm.F, sensors=nm.sensors,
                               actuators=nm.actuators, collocated=col, **kw)


def _errors(est, true):
    """Relative frequency, Gamma (Frobenius), cphi and phib errors after mode-sign alignment."""
    sg = np.sign(np.sum(est.cphi * true.cphi, axis=0))
    ef = np.abs(est.frequency - true.frequency).max() / true.frequency.max()
    eG = np.linalg.norm(est.Gamma * np.outer(sg, sg) - true.Gamma) / np.linalg.norm(true.Gamma)
    ec = np.linalg.norm(est.cphi * sg - true.cphi) / np.linalg.norm(true.cphi)
    eb = np.linalg.norm(est.phib * sg[:, None] - true.phib) / np.linalg.norm(true.phib)
    return ef, eG, ec, eb


def _ss_frf(sys, f):
    return np.moveaxis(sys(2j * np.pi * np.asarray(f)), -1, 0)


# --- normal_modes: exact data -------------------------------------------------------------
def test_exact_more_sensors_than_modes():
    E = 1e-6 * np.arange(36.0).reshape(12, 3)
    true, col = _truth(12, E=E)
    cm = _complex_modes(true, col)
    R0 = cm.residues.copy()
    nm = sd.normal_modes(cm, col)
    ef, eG, ec, eb = _errors(nm, true)
    # measured: ef 1e-15, eG 8e-13, ec 2e-14, eb 2e-14
    assert ef < 1e-5 and eG < 1e-3 and ec < 1e-4 and eb < 1e-4
    assert ef < 1e-12 and eG < 1e-9 and ec < 1e-11
    rec = nm.properness
    assert rec.pole_error < 1e-12
    assert np.allclose(np.sort_complex(nm.poles), np.sort_complex(cm.poles), rtol=1e-12)
    assert rec.properness_before < 1e-12 and rec.properness_after < 1e-12
    assert rec.delta_radius < 1e-12
    assert rec.positive_definite == {"mass": True, "stiffness": True, "damping": True}
    assert rec.c_T.shape == (12, 6) and rec.sensor_eigenvalues[:6].min() > 0
    assert rec.residue_error < 1e-12 and rec.collocation_error < 1e-12
    # E carried over, labels kept, Omega diagonal, strong coupling of the close pair found
    assert np.array_equal(nm.E, E) and nm.F is None
    assert nm.sensors == true.sensors and nm.actuators == true.actuators
    assert np.count_nonzero(nm.Omega - np.diag(np.diag(nm.Omega))) == 0
    assert abs(nm.Gamma[2, 3]) / np.sqrt(nm.Gamma[2, 2] * nm.Gamma[3, 3]) == \
        pytest.approx(abs(true.Gamma[2, 3]) / np.sqrt(true.Gamma[2, 2] * true.Gamma[3, 3]),
                      rel=1e-9)
    # FRFs identical, input untouched
    f = np.linspace(5, 40, 200)
    assert costs.relative_error(nm.frf(f), true.frf(f)) < 1e-11
    assert np.array_equal(cm.residues, R0)


def test_exact_as_many_sensors_as_modes():
    true, col = _truth(6)
    cm = _complex_modes(true, col)
    nm = sd.normal_modes(cm)                      # pairs taken from cm.collocated
    ef, eG, ec, eb = _errors(nm, true)
    assert ef < 1e-12 and eG < 1e-9 and ec < 1e-11 and eb < 1e-11
    assert np.array_equal(nm.properness.c_T, np.eye(6))
    assert nm.properness.pole_error < 1e-12


def test_one_collocated_pair_and_labels_suffice():
    true, col = _truth(12)
    cm = _complex_modes(true, col)
    nm = sd.normal_modes(cm, [("N5.y", "N5.y:in")])        # labels, a single pair
    ef, eG, ec, eb = _errors(nm, true)
    assert ef < 1e-12 and eG < 1e-9 and ec < 1e-11 and eb < 1e-11


def test_mode_selection_drops_out_of_band_poles():
    true, col = _truth(12)
    cm = _complex_modes(true, col)
    rng = np.random.default_rng(8)
    extra = 1e-6 * (rng.standard_normal((1, 12, 3)) + 1j * rng.standard_normal((1, 12, 3)))
    big = cm.replace(poles=np.r_[cm.poles, -3.0 + 2j * np.pi * 60], in_band=[True] * 6 + [False],
                     residues=np.concatenate([cm.residues, extra]))
    nm = sd.normal_modes(big, modes=big.in_band)
    assert nm.n == 6 and max(_errors(nm, true)) < 1e-10
    assert max(_errors(sd.normal_modes(big, modes=[0, 1, 2, 3, 4, 5]), true)) < 1e-10
    with pytest.raises(ValueError, match="modes: index out of range"):
        sd.normal_modes(big, modes=[0, 7])
    with pytest.raises(ValueError, match="modes as a boolean mask must have 7"):
        sd.normal_modes(big, modes=[True, False])
    with pytest.raises(ValueError, match="modes selects no mode"):
        sd.normal_modes(big, modes=np.zeros(7, bool))
    with pytest.raises(TypeError, match="modes must be"):
        sd.normal_modes(big, modes=[0.5, 1.5])


def test_round_off_asymptotic_terms_are_dropped():
    # a fit of exact data leaves E, F at round-off level: they must not become correction
    # terms (F would add rigid-body states to the StateSpace)
    true, col = _truth(12)
    cm = _complex_modes(true, col)
    cm = cm.replace(E=np.full((12, 3), 1e-19), F=np.full((12, 3), 1e-14))
    nm = sd.normal_modes(cm)
    assert nm.E is None and nm.F is None
    assert nm.properness.E_relative_size < 1e-12 and nm.properness.F_relative_size < 1e-12
    assert nm.to_statespace("acceleration").nstates == 2 * nm.n
    big = sd.normal_modes(cm.replace(E=np.full((12, 3), 1e-7), F=np.full((12, 3), 1e-2)))
    assert np.array_equal(big.E, np.full((12, 3), 1e-7))
    assert np.array_equal(big.F, np.full((12, 3), 1e-2))


def test_proportional_damping_gives_diagonal_gamma():
    true, col = _truth(12)
    true = true.proportional()
    nm = sd.normal_modes(_complex_modes(true, col))
    off = nm.Gamma - np.diag(np.diag(nm.Gamma))
    assert np.abs(off).max() < 1e-10 * np.abs(nm.Gamma).max()
    assert _errors(nm, true)[1] < 1e-10


def test_fewer_sensors_than_modes_keeps_the_rest_as_residual():
    """5 sensors for 6 modes (and fewer actuators: no transposition): 5 normal modes (3.46),
    the least proper one kept as it is in the residual dynamics, named with the reason."""
    true, col = _truth(12)
    cm = _complex_modes(true, col)
    few = cm.replace(residues=cm.residues[:, :5], E=cm.E[:5], F=cm.F[:5], sensors=cm.sensors[:5],
                     collocated=[(0, 0), (4, 1)])
    with pytest.warns(RuntimeWarning, match=r"fewer sensors \(5\) than modes"):
        nm = sd.normal_modes(few, std=False)
    assert nm.n == 5 and nm.residual.m == 1
    j = int(nm.residual.source[0])
    assert sorted(nm.properness.poles_used.tolist() + [j]) == list(range(6))
    assert "fewer sensors (5)" in nm.residual.reasons[0]
    assert nm.residual.poles[0] == few.poles[j]
    assert np.array_equal(nm.residual.residues[0], few.residues[j])
    f = np.linspace(5.0, 40.0, 300)
    assert costs.logls(nm.frf(f).H, few.frf(f).H) < 0.1          # measured 0.077


# --- non-proper (identified-like) complex modes: the Riccati correction ---------------------
@pytest.mark.parametrize("ns", [12, 6])
def test_perturbed_residues_small_riccati_root(ns):
    true, col = _truth(ns)
    cm = _complex_modes(true, col)
    rng = np.random.default_rng(5)
    eps = 1e-4
    R = cm.residues
    noise = rng.standard_normal(R.shape) + 1j * rng.standard_normal(R.shape)
    cmp = cm.replace(residues=R + eps * noise * np.abs(R).max(axis=(1, 2))[:, None, None])
    nm = sd.normal_modes(cmp)
    rec = nm.properness
    # the identified-like modes are not proper; the correction makes them proper
    assert 1e-5 < rec.properness_before < 1e-3
    assert rec.properness_after < 1e-14
    # delta is a root of (3.52) and the SMALL one: |eig| of the order of the properness error
    psi = rec.c_T.T @ rec.cpsi
    A0 = 2 * (psi @ psi.T).real
    G = 2 * (psi @ psi.conj().T).real
    d = rec.delta
    assert np.allclose(d, d.T)
    assert np.linalg.norm(A0 - d @ G - G @ d + d @ A0 @ d) < 1e-12 * np.linalg.norm(G)
    assert rec.delta_radius == pytest.approx(np.abs(np.linalg.eigvals(d)).max())
    assert rec.delta_radius < 5 * rec.properness_before < 1e-2
    assert 1 <= rec.newton_iterations <= 4
    # the correction is small: of the order of the perturbation
    dpsi = np.linalg.norm(rec.psi_proper - psi) / np.linalg.norm(psi)
    assert dpsi < 5 * eps
    # identified poles kept exactly (the transformation is exact for proper modes)
    assert rec.pole_error < 1e-12
    # accuracy of the order of the perturbation (Gamma ~ eps/zeta: damping is small)
    ef, eG, ec, eb = _errors(nm, true)
    # measured (ns=12 / 6): ef 1.3e-7 / 6.6e-7, eG 3.8e-3 / 4.3e-3, ec 1.6e-4 / 1.4e-4
    assert ef < 1e-5
    assert ec < 10 * eps and eb < 10 * eps
    assert eG < 100 * eps


def test_newton_from_zero_converges_quadratically():
    true, col = _truth(6)
    cm = _complex_modes(true, col)
    cpsi, _ = scaled_modes(cm.residues, col)
    rng = np.random.default_rng(2)
    psi = cpsi + 1e-3 * np.abs(cpsi).max() * (rng.standard_normal(cpsi.shape)
                                              + 1j * rng.standard_normal(cpsi.shape))
    psi_p, rec = proper_modes(psi)
    assert rec.newton_iterations <= 4 and rec.riccati_residual < 1e-13
    assert rec.delta_radius < 1e-2
    assert np.linalg.norm(psi_p @ psi_p.T + (psi_p @ psi_p.T).conj()) < 1e-13 * np.linalg.norm(
        psi_p @ psi_p.conj().T)
    # (3.52) as a CARE, G X + X G - X A0 X - A0 = 0: Hamiltonian [[G, -A0], [A0, -G]].  The
    # stable-subspace root a generic solver returns is a huge, useless root; the small root
    # found by Newton from 0 is the one of the anti-stable subspace.
    A0 = 2 * (psi @ psi.T).real
    G = 2 * (psi @ psi.conj().T).real
    n = psi.shape[0]
    ev, V = np.linalg.eig(np.block([[G, -A0], [A0, -G]]))
    roots = {}
    for name, sel in (("stable", ev.real < 0), ("antistable", ev.real > 0)):
        X = (V[n:, sel] @ np.linalg.inv(V[:n, sel])).real
        assert np.linalg.norm(A0 - X @ G - G @ X + X @ A0 @ X) < 1e-6 * np.linalg.norm(G)
        roots[name] = X
    # measured: |eig| 6.8e3 for the stable-subspace root, 6.6e-3 for the small one
    assert np.abs(np.linalg.eigvals(roots["stable"])).max() > 100
    assert np.allclose(rec.delta, roots["antistable"], atol=1e-10)


def test_non_positive_definite_mass_is_reported():
    # a mode with its collocated residues of the wrong sign (as a wrongly signed or
    # non-collocated "collocated" transfer) cannot give a positive definite mass (3.45)
    true, col = _truth(12)
    cm = _complex_modes(true, col)
    R = cm.residues.copy()
    R[3] *= -1
    bad = cm.replace(residues=R)
    with pytest.warns(RuntimeWarning, match="mass .* not positive definite"):
        nm = sd.normal_modes(bad, std=False)
    # never all or nothing: the other five are normal modes, mode 3 stays as it is
    assert nm.properness.poles_used.tolist() == [0, 1, 2, 4, 5]
    assert nm.residual.source.tolist() == [3]
    assert "mass" in nm.residual.reasons[0] and "not positive definite" in nm.residual.reasons[0]
    f = np.linspace(5.0, 40.0, 300)
    assert costs.logls(nm.frf(f).H, bad.frf(f).H) < 1e-4               # measured 7.0e-6


def test_non_positive_damping_is_warned_and_reported():
    true, col = _truth(12)
    cm = _complex_modes(true, col)
    rng = np.random.default_rng(5)
    R = cm.residues
    noise = rng.standard_normal(R.shape) + 1j * rng.standard_normal(R.shape)
    cmp = cm.replace(residues=R + 1e-2 * noise * np.abs(R).max(axis=(1, 2))[:, None, None])
    with pytest.warns(RuntimeWarning, match="damping matrix is not positive semi-definite"):
        nm = sd.normal_modes(cmp)
    assert nm.properness.positive_definite["damping"] is False
    assert nm.properness.damping_eigenvalues.min() < 0
    assert nm.properness.pole_error < 1e-12            # still the identified poles


def test_non_positive_damping_warning_says_what_to_do():
    true, col = _truth(12)
    cm = _complex_modes(true, col)
    rng = np.random.default_rng(5)
    R = cm.residues
    noise = rng.standard_normal(R.shape) + 1j * rng.standard_normal(R.shape)
    cmp = cm.replace(residues=R + 1e-2 * noise * np.abs(R).max(axis=(1, 2))[:, None, None])
    with pytest.warns(RuntimeWarning) as rec:
        nm = sd.normal_modes(cmp)
    w = next(w for w in rec if "positive semi-definite" in str(w.message))
    msg = str(w.message)
    assert w.filename == __file__                    # points at the caller's line
    ec = nm.properness.damping_eigenvalues
    rel = ec.min() / np.abs(ec).max()
    assert f"{rel:.1e} of it" in msg                 # the size, relative to the spectrum
    assert "can be used as is" in msg and "damping_eigenvalues" in msg
    # the advice follows the size: noise for a small one, a bad pole or pair for a large one
    assert ("more lines or less noise" in msg) == (rel > -1e-2)
    assert ("collocated pair" in msg) == (rel <= -1e-2)


def test_large_correction_is_refused():
    true, col = _truth(12)
    cm = _complex_modes(true, col)
    R = cm.residues.copy()
    R[2] *= 1j                                   # phase-rotated mode: far from proper
    bad = cm.replace(residues=R)
    with pytest.warns(RuntimeWarning, match=r"pole\(s\) 2 .*Riccati"):
        nm = sd.normal_modes(bad, std=False)
    assert nm.properness.poles_used.tolist() == [0, 1, 3, 4, 5]
    assert nm.residual.source.tolist() == [2]
    assert "Riccati equation (3.52) has no small real root" in nm.residual.reasons[0]
    assert nm.properness.poles_left_out.size == 0          # nothing lost
    f = np.linspace(5.0, 40.0, 300)
    assert costs.logls(nm.frf(f).H, bad.frf(f).H) < 1e-4               # measured 4.6e-6


# --- the thesis's comparison (3.3.4): full Gamma vs Gamma forced diagonal ------------------
def test_full_gamma_fits_much_better_than_proportional():
    true, col = _truth(12, coupling=0.9)
    f = np.linspace(5.0, 40.0, 600)
    test = true.frf(f)
    nm = sd.normal_modes(_complex_modes(true, col))
    prop = nm.proportional()
    full_log, prop_log = costs.logls(nm.frf(f), test), costs.logls(prop.frf(f), test)
    full_rel = costs.relative_error(nm.frf(f), test)
    prop_rel = costs.relative_error(prop.frf(f), test)
    # measured: logLS 3.6e-26 vs 1.4e-2; relative error 3.2e-13 vs 0.148
    assert full_log < 1e-20 and prop_log > 1e-3
    assert full_rel < 1e-10 and prop_rel > 0.05
    assert prop_log > 1e15 * full_log
    # the same from non-proper, identification-like complex modes (residues perturbed 1e-4)
    cm = _complex_modes(true, col)
    rng = np.random.default_rng(11)
    R = cm.residues
    noise = rng.standard_normal(R.shape) + 1j * rng.standard_normal(R.shape)
    nm = sd.normal_modes(cm.replace(residues=R + 1e-4 * noise * np.abs(R).max(axis=(1, 2))[
        :, None, None]))
    full_log = costs.logls(nm.frf(f), test)
    prop_log = costs.logls(nm.proportional().frf(f), test)
    # measured: logLS 7.9e-7 vs 1.4e-2 (relative error 2.2e-4 vs 0.148)
    assert full_log < 1e-5 and prop_log > 1e3 * full_log


# --- bad input -------------------------------------------------------------------------------
def test_bad_input():
    true, col = _truth(12)
    cm = _complex_modes(true, col)
    with pytest.raises(TypeError, match="cm must be a ComplexModeModel"):
        sd.normal_modes(true, col)
    with pytest.raises(ValueError, match="collocated: sensor index 12 out of range"):
        sd.normal_modes(cm, [(12, 0)])
    with pytest.raises(ValueError, match="collocated: actuator index 3 out of range"):
        sd.normal_modes(cm, [(0, 3)])
    with pytest.raises(TypeError, match="collocated"):
        sd.normal_modes(cm, 5)
    with pytest.raises(TypeError, match="collocated pairs must hold integer"):
        sd.normal_modes(cm, [(0.5, 0)])
    with pytest.raises(ValueError, match="collocated: unknown sensor label"):
        sd.normal_modes(cm, [("nope", 0)])
    with pytest.raises(ValueError, match="collocated must hold at least one"):
        sd.normal_modes(cm.replace(collocated=()))
    with pytest.raises(ValueError, match="collocated must hold at least one"):
        sd.normal_modes(cm, [])
    with pytest.raises(ValueError, match="tol must be"):
        sd.normal_modes(cm, tol=-1.0)
    with pytest.raises(ValueError, match="maxiter must be"):
        sd.normal_modes(cm, maxiter=0)
    with pytest.raises(TypeError, match="std must be True or False"):
        sd.normal_modes(cm, std=1)
    # a mode with no response at the collocated sensor cannot be scaled: kept as it is
    R = cm.residues.copy()
    R[1, 0, :] = 0.0
    with pytest.warns(RuntimeWarning, match="mode 1 is not observed at the collocated pairs"):
        nm = sd.normal_modes(cm.replace(residues=R), [(0, 0)], std=False)
    assert nm.residual.source.tolist() == [1] and nm.n == 5
    assert "mode 1 is not observed at the collocated pairs" in nm.residual.reasons[0]
    # no pole at all can be a mode: an error naming each pole's reason
    R[:, 0, :] = 0.0
    with pytest.raises(ValueError, match="no pole can be made a normal mode"):
        sd.normal_modes(cm.replace(residues=R), [(0, 0)])
    # nothing the caller passed is modified
    pairs = [[0, 0], [4, 1]]
    sd.normal_modes(cm, pairs)
    assert pairs == [[0, 0], [4, 1]]


# --- NormalModeModel.to_statespace with correction terms -----------------------------------
@pytest.mark.parametrize("quantity", ["displacement", "velocity", "acceleration"])
def test_statespace_equals_frf_without_E(quantity):
    true, col = _truth(12)
    nm = sd.normal_modes(_complex_modes(true, col))
    f = np.linspace(2.0, 60.0, 400)
    H = nm.frf(f, quantity).H
    G = nm.to_statespace(quantity)
    assert np.abs(_ss_frf(G, f) - H).max() < 1e-8 * np.abs(H).max()
    assert G.output_labels == [s.replace(".", "_") for s in nm.sensors]
    assert G.input_labels == ["N1_y:in_u", "N5_y:in_u", "N9_y:in_u"]
    assert G.nstates == 2 * nm.n


@pytest.mark.parametrize("quantity", ["displacement", "velocity", "acceleration"])
def test_statespace_with_E_correction_mode(quantity):
    rng = np.random.default_rng(3)
    E = 1e-4 * rng.standard_normal((12, 3))
    true, col = _truth(12, E=E)
    nm = sd.normal_modes(_complex_modes(true, col))
    f = np.linspace(2.0, 60.0, 400)
    H = nm.frf(f, quantity).H
    k = {"displacement": 0, "velocity": 1, "acceleration": 2}[quantity]
    fc = 10 * true.frequency.max()                      # default cut-off, Hz
    err = np.abs(_ss_frf(nm.to_statespace(quantity), f) - H)
    if k == 0:
        assert err.max() < 1e-8 * np.abs(H).max()
    else:
        Eterm = np.abs(E)[None] * (2 * np.pi * f[:, None, None]) ** k
        bound = 2 * f[:, None, None] / fc * Eterm
        assert np.all(err <= bound * (1 + 1e-6) + 1e-9 * np.abs(H).max())
        # and the correction mode really matters: without it the E term would be missing
        assert np.abs(_ss_frf(nm.replace(E=None).to_statespace(quantity), f) - H).max() > \
            2.5 * err.max()
    # an explicit cut-off halves the error when doubled
    if k:
        err2 = np.abs(_ss_frf(nm.to_statespace(quantity, omega_c=4 * np.pi * fc), f) - H)
        assert err2.max() < 0.6 * err.max()


@pytest.mark.parametrize("quantity", ["displacement", "velocity", "acceleration"])
def test_statespace_with_low_frequency_correction_F(quantity):
    rng = np.random.default_rng(4)
    E = 1e-5 * rng.standard_normal((12, 3))
    F = 50.0 * rng.standard_normal((12, 3))
    true, col = _truth(12, F=F)
    nm = sd.normal_modes(_complex_modes(true, col))
    assert np.array_equal(nm.F, F) and nm.E is None
    f = np.linspace(2.0, 60.0, 400)
    H = nm.frf(f, quantity).H
    # F/s^2 is in the FRF
    H0 = nm.replace(F=None).frf(f, quantity).H
    s = 2j * np.pi * f[:, None, None]
    k = {"displacement": 0, "velocity": 1, "acceleration": 2}[quantity]
    assert np.allclose(H - H0, F[None] / s**2 * s**k, rtol=1e-12, atol=0)
    # realised exactly by one rigid-body correction mode per actuator on request (2.24)
    G = nm.to_statespace(quantity, rigid_body=True)
    assert G.nstates == 2 * nm.n + 2 * 3
    assert np.abs(_ss_frf(G, f) - H).max() < 1e-8 * np.abs(H).max()
    # by default by stable critically damped modes a decade below the lowest mode (no band):
    # exactly F (s + 3 w_f) / (s + w_f)^3, within 3 (w_f / w)^2 (1 + 3 w_f / w) of F / s^2
    G = nm.to_statespace(quantity)
    assert G.nstates == 2 * nm.n + 3 * 3
    assert np.linalg.eigvals(G.A).real.max() < 0
    wf = 0.1 * 2 * np.pi * FREQ_HZ[0]
    HF = H0 + F[None] * (s + 3 * wf) / (s + wf) ** 3 * s**k
    assert np.abs(_ss_frf(G, f) - HF).max() < 1e-8 * np.abs(HF).max()
    x = wf / (2 * np.pi * f[:, None, None])
    rel = np.abs(HF - H) / np.abs(F[None] / s**2 * s**k)
    assert np.all(rel <= 3 * x**2 * (1 + 3 * x)) and rel[f >= 8.0].max() < 0.03
    # with both E (displacement exact) and F
    nmEF = nm.replace(E=E)
    if k == 0:
        HEF = nmEF.frf(f).H
        G = nmEF.to_statespace(rigid_body=True)
        assert np.abs(_ss_frf(G, f) - HEF).max() < 1e-8 * np.abs(HEF).max()
    # copies keep F
    assert np.array_equal(nm.proportional().F, F)


def test_statespace_with_static_correction_modes_from_fe():
    # static correction modes (2.21)-(2.22) carried as modes by an FE-derived model
    n = 8
    K = np.diag(np.full(n, 2e4)) - np.diag(np.full(n - 1, 1e4), 1) - np.diag(np.full(n - 1, 1e4),
                                                                                 -1)
    M = np.diag(1.0 + 0.1 * np.arange(n))
    C = 1e-4 * K + np.diag([0, 0, 3.0, 0, 0, 0, 0, 0])
    fe = sd.FEModel(M, K, C, dofs=[f"N{i}.x" for i in range(n)])
    nm = fe.normal_mode_model(["N1.x", "N6.x"], ["N1.x", "N3.x", "N6.x"], 3, static=True)
    assert nm.n_static == 2
    f = np.linspace(1.0, 30.0, 300)
    for q in ("displacement", "velocity", "acceleration"):
        H = nm.frf(f, q).H
        G = nm.to_statespace(q)
        assert np.abs(_ss_frf(G, f) - H).max() < 1e-8 * np.abs(H).max()
        assert G.output_labels == ["N1_x", "N3_x", "N6_x"]


def test_F_validation():
    true, _ = _truth(12)
    with pytest.raises(ValueError, match=r"F \(ns x na of [a-z, ]+\) must have shape \(12, 3\)"):
        true.replace(F=np.ones((3, 12)))
    with pytest.raises(ValueError, match=r"F \(ns x na of [a-z, ]+\) must contain only finite"):
        true.replace(F=np.full((12, 3), np.nan))
    F = np.ones((12, 3))
    m = true.replace(F=F)
    F[0, 0] = 5.0
    assert m.F[0, 0] == 1.0                           # copied, not a view of the input
