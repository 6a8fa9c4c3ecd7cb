"""Finite element core: element accuracy vs closed-form theory, eigen-solvers (dense vs
sparse, rigid bodies), static correction (2.21)/(4.24), modal models and validation."""

import numpy as np
import pytest
import scipy.sparse as sp

import sdctrl as sd
from sdctrl.fe import FEModel, assemble, bar_matrices, beam_matrices

AL = {"al": {"E": 70e9, "rho": 2700.0, "nu": 0.33}}
E, RHO, LEN = 70e9, 2700.0, 1.0
BW, BH = 0.02, 0.01                      # rectangular beam section 20 x 10 mm
SEC = {"s": {"A": BW * BH, "Iz": BW * BH**3 / 12, "Iy": BH * BW**3 / 12, "J": 4.6e-9}}
BETA_L = np.array([1.8751040687, 4.6940911330, 7.8547574382])   # cantilever roots


def _line(ne, kind="beam", length=LEN):
    nodes = {f"N{i}": (i * length / ne, 0.0, 0.0) for i in range(ne + 1)}
    els = [(kind, f"N{i}", f"N{i + 1}", "al", "s") for i in range(ne)]
    return nodes, els


def _cantilever(ne=20, sparse=True):
    nodes, els = _line(ne)
    return assemble(nodes, els, AL, SEC, bc=["N0"], sparse=sparse)


def _free_beam(ne=12):
    nodes, els = _line(ne)
    return assemble(nodes, els, AL, SEC)


# --- element accuracy ------------------------------------------------------------------------
def test_cantilever_matches_euler_bernoulli():
    """Mesh: 20 equal 3-D beam elements (consistent mass), clamped at N0."""
    fe = _cantilever(20)
    f, _ = fe.modes(8)
    A = SEC["s"]["A"]
    f_z = BETA_L**2 / (2 * np.pi * LEN**2) * np.sqrt(E * SEC["s"]["Iz"] / (RHO * A))  # x-y plane
    f_y = BETA_L**2 / (2 * np.pi * LEN**2) * np.sqrt(E * SEC["s"]["Iy"] / (RHO * A))  # x-z plane
    theory = np.sort(np.concatenate([f_z, f_y]))
    # among the 8 lowest modes (a torsion mode lies between), the 3+3 bending modes
    near = np.array([f[np.argmin(np.abs(f - t))] for t in theory])
    err = np.abs(near / theory - 1)
    assert err.max() < 5e-3 and len(set(near)) == 6
    assert err[0] < 1e-5                     # first mode essentially exact on this mesh
    # consistent-mass FE frequencies are upper bounds (Rayleigh-Ritz)
    assert np.all(near >= theory * (1 - 1e-9))


def test_bar_axial_modes_match_theory():
    """Mesh: 50 bars along x, fixed at N0, transverse DOFs removed (pure axial)."""
    ne = 50
    nodes, els = _line(ne, "bar")
    bc = ["N0"] + [f"N{i}.{d}" for i in range(1, ne + 1) for d in "yz"]
    c = np.sqrt(E / RHO)
    theory = (2 * np.arange(1, 4) - 1) * c / (4 * LEN)
    f_cons, _ = assemble(nodes, els, AL, SEC, bc=bc).modes(3)
    f_lump, _ = assemble(nodes, els, AL, SEC, bc=bc, lumped=True).modes(3)
    assert np.abs(f_cons / theory - 1).max() < 5e-3
    assert np.abs(f_lump / theory - 1).max() < 5e-3
    assert np.abs(f_cons[0] / theory[0] - 1) < 1e-4
    assert np.all(f_cons > theory) and np.all(f_lump < theory)     # the classic bounds


