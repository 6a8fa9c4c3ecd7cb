"""Tests of sdctrl.robust._uncertainty: exact LFT (5.5), physical bounds, multi-test statistics
(5.2.3)."""
import numpy as np
import pytest

from sdctrl._lib.statespace import ss_frf
from sdctrl.modal._normal_model import NormalModeModel
from sdctrl.robust._uncertainty import (
    default_bounds,
    modal_density_bound,
    multi_test_statistics,
    psd_gamma_bound,
    uncertain,
)


def _omega_gamma(sys):
    """``Omega`` and ``Gamma`` of a realisation ``A = [[0, I], [-Omega, -Gamma]]`` (2.15)."""
    n = sys.nstates // 2
    A = np.asarray(sys.A)
    return -A[n:, :n], -A[n:, n:]


def two_mode():
    """Thesis two-mode example (5.6)."""
    return NormalModeModel(Omega=np.diag([1.0, 1.21]), Gamma=np.diag([0.04, 0.022]),
                           cphi=np.array([[1.0, 1], [2, -1], [-2, 0]]), phib=np.array([[1.0], [1]]))


def three_mode():
    rng = np.random.default_rng(3)
    return NormalModeModel(Omega=np.diag([4.0, 9.0, 25.0]), Gamma=np.diag([0.08, 0.12, 0.2]),
                           cphi=rng.normal(size=(2, 3)), phib=rng.normal(size=(3, 2)),
                           E=0.01 * rng.normal(size=(2, 2)))


def close_lft(P, blocks, deltas, w):
    reps = [r for _, r in blocks]
    r = sum(reps)
    Dl = np.diag(np.repeat(deltas, reps))
    H = ss_frf(P.A, P.B, P.C, P.D, w)
    P11, P12, P21, P22 = H[:, :r, :r], H[:, :r, r:], H[:, r:, :r], H[:, r:, r:]
    return P22 + P21 @ Dl @ np.linalg.solve(np.eye(r) - P11 @ Dl, P12)


STRUCTURES = [
    (two_mode, {"dGamma": [[0.01, 0.02], [0, 0.005]]}),
    (two_mode, {"dOmega": [[0.1, 0.05], [0.05, 0.0]], "db": [[0.1], [0.0]]}),
    (two_mode, {"dGamma": [[0.01, 0.02], [0, 0]], "dOmega": [[0.1, 0.05], [0.05, 0]],
                    "db": [[0.1], [0.2]], "dc": np.full((3, 2), 0.1)}),
    (three_mode, {"dGamma": psd_gamma_bound(np.diag([0.08, 0.12, 0.2]), 0.5),
                      "dOmega": modal_density_bound(np.diag([4.0, 9.0, 25.0]), 0.1),
                      "dc": np.full((2, 3), 0.05), "db": np.full((3, 2), 0.05)}),
]


@pytest.mark.parametrize("make,bounds", STRUCTURES)
def test_lft_closure_matches_direct_perturbation(make, bounds):
    m = make()
    um = uncertain(m, **bounds)
    P, blocks = um.lft()
    r = sum(rep for _, rep in blocks)
    assert all(name.startswith("delta") for name in P.input_labels[:r])
    assert all(name.startswith("delta") for name in P.output_labels[:r])
    assert P.input_labels[r:] == list(um.nominal.input_labels)
    w = np.linspace(0.05, 1.5 * np.sqrt(np.max(np.diag(m.Omega))), 80)
    rng = np.random.default_rng(0)
    for _ in range(5):
        d = rng.uniform(-1, 1, len(blocks))
        s = um.perturbed(d)
        H = ss_frf(s.A, s.B, s.C, s.D, w)
        Hl = close_lft(P, blocks, d, w)
        assert np.max(np.abs(Hl - H)) <= 1e-8 * np.max(np.abs(H))
        # parameters within bounds
        Om, Ga = _omega_gamma(s)
        assert np.all(np.abs(Om - m.Omega) <= um.dOmega + 1e-15)
        assert np.all(np.abs(Ga - m.Gamma) <= um.dGamma + 1e-15)
        assert np.allclose(Om, Om.T) and np.allclose(Ga, Ga.T)


def test_symmetric_pair_is_one_repeated_scalar():
    um = uncertain(two_mode(), dGamma=[[0, 0.02], [0.02, 0]])
    _, blocks = um.lft()
    assert blocks == [("delta_Gamma_0_1", 2)]
    _Om, Ga = _omega_gamma(um.perturbed([0.5]))
    assert Ga[0, 1] == Ga[1, 0] == pytest.approx(0.01)


