"""The BFGS D-G bound of sdctrl.robust.mu._upper against the optimum of the D-G LMI solved by cvxpy
(Clarabel).

Both are certificates of the same family (scalings ``(D, G)`` of Fan, Tits and Doyle), so the
BFGS bound can never lie below the LMI optimum; the interior-point solution is the reference
for how far above it stops.  The cases include repeated real scalars (a symmetric Gamma/Omega
pair), which SLICOT AB13MD does not accept, and the case the lead measured 0.9% above the LMI.
"""
import numpy as np
import pytest

from sdctrl.robust.mu._upper import (BlockStructure, Factored, certify_dg, dg_upper, evaluate,
                                     mu_upper)
from sdctrl.robust.mu._lmi import lmi_bound

pytest.importorskip("cvxpy")

CASES = [   # (seed, sizes, kinds); measured BFGS excess over the LMI optimum in the comment
    (13, (2, 2), ("real", "complex")),                      # 0.9%  (the lead's case)
    (24, (3, 2), ("real", "real")),                         # 2.0%
    (22, (2, 2), ("real", "real")),                         # 0.5%
    (10, (2, 1, 2), ("real", "real", "complex")),           # < 1e-5
    (11, (2, 2, 1), ("real", "real", "full")),              # 1e-5
    (5, (1, 1, 1, 1), ("real",) * 4),                       # 1.2e-4
]
#: stated tolerance of the plain BFGS bound above the LMI optimum (largest measured: 2.0%)
BFGS_RTOL = 0.025
#: the polished bound: the LMI optimum up to the bisection step and solver accuracy (largest
#: measured: 1.2e-4, seed 24 with cvxpy 1.9 / Clarabel, where the bracket of the reference is
#: itself 7.6e-6 wide)
POLISH_RTOL = 2e-4


def _matrix(seed, n):
    rng = np.random.default_rng(seed)
    return rng.normal(size=(n, n)) + 1j * rng.normal(size=(n, n))


def _reference(M, st):
    """The LMI optimum by cvxpy, independent of the BFGS scalings (centred on the identity,
    then re-centred on its own scalings until that gains nothing)."""
    ref = lmi_bound(M, st, rounds=6)
    assert not ref.failed and ref.D is not None
    assert certify_dg(M, ref.D, ref.G) == pytest.approx(ref.bound, rel=1e-12)
    return ref.bound, ref.lower


@pytest.mark.parametrize("seed,sizes,kinds", CASES)
def test_dg_bound_against_the_lmi_optimum(seed, sizes, kinds):
    st = BlockStructure(sizes, kinds)
    M = _matrix(seed, st.N)
    ref, ref_lower = _reference(M, st)
    assert ref_lower <= ref <= ref_lower * (1 + 2e-5)               # a tight bracket
    ub, _ = dg_upper(Factored(M), st)
    assert ub >= ref_lower * (1 - 1e-6)           # a certificate: never below the optimum
    assert ub <= ref * (1 + BFGS_RTOL)
    up, xp = dg_upper(Factored(M), st, polish=True)
    assert ref_lower * (1 - 1e-6) <= up <= ref * (1 + POLISH_RTOL)
    assert up <= ub
    D, G = st.dense_scalings(xp)                  # the returned scalings certify the value
    assert certify_dg(M, D, G) == pytest.approx(up, rel=1e-9)
    assert np.sqrt(evaluate(Factored(M), st, xp, grad=False)[0]) == pytest.approx(up, rel=1e-9)


def test_polish_closes_the_gap_of_a_regularised_repeated_real_structure():
    """Two symmetric pairs with their complex regularisation (the structure robust_stability
    uses, scalings spanning ~1/eps): BFGS stops 32% above the best LMI value here (measured
    0.3152 against 0.2388).  Clarabel is less reliable on it (solver errors, and infeasibility
    claims that the bounded scaling range makes wrong), so the reference is the best certified
    LMI value after three re-centred rounds, and the polished bound must come within 1% of it
    (measured 0.33%)."""
    M = _matrix(2, 4)
    b0, _ = mu_upper(M, (2, 2), eps=0.005)
    b1, (Maug, D, G) = mu_upper(M, (2, 2), eps=0.005, polish=True)
    assert certify_dg(Maug, D, G) == pytest.approx(b1, rel=1e-9)
    ref = lmi_bound(Maug, BlockStructure.real_repeated((2, 2), 0.005), rounds=3)
    assert certify_dg(Maug, ref.D, ref.G) == pytest.approx(ref.bound, rel=1e-12)
    assert b0 > 1.3 * ref.bound
    assert ref.bound <= b1 <= 1.01 * ref.bound


def test_params_invert_dense_scalings():
    st = BlockStructure((2, 1, 3, 2, 1), ("real", "complex", "full", "complex", "real"))
    x = 0.3 * np.random.default_rng(0).normal(size=st.nv)
    D, G = st.dense_scalings(x)
    np.testing.assert_allclose(st.params(D, G), x, atol=1e-12)