def test_element_rigid_body_motion_is_stress_free_and_mass_exact():
    rng = np.random.default_rng(3)
    xa, xb = rng.standard_normal((5, 3)), rng.standard_normal((5, 3))
    K, M = beam_matrices(xa, xb, E, 26e9, 2e-4, 1e-8, 3e-8, 2e-8, RHO,
                         orientation=None)
    for e in range(5):
        for t in range(3):                       # translations
            u = np.zeros(12)
            u[[t, t + 6]] = 1.0
            assert np.abs(K[e] @ u).max() < 1e-6 * np.abs(K[e]).max()
            m = RHO * 2e-4 * np.linalg.norm(xb[e] - xa[e])
            assert u @ M[e] @ u == pytest.approx(m, rel=1e-12)
        # small rotation about z through node a: u = theta ^ r
        th = np.array([0.3, -0.2, 0.5])
        u = np.concatenate([np.zeros(3), th, np.cross(th, xb[e] - xa[e]), th])
        assert np.abs(K[e] @ u).max() < 1e-6 * np.abs(K[e]).max() * np.abs(u).max()
        assert np.allclose(K[e], K[e].T) and np.allclose(M[e], M[e].T)
    Kb, _Mb = bar_matrices(xa, xb, E, 1e-4, RHO)
    u = np.tile(rng.standard_normal(3), 2)
    assert np.abs(Kb @ u).max() < 1e-6 * np.abs(Kb).max()


# --- eigen-solvers --------------------------------------------------------------------------
def test_sparse_and_dense_paths_agree():
    fe_s = _cantilever(30, sparse=True)
    fe_d = _cantilever(30, sparse=False)
    assert fe_s.sparse and not fe_d.sparse
    f1, p1 = fe_s.modes(12, method="sparse")
    f2, p2 = fe_d.modes(12, method="dense")
    f3, _p3 = fe_s.modes(12, method="dense")
    assert np.allclose(f1, f2, rtol=1e-10) and np.allclose(f2, f3, rtol=1e-12)
    M = fe_d.M
    assert np.allclose(p1.T @ (M @ p1), np.eye(12), atol=1e-10)
    assert np.allclose(p2.T @ (M @ p2), np.eye(12), atol=1e-10)
    mac = np.abs(np.einsum("ij,ij->j", p1, M @ p2))
    assert np.all(mac > 1 - 1e-8)            # same shapes (each mode is distinct here)
    b = fe_d.point(["N30.y", "N15.z"])
    assert np.allclose(fe_s.static_response(b), fe_d.static_response(b), rtol=1e-10, atol=0)
    assert np.allclose(fe_s.static_correction(b, p1), fe_d.static_correction(b, p2),
                       rtol=1e-7, atol=1e-9 * np.abs(fe_d.static_response(b)).max())


def test_rigid_body_modes_of_free_structure():
    fe = _free_beam(12)
    for method in ("dense", "sparse"):
        f, phi = fe.modes(10, method=method)
        assert np.all(f[:6] < 1e-3) and f[6] > 10.0          # 6 rigid bodies, then flexible
        K = fe.K.toarray()
        assert np.abs(K @ phi[:, :6]).max() < 1e-6 * np.abs(K).max()
    R = fe.rigid_modes()
    assert R.shape == (fe.N, 6)
    assert np.allclose(R.T @ (fe.M @ R), np.eye(6), atol=1e-9)
    # the rigid subspace contains the three translations of the whole beam
    for d in "xyz":
        t = np.array([1.0 if lab.endswith(f".{d}") else 0.0 for lab in fe.dofs])
        resid = t - R @ (R.T @ (fe.M @ t))
        assert np.linalg.norm(resid) < 1e-6 * np.linalg.norm(t)
    assert _cantilever(10).rigid_modes().shape[1] == 0