def test_nominal_and_sample_deterministic():
    m = two_mode()
    um = uncertain(m, dGamma=[[0.01, 0], [0, 0]])
    nom = um.nominal
    ref = m.to_statespace()
    w = np.linspace(0.5, 1.5, 20)
    assert np.allclose(ss_frf(nom.A, nom.B, nom.C, nom.D, w), ss_frf(ref.A, ref.B, ref.C, ref.D, w))
    a, b = um.sample(3, seed=4), um.sample(3, seed=4)
    assert all(np.array_equal(x.A, y.A) for x, y in zip(a, b))
    assert not np.array_equal(a[0].A, a[1].A)


def test_bad_inputs():
    m = two_mode()
    with pytest.raises(ValueError, match="dGamma"):
        uncertain(m, dGamma=np.zeros((3, 3)))
    with pytest.raises(ValueError, match="dc"):
        uncertain(m, dc=-np.ones((3, 2)))
    um = uncertain(m, dGamma=[[0.01, 0], [0, 0]])
    with pytest.raises(ValueError, match="deltas"):
        um.perturbed([0.1, 0.2])


def test_boundary_validation_names_the_argument_and_keeps_the_input():
    m = two_mode()
    dG = np.array([[0.01, 0.02], [0.0, 0.005]])
    um = uncertain(m, dGamma=dG)
    assert np.array_equal(dG, [[0.01, 0.02], [0.0, 0.005]])        # caller's array untouched
    with pytest.raises(TypeError, match="dOmega"):
        uncertain(m, dOmega=np.ones((2, 2)) * 1j)
    with pytest.raises(TypeError, match="db"):
        uncertain(m, db=[["a"], ["b"]])
    assert len(um.params) == 3                                       # 2 diagonal, 1 pair
    with pytest.raises(ValueError, match="deltas"):
        um.perturbed([[0.1, 0.2, 0.3]])
    with pytest.raises(ValueError, match="deltas"):                 # a scaling mistake
        um.perturbed([1e7, 0.0, 0.0])
    with pytest.raises(TypeError, match="deltas"):
        um.perturbed([0.1, 0.2 + 1j, 0.0])
    # a large but sane delta (a margin of 1000 x the bounds) still builds the model
    _, Ga = _omega_gamma(um.perturbed([1e3, 0.0, 0.0]))
    assert Ga[0, 0] == pytest.approx(m.Gamma[0, 0] + 1e3 * 0.01)
    with pytest.raises(ValueError, match="n"):
        um.sample_deltas(0)
    with pytest.raises(TypeError, match="seed"):
        um.sample(2, seed=0.5)
    with pytest.raises(ValueError, match="seed"):
        um.sample_deltas(2, seed=-1)
    with pytest.raises(TypeError, match="n_samples"):
        um.frf_envelope([0.1, 0.2], n_samples=2.5)


def test_frf_envelope_of_the_vertices_alone():
    """``n_samples=0`` and ``max_vertices=0`` are allowed: the envelope then spans only the
    vertices, or only the nominal model."""
    um = uncertain(two_mode(), dGamma=[[0, 0.015], [0.015, 0]])
    f = np.linspace(0.1, 0.25, 30)
    w = 2 * np.pi * f
    nominal = um.frf_envelope(f, n_samples=0, max_vertices=0)
    assert np.array_equal(nominal["mag_min"], nominal["mag_max"])
    assert np.allclose(nominal["mag_max"], np.abs(nominal["nominal"]))
    env = um.frf_envelope(f, n_samples=0)
    H = [np.abs(ss_frf(s.A, s.B, s.C, s.D, w)) for s in (um.perturbed([-1.0]),
                                                           um.perturbed([1.0]))]
    hi = np.maximum(np.maximum(*H), np.abs(env["nominal"]))
    assert np.allclose(env["mag_max"], hi, rtol=1e-12)


def test_physical_bounds():
    G = np.array([[0.04, 0.0], [0.0, 0.022]])
    g = psd_gamma_bound(G)
    assert g[0, 1] == pytest.approx(np.sqrt(0.04 * 0.022)) and g[0, 0] == 0
    # at the bound Gamma is singular (PSD limit), beyond it indefinite
    Gb = G + np.array([[0, 1], [1, 0]]) * g[0, 1]
    assert np.min(np.linalg.eigvalsh(Gb)) == pytest.approx(0, abs=1e-12)
    Gc = G + np.array([[0, 1], [1, 0]]) * g[0, 1] * 1.01
    assert np.min(np.linalg.eigvalsh(Gc)) < 0
    o = modal_density_bound(np.diag([1.0, 1.21]))
    assert o[0, 1] == pytest.approx(0.21)
    b = default_bounds(two_mode(), 0.5, 0.1)
    assert b["dGamma"][0, 1] == pytest.approx(0.5 * np.sqrt(0.04 * 0.022))


