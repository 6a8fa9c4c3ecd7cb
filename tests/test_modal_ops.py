"""NormalModeModel operations: reduced-coordinate modifications (4.17), D-strut feedback
(5.3-5.4), proportional copy and the uncertain door, checked against direct FE solutions."""

import numpy as np
import pytest

import sdctrl as sd


def _chain(n=6, seed=0):
    """Free-fixed spring-mass chain with proportional damping and a few labelled DOFs."""
    rng = np.random.default_rng(seed)
    m = 1.0 + rng.random(n)
    k = 1e4 * (1.0 + rng.random(n))
    K = np.zeros((n, n))
    for i in range(n):
        K[i, i] += k[i]
        if i + 1 < n:
            K[i, i] += k[i + 1]
            K[i, i + 1] = K[i + 1, i] = -k[i + 1]
    M = np.diag(m)
    C = 1e-4 * K + 0.05 * M
    dofs = [f"N{i + 1}.x" for i in range(n)]
    return sd.FEModel(M, K, C, dofs=dofs)


def _full_model(fe):
    b = fe.point(["N2.x", "N6.x"])
    c = fe.point(["N1.x", "N3.x", "N6.x"]).T
    return fe.normal_mode_model(b, c, fe.N), b, c


def test_with_feedback_equals_direct_fe_solution():
    fe = _chain()
    nm, b, c = _full_model(fe)
    strut = fe.point(["N4.x"]) - fe.point(["N2.x"])           # relative axial pair
    kv, kp = 30.0, 2e3
    G0, O0, s0 = nm.Gamma.copy(), nm.Omega.copy(), strut.copy()
    cl = nm.with_feedback(strut, strut.T, kp=kp, kv=kv)
    f = np.linspace(1.0, 40.0, 300)
    direct = sd.FEModel(fe.M, fe.K + kp * strut @ strut.T, fe.C + kv * strut @ strut.T,
                        dofs=fe.dofs).frf(f, b, c)
    H = cl.frf(f).H
    assert np.abs(H - direct.H).max() < 1e-9 * np.abs(direct.H).max()
    # Omega stays diagonal (normal modes of the stiffened structure), damping is full
    assert np.count_nonzero(cl.Omega - np.diag(np.diag(cl.Omega))) == 0
    assert np.abs(cl.Gamma - np.diag(np.diag(cl.Gamma))).max() > 1e-3 * np.abs(cl.Gamma).max()
    # the same loop given in modal form
    cl2 = nm.with_feedback(nm.shapes.T @ strut, strut.T @ nm.shapes, kp=kp, kv=kv, modal=True)
    assert np.abs(cl2.frf(f).H - direct.H).max() < 1e-9 * np.abs(direct.H).max()
    # its StateSpace carries the same FRF
    G = cl.to_statespace()
    Hs = np.moveaxis(G(2j * np.pi * f), -1, 0)
    assert np.abs(Hs - direct.H).max() < 1e-8 * np.abs(direct.H).max()
    # neither the nominal model nor the caller's arrays were modified
    assert np.array_equal(nm.Gamma, G0) and np.array_equal(nm.Omega, O0)
    assert np.array_equal(strut, s0)


def test_modified_equals_fe_with_mass_and_stiffness_changes():
    fe = _chain()
    nm, b, c = _full_model(fe)
    phi = nm.shapes
    dM = np.zeros((fe.N, fe.N))
    dM[2, 2] = 0.7                               # added mass at N3
    dK = np.zeros((fe.N, fe.N))
    dK[[0, 0, 1, 1], [0, 1, 0, 1]] = 3e3 * np.array([1, -1, -1, 1])   # stiffer first link
    dC = np.zeros((fe.N, fe.N))
    dC[5, 5] = 4.0
    mod = nm.modified(dmu=phi.T @ dM @ phi, dGamma=phi.T @ dC @ phi, dOmega=phi.T @ dK @ phi)
    f = np.linspace(1.0, 40.0, 300)
    direct = sd.FEModel(fe.M + dM, fe.K + dK, fe.C + dC, dofs=fe.dofs).frf(f, b, c)
    assert np.abs(mod.frf(f).H - direct.H).max() < 1e-9 * np.abs(direct.H).max()
    # mass-normalised again: new frequencies are those of the modified FE model
    f_ref, _ = sd.FEModel(fe.M + dM, fe.K + dK, dofs=fe.dofs).modes(fe.N)
    assert np.allclose(mod.frequency, f_ref, rtol=1e-10)
    T = mod.transformation
    assert np.allclose(T.T @ (np.eye(fe.N) + phi.T @ dM @ phi) @ T, np.eye(fe.N), atol=1e-10)
    # the same changes given on physical DOFs: HybridModel.with_modification (5.2), one name
    # for physical dM, dC, dK, ``modified`` for modal ones; a truncated basis (4 of 6 modes)
    h = sd.HybridModel(nm.Omega[:4, :4], nm.Gamma[:4, :4], nm.cphi[:, :4], nm.phib[:4],
                       shapes=phi[:, :4], dofs=nm.dofs)
    p4 = phi[:, :4]
    by_dofs = h.with_modification(dM, dC, dK)
    by_modes = h.modified(dmu=p4.T @ dM @ p4, dGamma=p4.T @ dC @ p4, dOmega=p4.T @ dK @ p4)
    H = by_modes.frf(f).H
    assert np.abs(by_dofs.frf(f).H - H).max() < 1e-12 * np.abs(H).max()
    assert np.abs(H - direct.H).max() > 1e-4 * np.abs(direct.H).max()     # truncated: not exact
    assert not hasattr(h, "modify")