# --- static correction ------------------------------------------------------------------------
def test_static_correction_completes_the_static_response_exactly():
    fe = _cantilever(25)
    b = fe.point(["N25.y", "N12.z", "N7.x"])
    c = fe.point(["N25.y", "N20.z", "N3.y", "N25.x"]).T
    f, phi = fe.modes(5)
    w2 = (2 * np.pi * f) ** 2
    phiC = fe.static_correction(b, phi)
    Kinv_b = np.linalg.solve(fe.K.toarray(), b)          # independent dense reference
    retained = c @ phi @ ((phi.T @ b) / w2[:, None])
    ref = c @ Kinv_b
    # to the retained modes' accuracy (K^-1 M phi = phi / omega^2 to 1e-10 here): 8.4e-11
    # of the largest gain (exact by construction while phi_C subtracted the modes' part
    # from K^-1 b, which cancelled on suspended structures)
    assert np.allclose(c @ phiC + retained, ref, rtol=1e-9, atol=1e-9 * np.abs(ref).max())
    # mass- and stiffness-orthogonal to the retained modes (2.22)
    assert np.abs(phi.T @ (fe.M @ phiC)).max() < 1e-8 * np.abs(phiC).max()
    assert np.abs(phi.T @ (fe.K @ phiC)).max() < 1e-8 * np.abs(fe.K @ phiC).max()
    # the augmented normal-mode model has the exact static gain c K^-1 b
    nm = fe.normal_mode_model(b, c, 5, static=True)
    assert nm.n_static == 3 and nm.n == 8
    dc = nm.cphi @ np.linalg.solve(nm.Omega, nm.phib)
    # cond(K) of this 25-element cantilever is 1.5e8: cross terms that are exactly zero come out
    # at ~1e-10 of the largest gain through the modal solve, so the absolute floor sits at 1e-9
    assert np.allclose(dc, ref, rtol=1e-8, atol=1e-9 * np.abs(ref).max())
    # correction modes are critically damped, above the retained modes
    wc = np.sqrt(np.diag(nm.Omega)[5:])
    assert np.allclose(np.diag(nm.Gamma)[5:], 2 * wc)
    assert wc.min() > 2 * np.pi * f[-1]
    # E-form gives the same static gain through the feedthrough
    nmE = fe.normal_mode_model(b, c, 5, static="E")
    dcE = nmE.cphi @ np.linalg.solve(nmE.Omega, nmE.phib) + nmE.E
    assert np.allclose(dcE, ref, rtol=1e-9, atol=1e-10 * np.abs(ref).max())


def test_static_correction_of_free_structure_uses_inertia_relief():
    fe = _free_beam(12)
    _f, phi = fe.modes(9)
    b = fe.point(["N12.y", "N6.z"])
    K, M = fe.K.toarray(), fe.M.toarray()
    lam, V = np.linalg.eigh(np.linalg.solve(np.linalg.cholesky(M), np.linalg.solve(
        np.linalg.cholesky(M), K).T))     # L^-1 K L^-T
    L = np.linalg.cholesky(M)
    Phi = np.linalg.solve(L.T, V)          # all mass-normalised modes
    flex = lam > 1e-6 * lam.max()
    assert np.count_nonzero(~flex) == 6
    G = Phi[:, flex] @ (Phi[:, flex].T / lam[flex][:, None])     # flexible flexibility
    x = fe.static_response(b)
    assert np.allclose(x, G @ b, rtol=1e-7, atol=1e-9 * np.abs(G @ b).max())
    phiC = fe.static_correction(b, phi)
    keep = np.arange(fe.N)[flex][:3]       # the 3 retained flexible modes of phi
    ref = G @ b - Phi[:, keep] @ (Phi[:, keep].T @ b / lam[keep][:, None])
    assert np.allclose(phiC, ref, rtol=1e-6, atol=1e-8 * np.abs(ref).max())


def test_principal_static_modes_are_mass_orthonormal_and_drop_dependent_columns():
    fe = _cantilever(15)
    _f, phi = fe.modes(4)
    b = fe.point(["N15.y", "N10.y"])
    Ps = fe.static_correction(np.hstack([b, b @ [[1.0], [2.0]]]), phi)   # 3rd dependent
    V = fe.principal_static_modes(Ps)
    assert V.shape[1] == 2
    assert np.allclose(V.T @ (fe.M @ V), np.eye(2), atol=1e-10)
    # same span: Ps is reproduced from V by M-projection
    assert np.allclose(V @ (V.T @ (fe.M @ Ps)), Ps, atol=1e-9 * np.abs(Ps).max())