def test_frf_envelope_contains_samples():
    um = uncertain(two_mode(), dGamma=[[0, 0.015], [0.015, 0]])
    f = np.linspace(0.1, 0.25, 60)
    env = um.frf_envelope(f, n_samples=30, seed=1)
    # vertices are in the envelope exactly and the envelope is non-trivial at the zero
    for d in (-1.0, 1.0):
        s = um.perturbed([d])
        H = np.abs(ss_frf(s.A, s.B, s.C, s.D, 2 * np.pi * f))
        assert (np.all(H <= env["mag_max"] * (1 + 1e-12))
                and np.all(H >= env["mag_min"] * (1 - 1e-12)))
    assert np.max(env["mag_max"] / env["mag_min"]) > 1.5


def test_multi_test_statistics_recovers_spread():
    m = three_mode()
    m = m.replace(cphi=np.random.default_rng(5).normal(size=(6, 3)), E=None,
                  sensors=[f"s{i}" for i in range(6)])
    rng = np.random.default_rng(7)
    sg, so, sb, sc = 0.01, 0.05, 0.02, 0.03
    models = [m]
    for _ in range(400):
        dG = rng.normal(scale=sg, size=(3, 3))
        dG = np.triu(dG) + np.triu(dG, 1).T
        dO = rng.normal(scale=so, size=(3, 3))
        dO = np.triu(dO) + np.triu(dO, 1).T
        mm = m.replace(Gamma=m.Gamma + dG, Omega=m.Omega + dO,
                       phib=m.phib + rng.normal(scale=sb, size=m.phib.shape),
                       cphi=m.cphi + rng.normal(scale=sc, size=m.cphi.shape))
        perm = rng.permutation(3)
        T = np.eye(3)[:, perm] @ np.diag(rng.choice([-1.0, 1.0], 3))
        models.append(mm.replace(Omega=T.T @ mm.Omega @ T, Gamma=T.T @ mm.Gamma @ T,
                                 phib=T.T @ mm.phib, cphi=mm.cphi @ T))
    res = multi_test_statistics(models)
    assert np.allclose(res.mean.Omega, m.Omega, atol=4 * so / np.sqrt(400))
    assert np.allclose(res.mean.cphi, m.cphi, atol=4 * sc / np.sqrt(400))
    np.testing.assert_allclose(res.std["Gamma"], sg, rtol=0.15)
    np.testing.assert_allclose(res.std["Omega"], so, rtol=0.15)
    np.testing.assert_allclose(res.std["phib"], sb, rtol=0.15)
    np.testing.assert_allclose(res.std["cphi"], sc, rtol=0.15)
    pd = res.tables["gamma_pct_pd_bound"]
    assert pd[0, 1] == pytest.approx(100 * res.std["Gamma"][0, 1] / np.sqrt(0.08 * 0.12), rel=0.05)
    um = uncertain(res.mean, **res.bounds)
    assert len(um.blocks) > 0


def _with_fixed_parts():
    """The thesis two-mode example (5.6) with every certain part a model can carry: a residual
    flexibility E, a residual mass F (realised by correction modes a decade below the band,
    2.19-2.20) and residual dynamics (one complex pole kept as it is, 3.26-3.33)."""
    from sdctrl.modal import ResidualDynamics
    m = two_mode()
    res = ResidualDynamics(np.array([-0.05 + 2.5j]), np.array([[[0.02 + 0.01j], [-0.03j],
                                                                  [0.01 + 0j]]]),
                           sensors=m.sensors, actuators=m.actuators)
    return m.replace(E=np.array([[0.01], [-0.02], [0.005]]), F=np.full((3, 1), 0.01),
                     residual=res)