def test_modified_rejects_bad_changes():
    nm, _, _ = _full_model(_chain())
    n = nm.n
    with pytest.raises(ValueError, match="dmu"):
        nm.modified(dmu=np.ones((n, n + 1)))
    with pytest.raises(ValueError, match="dOmega must be symmetric"):
        nm.modified(dOmega=np.triu(np.ones((n, n))))
    with pytest.raises(ValueError, match="positive definite"):
        nm.modified(dmu=-2 * np.eye(n))


def test_with_feedback_validation():
    nm, _, _ = _full_model(_chain())
    n, N = nm.n, nm.shapes.shape[0]
    with pytest.raises(ValueError, match="b must have shape"):
        nm.with_feedback(np.ones((N + 1, 1)), np.ones((1, N)), kv=1.0)
    with pytest.raises(ValueError, match="not collocated"):
        bb = np.zeros((N, 1))
        bb[0] = 1
        cc = np.zeros((1, N))
        cc[0, 3] = 1
        nm.with_feedback(bb, cc, kv=1.0)
    with pytest.raises(ValueError, match="kp must be"):
        nm.with_feedback(np.ones((n, 2)), np.ones((2, n)), kp=np.ones(3), modal=True)
    bare = nm.replace(shapes=None, dofs=None)
    with pytest.raises(ValueError, match="no shapes"):
        bare.with_feedback(np.ones((N, 1)), np.ones((1, N)), kv=1.0)


def test_proportional_copy_and_uncertain_door():
    fe = _chain()
    fe = sd.FEModel(fe.M, fe.K, fe.C + np.diag([0, 0, 0, 5.0, 0, 0]), dofs=fe.dofs)
    nm, _, _ = _full_model(fe)
    prop = nm.proportional()
    assert np.array_equal(prop.Gamma, np.diag(np.diag(nm.Gamma)))
    assert np.abs(nm.Gamma - prop.Gamma).max() > 0
    um = nm.uncertain(dGamma=0.1 * np.abs(nm.Gamma))
    assert um.nominal.nstates == 2 * nm.n


def test_operations_keep_the_correction_terms():
    nm, _, _ = _full_model(_chain())
    E = 1e-6 * np.ones((nm.ns, nm.na))
    F = 2.0 * np.ones((nm.ns, nm.na))
    m = nm.replace(E=E, F=F)
    n = m.n
    for out in (m.proportional(), m.modified(dOmega=10.0 * np.eye(n)),
                m.with_feedback(np.ones((n, 1)), np.ones((1, n)), kv=0.1, modal=True)):
        assert np.array_equal(out.E, E) and np.array_equal(out.F, F)
    # the FRF carries E + F/s^2 and the StateSpace realises F exactly (2.24)
    f = np.linspace(1.0, 40.0, 100)
    s = 2j * np.pi * f[:, None, None]
    assert np.allclose(m.frf(f).H - nm.frf(f).H, E + F / s**2, rtol=1e-10, atol=0)
    Hs = np.moveaxis(m.to_statespace(rigid_body=True)(2j * np.pi * f), -1, 0)
    assert np.abs(Hs - m.frf(f).H).max() < 1e-9 * np.abs(m.frf(f).H).max()