def test_static_correction_improves_the_band_response():
    nodes, els = _line(20)
    fe = assemble(nodes, els, AL, SEC, bc=["N0"], rayleigh=(0.5, 2e-6))
    b, c = "N20.y", ["N20.y", "N10.y"]
    f, _ = fe.modes(5)                   # y1, z1, y2, z2 retained; y3 (144 Hz) truncated
    band = np.linspace(1.0, 0.3 * f[4], 40)
    ref = fe.frf(band, b, c)
    err = {}
    for static, sdamp in ((False, "critical"), (True, "projected"), (True, "critical"),
                          ("E", "critical")):
        nm = fe.normal_mode_model(b, c, 4, static=static, static_damping=sdamp)
        err[static, sdamp] = (np.abs(nm.frf(band).H - ref.H).max(axis=0)
                              / np.abs(ref.H).max(axis=0))
    base = err[False, "critical"]
    # the residual left is the dynamic amplification of the truncated modes, ~(f/f5)^2
    assert np.all(err[True, "projected"] < 0.2 * base)
    assert np.all(err["E", "critical"] < 0.2 * base)
    # a critically damped correction mode at the Ritz frequency (~f5) has a phase error
    # ~2 f / f5 in the band: better than truncation, worse than the alternatives
    assert np.all(err[True, "critical"] < base)
    assert np.all(err[True, "critical"] > err[True, "projected"])
    assert nm.sensors == ("N20.y", "N10.y") and nm.actuators == ("N20.y",)
    assert nm.dofs == fe.dofs and nm.shapes.shape == (fe.N, 4) and nm.E.shape == (2, 1)


def test_projected_damping_reproduces_the_full_model():
    nodes, els = _line(8)
    els = els + [("dashpot", "N8.y", None, 3.0), ("dashpot", "N4.z", "N8.z", 2.0)]
    fe = assemble(nodes, els, AL, SEC, bc=["N0"], rayleigh=(0.5, 1e-6))
    nm = fe.normal_mode_model(["N8.y", "N4.z"], ["N8.y", "N5.z"], fe.N)
    _f, phi = fe.modes(fe.N)
    assert np.allclose(nm.Gamma, phi.T @ fe.C.toarray() @ phi, atol=1e-9)
    off = nm.Gamma - np.diag(np.diag(nm.Gamma))
    assert np.abs(off).max() > 1e-3 * np.abs(np.diag(nm.Gamma)).max()   # non-proportional
    freq = np.linspace(5, 400, 50)
    H_nm = nm.frf(freq, "velocity").H
    H_fe = fe.frf(freq, ["N8.y", "N4.z"], ["N8.y", "N5.z"], "velocity").H
    assert np.allclose(H_nm, H_fe, rtol=1e-7, atol=1e-9 * np.abs(H_fe).max())


# --- shapes -------------------------------------------------------------------------------------
def test_point_and_strut_shapes():
    nodes = {"A": (0, 0, 0), "B": (1.0, 1.0, 0), "C": (2.0, 0, 0)}
    els = [("bar", "A", "B", "al", "s"), ("bar", "B", "C", "al", "s"),
           ("bar", "A", "C", "al", "s"), ("mass", "B", 1.0)]
    fe = assemble(nodes, els, AL, SEC, bc=["A.x", "A.y", "A.z", "C.y", "C.z", "B.z"])
    b = fe.strut("A", "B")
    e = np.array([1.0, 1.0]) / np.sqrt(2)
    assert b[fe.dof_index(["B.x", "B.y"]), 0] == pytest.approx(e)
    assert np.count_nonzero(b) == 2          # A is fixed: its part vanishes
    # a rigid translation along x of the free DOFs does not stretch the strut C-C
    s2 = fe.strut("B", "C")
    u = np.array([1.0 if lab.endswith(".x") else 0.0 for lab in fe.dofs])
    assert s2[:, 0] @ u == pytest.approx(0.0, abs=1e-15)
    p = fe.point("B", direction=(3.0, 4.0, 0.0))
    assert p[fe.dof_index(["B.x", "B.y"]), 0] == pytest.approx([0.6, 0.8])
    assert np.array_equal(fe.point(["B.y", "C.x"]).T @ fe.point(["B.y", "C.x"]), np.eye(2))
    with pytest.raises(ValueError, match="unknown DOF label"):
        fe.point("B.q")
    with pytest.raises(ValueError, match="node_b"):
        fe.strut("A", "Z")


