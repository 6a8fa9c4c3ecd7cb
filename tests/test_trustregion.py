"""The numpy bounded least-squares solver of the variable projection
(sdctrl._lib.trustregion) against closed-form problems, and the numpy triangular solves
and chi-square quantiles that replace scipy on the identification path."""

import math

import numpy as np
import pytest

from sdctrl._lib.chisquare import chi2_isf
from sdctrl._lib.triangular import solve_lower, solve_upper
from sdctrl._lib.trustregion import bounded_least_squares

INF = np.full(4, np.inf)


def _linear(seed=0):
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(30, 4)) * np.array([1.0, 10.0, 0.1, 1e3])      # badly scaled
    b = rng.normal(size=30)
    return A, b, np.linalg.lstsq(A, b, rcond=None)[0]


def test_linear_problem_is_solved_in_one_step():
    A, b, xs = _linear()
    # from 2 xs the step -xs lies inside the first trust region (radius ||x0|| scaled);
    # first evaluation, one Gauss-Newton step (exact for a linear residual), then the
    # gradient test at the solution: two evaluations
    res = bounded_least_squares(lambda x: (A @ x - b, A), 2 * xs, -INF, INF)
    assert res.nfev == 2 and res.status == 1
    np.testing.assert_allclose(res.x, xs, rtol=1e-12, atol=1e-14)
    assert res.cost == pytest.approx(0.5 * np.sum((A @ xs - b) ** 2), rel=1e-12)


def test_linear_problem_with_an_active_bound_meets_the_kkt_conditions():
    A, b, xs = _linear(1)
    lo, hi = -INF.copy(), INF.copy()
    hi[0] = xs[0] - 0.5                                   # the free optimum is cut off
    res = bounded_least_squares(lambda x: (A @ x - b, A), np.full(4, -1.0), lo, hi,
                                ftol=1e-15, xtol=1e-15, gtol=1e-12, max_nfev=200)
    # closed form: x0 at its bound, the others the least squares of the rest
    x_b = np.empty(4)
    x_b[0] = hi[0]
    x_b[1:] = np.linalg.lstsq(A[:, 1:], b - A[:, 0] * hi[0], rcond=None)[0]
    assert res.status > 0
    assert np.all(res.x < hi)                             # strictly inside
    np.testing.assert_allclose(res.x, x_b, rtol=1e-6, atol=1e-8)
    g = A.T @ (A @ res.x - b)
    assert g[0] < 0                                       # the bound holds the descent
    np.testing.assert_allclose(g[1:], 0.0, atol=1e-6 * np.abs(g[0]))


def _rosenbrock(x):
    f = np.array([10 * (x[1] - x[0] ** 2), 1 - x[0]])
    J = np.array([[-20 * x[0], 10.0], [-1.0, 0.0]])
    return f, J


@pytest.mark.parametrize("lo,hi,x0,xs", [
    ((-2.0, -2.0), (2.0, 2.0), (-1.2, 1.0), (1.0, 1.0)),          # inactive bounds
    ((-2.0, -2.0), (0.5, 2.0), (-1.2, 1.0), (0.5, 0.25)),         # x0 <= 0.5 active
    ((-np.inf, 1.5), (np.inf, np.inf), (-1.2, 2.0), None),        # x1 >= 1.5 active
])
def test_rosenbrock_with_bounds(lo, hi, x0, xs):
    lo, hi = np.array(lo), np.array(hi)
    res = bounded_least_squares(_rosenbrock, np.array(x0), lo, hi, ftol=1e-14, xtol=1e-14,
                                gtol=1e-14, max_nfev=200)
    assert res.status > 0 and res.nfev < 60
    assert np.all(res.x > lo) and np.all(res.x < hi)
    if xs is None:
        # on x1 = 1.5 the cost 50 (1.5 - x0^2)^2 + (1 - x0)^2 / 2 is stationary:
        # 200 x0 (x0^2 - 1.5) + (x0 - 1) = 0 on the branch of the start (x0 < 0)
        r = np.roots([200.0, 0.0, -299.0, -1.0])
        x0s = float(np.real(r[np.argmin(np.abs(r - x0[0]))]))
        xs = (x0s, 1.5)
    np.testing.assert_allclose(res.x, xs, rtol=1e-6, atol=1e-7)


