"""Tests of sdctrl.robust.mu._upper / sdctrl.robust.mu._frequency_sweep: D-G upper bounds of mixed
mu against SLICOT AB13MD, closed forms and brute force; the factored (L K R) path;
Hamiltonian-certified intervals."""
import numpy as np
import pytest

from sdctrl.robust.mu._upper import BlockStructure, Factored, certify_dg, dg_upper, evaluate
from sdctrl.robust.mu._frequency_sweep import FactoredSystem, cheap_bounds, interval


def _rand(rng, *shape):
    return rng.normal(size=shape) + 1j * rng.normal(size=shape)


@pytest.mark.parametrize("case", range(6))
def test_dg_bound_agrees_with_ab13md(case):
    """AB13MD (Fan-Tits-Doyle D-G bound, SLICOT) on the structures it accepts: 1x1 real blocks,
    complex scalars and full complex blocks.  Measured: agreement to 2e-5 relative."""
    slycot = pytest.importorskip("slycot")
    rng = np.random.default_rng(case)
    structures = [([1, 1, 1, 1], [1, 1, 1, 1]), ([1, 1, 1, 1], [1, 1, 2, 2]),
                  ([1, 1, 2], [1, 2, 2]), ([1, 1, 1, 1, 1, 1], [1, 1, 1, 2, 2, 1]),
                  ([2, 1, 1, 2], [2, 1, 1, 2]), ([1, 1, 1, 1, 1, 1], [1] * 6)]
    sizes, types = structures[case]
    N = sum(sizes)
    M = _rand(rng, N, N)
    ab = slycot.ab13md(M, np.array(sizes), np.array(types))[0]
    kinds = tuple("real" if t == 1 else ("complex" if r == 1 else "full")
                  for r, t in zip(sizes, types))
    st = BlockStructure(tuple(sizes), kinds)
    ub, x = dg_upper(Factored(M), st)
    assert ub == pytest.approx(ab, rel=0.01)
    assert ub <= ab * (1 + 1e-3)
    D, G = st.dense_scalings(x)
    assert certify_dg(M, D, G) == pytest.approx(ub, rel=1e-9)     # a certificate, exactly
    assert np.all(np.linalg.eigvalsh(D) > 0)
    for i, kind in enumerate(kinds):                               # G lives on real blocks only
        if kind != "real":
            sl = slice(sum(sizes[:i]), sum(sizes[:i + 1]))
            assert not np.any(G[sl, sl])


def test_repeated_real_scalar_is_exact():
    """``delta I_2`` (a symmetric Gamma/Omega pair): real mu is the largest real eigenvalue
    modulus of M, 0 when M has none; independent scalars would give a larger value."""
    rng = np.random.default_rng(3)
    rep, ind = BlockStructure((2,), ("real",)), BlockStructure((1, 1), ("real", "real"))
    for _ in range(3):
        T = _rand(rng, 2, 2)
        lam = rng.uniform(-3, 3, 2)
        M = T @ np.diag(lam) @ np.linalg.inv(T)
        assert dg_upper(Factored(M), rep)[0] == pytest.approx(np.max(np.abs(lam)), rel=1e-6)
    T = np.array([[1.0, 2.0], [0.5j, -1.0]])
    M = T @ np.diag([1 + 1j, 2 - 0.5j]) @ np.linalg.inv(T)
    assert dg_upper(Factored(M), rep)[0] <= 1e-6 * np.linalg.norm(M, 2)
    assert dg_upper(Factored(M), ind)[0] > 0.3 * np.linalg.norm(M, 2)


@pytest.mark.parametrize("structure", [
    ((1, 2, 2, 1, 3, 2), ("real", "real", "complex", "complex", "full", "full")),
    ((1,) * 7, ("real", "complex", "real", "full", "real", "complex", "real"))])   # scalar path