def test_assembly_sparse_equals_dense_and_pairs_recorded():
    nodes, els = _line(5)
    els = els + [("spring", "N5.y", None, 1e3), ("mass", "N3", 2.0, (0.1, 0.1, 0.1))]
    s = assemble(nodes, els, AL, SEC, bc=["N0"], rayleigh=(0.1, 1e-5))
    d = assemble(nodes, els, AL, SEC, bc=["N0"], rayleigh=(0.1, 1e-5), sparse=False)
    assert np.allclose(s.K.toarray(), d.K) and np.allclose(s.M.toarray(), d.M)
    assert np.allclose(s.C.toarray(), d.C)
    assert s.elements[0] == ("N0", "N1") and len(s.elements) == 5
    assert s.nodes["N5"] == (1.0, 0.0, 0.0)
    # total translational mass = beam mass + lumped mass (minus the element terms of the clamped
    # node)
    tx = np.array([1.0 if lab.endswith(".x") else 0.0 for lab in d.dofs])
    beam_mass = RHO * SEC["s"]["A"] * LEN
    assert tx @ d.M @ tx == pytest.approx(beam_mass * (1 - 2 / 15) + 2.0, rel=1e-12)


# --- validation ---------------------------------------------------------------------------------
def test_constructor_validation():
    M, K = np.eye(3), np.diag([1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="M must be a square"):
        FEModel(np.ones((3, 2)), K)
    with pytest.raises(ValueError, match=r"K must have shape \(3, 3\)"):
        FEModel(M, np.eye(2))
    with pytest.raises(ValueError, match="K must be symmetric"):
        FEModel(M, K + np.triu(np.ones((3, 3)), 1))
    with pytest.raises(ValueError, match="M must be positive definite"):
        FEModel(np.diag([1.0, 0.0, 1.0]), K)
    with pytest.raises(ValueError, match="M must be positive definite"):
        FEModel(np.array([[1.0, 2, 0], [2, 1, 0], [0, 0, 1]]), K)
    bad = sp.csr_matrix(np.array([[1.0, 2, 0], [2, 1, 0], [0, 0, 1]]))
    with pytest.raises(ValueError, match="M must be positive definite"):
        FEModel(bad, sp.csr_matrix(K))
    with pytest.raises(ValueError, match="C must be symmetric"):
        FEModel(M, K, C=np.triu(np.ones((3, 3))))
    with pytest.raises(ValueError, match="finite"):
        FEModel(M, np.diag([1.0, np.nan, 1.0]))
    with pytest.raises(ValueError, match="dofs must have 3 labels"):
        FEModel(M, K, dofs=["a.x", "b.x"])
    with pytest.raises(TypeError, match="M must be"):
        FEModel(None, K)
    with pytest.raises(ValueError, match="elements"):
        FEModel(M, K, nodes={"a": (0, 0, 0)}, elements=[("a", "b")])


def test_inputs_not_modified_and_model_immutable():
    M, K = np.eye(3), np.diag([1.0, 2.0, 3.0])
    M0, K0 = M.copy(), K.copy()
    fe = FEModel(M, K)
    M[0, 0] = 5.0
    assert fe.M[0, 0] == 1.0 and np.array_equal(K, K0) and M0[0, 0] == 1.0
    with pytest.raises(AttributeError):
        fe.K = K
    with pytest.raises(ValueError):
        fe.M[0, 0] = 2.0                    # read-only storage
    _f, phi = fe.modes(2)
    phi[:] = 0
    assert np.abs(fe.modes(2)[1]).max() > 0  # cache not exposed


def test_method_argument_validation():
    fe = _cantilever(5)
    with pytest.raises(ValueError, match="n must lie"):
        fe.modes(0)
    with pytest.raises(TypeError, match="n must be an integer"):
        fe.modes(2.5)
    with pytest.raises(ValueError, match="method"):
        fe.modes(2, method="lanczos")
    _f, phi = fe.modes(3)
    with pytest.raises(ValueError, match="mass-normalised"):
        fe.static_correction("N5.y", 2 * phi)
    with pytest.raises(ValueError, match=r"b must have shape \(N=30, k\)"):
        fe.static_correction(np.ones((4, 1)), phi)
    with pytest.raises(ValueError, match="damping"):
        fe.normal_mode_model("N5.y", "N5.y", 3, damping=-0.1)
    with pytest.raises(ValueError, match="static"):
        fe.normal_mode_model("N5.y", "N5.y", 3, static="yes")
    with pytest.raises(ValueError, match="unknown material"):
        assemble({"a": (0, 0, 0), "b": (1, 0, 0)}, [("bar", "a", "b", "steel", "s")], AL, SEC)
    with pytest.raises(ValueError, match="unknown node"):
        assemble({"a": (0, 0, 0)}, [("bar", "a", "z", "al", "s")], AL, SEC)


def test_top_level_name_and_statespace_labels():
    assert sd.FEModel is FEModel
    fe = _cantilever(6)
    nm = fe.normal_mode_model(["N6.y"], ["N6.y", "N3.z"], 4, static=True)
    sys = nm.to_statespace("displacement")
    assert list(sys.input_labels) == ["N6_y_u"] and list(sys.output_labels) == ["N6_y", "N3_z"]
    # collocated driving point: passive, Im H <= 0 for displacement/force
    H = nm.frf(np.linspace(1, 500, 200)).H[:, 0, 0]
    assert np.all(H.imag <= 1e-15 * np.abs(H).max())


def test_free_structure_modal_model_with_static_modes():
    nodes, els = _line(12)
    fe = assemble(nodes, els, AL, SEC, rayleigh=(0.0, 2e-6))
    f, _ = fe.modes(10)
    b, c = ["N12.y", "N6.z"], ["N12.y", "N6.z", "N0.y"]
    band = np.linspace(2.0, 0.3 * f[9], 30)
    ref = fe.frf(band, b, c, "acceleration")
    err = {}
    for static in (False, True):
        nm = fe.normal_mode_model(b, c, 9, static=static, static_damping="projected")
        assert np.allclose(np.diag(nm.Omega)[:6], 0.0, atol=1e-6)     # rigid bodies kept
        err[static] = np.abs(nm.frf(band, "acceleration").H - ref.H).max() / np.abs(ref.H).max()
    assert err[True] < 0.1 * err[False]
    # correction modes are mass-orthogonal to the rigid-body modes (inertia relief)
    R = fe.rigid_modes()
    assert np.abs(R.T @ (fe.M @ nm.shapes[:, 9:])).max() < 1e-8


@pytest.mark.parametrize("sigma", [1e300, -1e300, 1e40])
def test_sparse_modes_far_shift_is_a_value_error_with_advice(sigma):
    """Issue 25: sigma far outside the spectrum raised ArpackError("Starting vector is zero")."""
    n = 30
    K = sp.diags([2 * np.ones(n), -np.ones(n - 1), -np.ones(n - 1)], [0, 1, -1]).tocsr() * 1e4
    fe = sd.FEModel(sp.eye(n).tocsr(), K)
    with pytest.raises(ValueError, match=r"sigma = .* \(rad/s\)\^2 .*\(2 pi f\)\^2"):
        fe.modes(3, "sparse", sigma=sigma)
    f, _ = fe.modes(3, "sparse", sigma=-1.0)                # a shift below the spectrum works
    lam = 2e4 * (1 - np.cos(np.arange(1, n + 1) * np.pi / (n + 1)))
    np.testing.assert_allclose(np.sort(f), np.sqrt(np.sort(lam)[:3]) / (2 * np.pi), rtol=1e-10)