def test_e_f_and_residual_dynamics_are_certain_parts():
    """E, F and the residual dynamics are fixed parts of the plant: the uncertain model's
    nominal StateSpace is the model's own, its LFT closes exactly on the perturbed models,
    the perturbation moves only Omega/Gamma/phib/cphi, and robust stability runs on it."""
    import control

    from sdctrl.modal._normal_realisation import default_omega_f
    from sdctrl.robust import robust_stability
    mF = _with_fixed_parts()
    bounds = {"dGamma": np.diag([0.01, 0.005]), "dOmega": [[0.1, 0.05], [0.05, 0.1]]}
    um = uncertain(mF, **bounds)
    with pytest.warns(RuntimeWarning, match="residual dynamics"):       # the door agrees
        assert mF.uncertain(**bounds).nominal.nstates == um.nominal.nstates
    own, nom = mF.to_statespace(), um.nominal
    for X in "ABCD":                                   # bit for bit, state names included
        assert np.array_equal(getattr(nom, X), getattr(own, X))
    assert nom.state_labels == own.state_labels and nom.nstates == 2 * 2 + 2 + 3
    assert [x for x in nom.state_labels[-3:]] == ["zr0", "dzr0", "ddzr0"]
    P, blocks = um.lft()
    w = np.linspace(0.05, 3.0, 80)
    rng = np.random.default_rng(0)
    for _ in range(5):
        d = rng.uniform(-1, 1, len(blocks))
        s = um.perturbed(d)
        H = ss_frf(s.A, s.B, s.C, s.D, w)
        assert np.max(np.abs(close_lft(P, blocks, d, w) - H)) <= 1e-8 * np.max(np.abs(H))
        # the certain part is untouched: the perturbed model is the model with the perturbed
        # Omega/Gamma and the nominal's E, residual dynamics and F's correction modes (their
        # corner w_f the nominal's: by default it follows the modes' frequencies)
        Om, Ga = _omega_gamma(control.ss(s.A[:4, :4], s.B[:4], s.C[:, :4], 0 * s.D))
        mm = mF.replace(Omega=Om, Gamma=Ga, omega_f=default_omega_f(mF))
        ref = mm.to_statespace()
        np.testing.assert_allclose(ss_frf(s.A, s.B, s.C, s.D, w),
                                   ss_frf(ref.A, ref.B, ref.C, ref.D, w), rtol=1e-12,
                                   atol=1e-14)
    # F's correction modes are stable (a triple pole a decade below the band), so the loop
    # can be robustly stable: collocated rate feedback on the first sensor
    assert np.all(np.linalg.eigvals(nom.A).real < 0)
    K = control.ss(control.tf([0.5, 0.0], [1.0, 2.0])) * control.ss([], [], [], [[1.0, 0.0, 0.0]])
    r = robust_stability(um, K)
    assert r.stable and 0 < r.margin <= r.margin_lower * (1 + 1e-6)
    cl = control.feedback(um.perturbed(r.worst_delta * 1.001), K, sign=-1)
    assert np.max(np.linalg.eigvals(cl.A).real) >= -1e-9
    for d in rng.uniform(-1, 1, size=(100, len(blocks))):
        d = 0.99 * r.margin * d / np.max(np.abs(d))
        cl = control.feedback(um.perturbed(d), K, sign=-1)
        assert np.max(np.linalg.eigvals(cl.A).real) < 0
    # without F the same model is the same plant less F's response (3 states fewer)
    um0 = uncertain(mF.replace(F=None), **bounds)
    assert um0.nominal.nstates == nom.nstates - 3


def test_compact_lft_reads_and_drives_few_signals():
    """Every entry of every matrix uncertain on 8 modes: 192 channels, but they read only the
    modal displacements, velocities and actuator inputs and drive only the modal forces and
    the sensors, so the channel response is L Mc R with a 19 x 13 core (no 192 x 192 object)."""
    rng = np.random.default_rng(4)
    n, ns, na = 8, 5, 3
    m = NormalModeModel(Omega=np.diag(np.arange(1.0, n + 1) ** 2), Gamma=0.05 * np.eye(n),
                        cphi=rng.normal(size=(ns, n)), phib=rng.normal(size=(n, na)))
    um = uncertain(m, dGamma=np.full((n, n), 0.01), dOmega=np.full((n, n), 0.1),
                   db=np.full((n, na), 0.05), dc=np.full((ns, n), 0.05))
    c = um.compact_lft()
    N = sum(r for _, r in um.blocks)
    assert N == 2 * n * n + n * na + ns * n == 192
    assert c.L.shape == (N, 2 * n + na) and c.R.shape == (n + ns, N)
    assert np.all(np.count_nonzero(c.L, axis=1) == 1) and np.all(np.count_nonzero(c.R, axis=0) == 1)
    P, _ = um.lft()
    np.testing.assert_array_equal(P.B[:, :N], c.Bv @ c.R)
    np.testing.assert_array_equal(P.C[:N], c.L @ c.Cv)
    np.testing.assert_array_equal(P.D[:N, N:], c.L @ c.Dvu)
    np.testing.assert_array_equal(P.D[N:, :N], c.Dyv @ c.R)