def test_factored_path_equals_dense_and_gradient(structure):
    rng = np.random.default_rng(1)
    st = BlockStructure(*structure)
    L, K, R = _rand(rng, st.N, 2), _rand(rng, 2, 3), rng.normal(size=(3, st.N))
    low, dense = Factored(K, L, R), Factored(L @ K @ R)
    assert low.low_rank and not dense.low_rank
    x = 0.3 * rng.normal(size=st.nv)
    lam_l, g_l = evaluate(low, st, x)
    lam_d, g_d = evaluate(dense, st, x)
    D, G = st.dense_scalings(x)
    assert lam_l == pytest.approx(lam_d, rel=1e-10)
    assert lam_d == pytest.approx(certify_dg(dense.dense(), D, G) ** 2, rel=1e-10)
    np.testing.assert_allclose(g_l, g_d, rtol=1e-7, atol=1e-9 * np.abs(g_d).max())
    h = 1e-6
    fd = np.array([(evaluate(low, st, x + h * e, False)[0] - evaluate(low, st, x - h * e, False)[0])
                   / (2 * h) for e in np.eye(st.nv)])
    np.testing.assert_allclose(g_l, fd, atol=1e-6 * np.abs(g_l).max())
    assert dg_upper(low, st)[0] == pytest.approx(dg_upper(dense, st)[0], rel=1e-4)


def _system(seed=0):
    """A stable 6-state core with feedthrough, 3 channels of which one repeated."""
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(6, 6))
    A -= (np.max(np.linalg.eigvals(A).real) + 0.3) * np.eye(6)
    fs = FactoredSystem(A, rng.normal(size=(6, 2)), rng.normal(size=(3, 6)),
                        0.3 * rng.normal(size=(3, 2)), rng.normal(size=(4, 3)),
                        rng.normal(size=(2, 4)))
    return fs, BlockStructure.real_repeated((2, 1, 1), 0.01)


def test_hamiltonian_interval_matches_brute_force():
    fs, st = _system()
    fa = fs.augmented(0.01)
    w0 = 1.3
    b, x = dg_upper(Factored(fa.core(w0)[0], fa.L, fa.R), st)
    w = np.linspace(0, 8, 16001)
    vals = np.sqrt([evaluate(Factored(k, fa.L, fa.R), st, x, False)[0] for k in fa.core(w)])
    for beta in (1.02 * b, 1.3 * b, 3 * b):
        lo, hi = interval(fa, st, x, beta, w0)
        assert lo <= w0 <= hi
        inside = (w >= lo) & (w <= hi)
        assert np.all(vals[inside] <= beta * (1 + 1e-9))          # certified where claimed
        step = w[1] - w[0]                                         # and no wider than true
        if hi < 8:
            assert np.any(vals[(w > hi) & (w < hi + 2 * step)] > beta * (1 - 1e-6))
        if lo > 0:
            assert np.any(vals[(w < lo) & (w > lo - 2 * step)] > beta * (1 - 1e-6))
    lo, hi = interval(fa, st, x, 0.9 * b, w0)                       # not certified: empty
    assert lo > hi


def test_cheap_bound_is_a_certificate():
    fs, st = _system(1)
    fa = fs.augmented(0.01)
    w = np.linspace(0.1, 5, 7)
    Ks = fa.core(w)
    cb, d = cheap_bounds(Ks, fa.L, fa.R, st)
    for k, c, di in zip(Ks, cb, d):
        fm = Factored(k, fa.L, fa.R)
        assert np.sqrt(evaluate(fm, st, st.start(di), False)[0]) == pytest.approx(c, rel=1e-9)
        assert dg_upper(fm, st)[0] <= c * (1 + 1e-12)


def test_dg_upper_takes_a_plain_matrix():
    """The public ``sdctrl.robust.mu.dg_upper`` needs no private type: a full complex block
    has mu = sigma_max (the bound is exact), and the factored form gives the same bound."""
    from sdctrl.robust.mu import BlockStructure, dg_upper
    from sdctrl.robust.mu._structure import Factored

    rng = np.random.default_rng(5)
    M = rng.standard_normal((4, 4)) + 1j * rng.standard_normal((4, 4))
    full = dg_upper(M, BlockStructure((4,), ("full",)))[0]
    assert full == pytest.approx(np.linalg.svd(M, compute_uv=False)[0], rel=1e-6)
    mixed = BlockStructure((1, 1, 2), ("real", "complex", "full"))
    assert dg_upper(M, mixed)[0] == dg_upper(Factored(M), mixed)[0]