def test_evaluations_are_capped_and_reported():
    res = bounded_least_squares(_rosenbrock, np.array([-1.2, 1.0]), np.full(2, -2.0),
                                np.full(2, 2.0), ftol=1e-15, xtol=1e-15, gtol=1e-15,
                                max_nfev=5)
    assert res.nfev == 5 and res.status == 0
    assert "maximum number" in res.message


def test_triangular_solves():
    rng = np.random.default_rng(2)
    R = np.triu(rng.normal(size=(6, 6))) + 4 * np.eye(6)
    B = rng.normal(size=(6, 3))
    np.testing.assert_allclose(R @ solve_upper(R, B), B, atol=1e-12)
    L = (R.T + 1j * np.tril(rng.normal(size=(6, 6)), -1))
    np.testing.assert_allclose(L @ solve_lower(L, B), B, atol=1e-12)
    np.testing.assert_allclose(L @ solve_lower(L, B[:, 0]), B[:, 0], atol=1e-12)


def test_chi2_quantiles_closed_forms():
    # df = 2: P(chi2 > x) = exp(-x / 2); df = 1: erfc(sqrt(x / 2)); df = 4: (1 + x/2) e^-x/2
    for p in (1e-3, 2.5e-6, 5e-7, 1e-9):
        assert chi2_isf(np.array([2.0]), p)[0] == pytest.approx(-2 * math.log(p), rel=1e-13)
        x1, x4 = chi2_isf(np.array([1.0, 4.0]), p)
        assert math.erfc(math.sqrt(x1 / 2)) == pytest.approx(p, rel=1e-11)
        assert (1 + x4 / 2) * math.exp(-x4 / 2) == pytest.approx(p, rel=1e-11)


def test_chi2_quantiles_invariants():
    df = np.array([[1e-3, 0.3, 2.7], [11.0, 56.0, 1e3]])
    q = chi2_isf(df, 2.5e-6)
    assert q.shape == df.shape
    assert np.all(np.diff(q.ravel()) > 0)                       # grows with df
    # far in the tail of a large df: close to the normal approximation of chi2(1000)
    assert q[1, 2] == pytest.approx(1000 + 4.5648 * math.sqrt(2000), rel=0.02)


def test_same_solutions_and_stopping_tests_as_scipy_trf():
    """On exponential fits with bounds (one active), badly scaled: the solution and the
    stopping test of least_squares(method="trf", x_scale="jac") with the same tolerances."""
    from scipy.optimize import least_squares

    t = np.linspace(0.0, 4.0, 40)
    y = 3.0 * np.exp(-0.7 * t) + 0.02 * np.cos(5 * t)

    def fun(x):
        e = np.exp(-x[1] * t)
        return x[0] * 1e3 * e - y, np.column_stack([1e3 * e, -x[0] * 1e3 * t * e])

    for hi1 in (2.0, 0.5):                     # decay rate free, then held at its bound
        lo, hi = np.array([1e-4, 0.01]), np.array([1e-2, hi1])
        x0 = np.array([2e-3, 0.2])
        ref = least_squares(lambda x: fun(x)[0], x0, jac=lambda x: fun(x)[1], bounds=(lo, hi),
                            method="trf", x_scale="jac", ftol=1e-10, xtol=1e-10, gtol=1e-10)
        res = bounded_least_squares(fun, x0, lo, hi, ftol=1e-10, xtol=1e-10, gtol=1e-10)
        np.testing.assert_allclose(res.x, ref.x, rtol=1e-7)
        assert res.cost == pytest.approx(ref.cost, rel=1e-10)
        assert res.status == ref.status and abs(res.nfev - ref.nfev) <= 2
