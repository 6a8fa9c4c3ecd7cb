"""sdctrl._lib.boundlsq gives scipy.optimize.least_squares(method="trf", x_scale="jac")'s
iterates: same x (to rounding), same status and evaluation count, on problems whose bounds
are active, inactive and hit along the way (reflected steps)."""

import numpy as np
import pytest
from scipy.optimize import least_squares

from sdctrl._lib.boundlsq import trf_least_squares


def _exp_fit(seed):
    """Sum of two decaying exponentials (a classic ill-conditioned fit) with noise."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 4, 60)
    truth = np.array([1.0, 1.3, 0.7, 0.25])
    y = truth[0] * np.exp(-truth[1] * t) + truth[2] * np.exp(-truth[3] * t)
    y = y + 1e-3 * rng.standard_normal(t.size)

    def fun(x):
        return x[0] * np.exp(-x[1] * t) + x[2] * np.exp(-x[3] * t) - y

    def jac(x, *_):
        e1, e3 = np.exp(-x[1] * t), np.exp(-x[3] * t)
        return np.column_stack([e1, -x[0] * t * e1, e3, -x[2] * t * e3])

    return fun, jac, truth


def _rosenbrock():
    def fun(x):
        return np.array([10 * (x[1] - x[0] ** 2), 1 - x[0]])

    def jac(x, *_):
        return np.array([[-20 * x[0], 10.0], [-1.0, 0.0]])

    return fun, jac


CASES = [
    ("rosen free", *_rosenbrock(), [-2.0, 2.0], [-np.inf, -np.inf], [np.inf, np.inf]),
    ("rosen active bound", *_rosenbrock(), [-2.0, 2.0], [-np.inf, 1.5], [np.inf, np.inf]),
    ("rosen box", *_rosenbrock(), [2.0, 2.0], [-1.5, -1.0], [2.5, 3.0]),
    ("rosen upper", *_rosenbrock(), [0.1, 0.5], [-3.0, -3.0], [0.5, 0.8]),
]


@pytest.mark.parametrize("name, fun, jac, x0, lb, ub", CASES)
def test_same_iterates_as_scipy(name, fun, jac, x0, lb, ub):
    x0, lb, ub = (np.asarray(v, float) for v in (x0, lb, ub))
    ref = least_squares(fun, x0, jac=jac, bounds=(lb, ub), method="trf", x_scale="jac",
                        ftol=1e-12, xtol=1e-12, gtol=1e-12, max_nfev=200)
    got = trf_least_squares(fun, jac, x0, lb, ub, 1e-12, 1e-12, 1e-12, 200)
    assert got.status == ref.status and got.nfev == ref.nfev and got.njev == ref.njev
    np.testing.assert_allclose(got.x, ref.x, rtol=1e-13, atol=1e-15)
    assert got.cost == pytest.approx(ref.cost, rel=1e-12, abs=1e-300)
    assert got.message == ref.message
    assert np.all(got.x >= lb) and np.all(got.x <= ub)


@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize("tight", [False, True])
def test_exponential_fit(seed, tight):
    fun, jac, truth = _exp_fit(seed)
    x0 = np.array([0.5, 1.0 if tight else 2.0, 1.0, 0.1])
    lb = np.array([0.0, 0.0, 0.0, 0.0])
    ub = np.array([5.0, 1.2 if tight else 5.0, 5.0, 5.0])   # tight: the truth (1.3) cut off
    ref = least_squares(fun, x0, jac=jac, bounds=(lb, ub), method="trf", x_scale="jac",
                        ftol=1e-10, xtol=1e-10, gtol=1e-10, max_nfev=100)
    got = trf_least_squares(fun, jac, x0, lb, ub, 1e-10, 1e-10, 1e-10, 100)
    assert got.status == ref.status and got.nfev == ref.nfev
    np.testing.assert_allclose(got.x, ref.x, rtol=1e-12)
    if not tight:                                   # the fit recovers the truth
        np.testing.assert_allclose(got.x, truth, rtol=0.05)
    else:                                           # and stops on the bound
        assert got.x[1] == pytest.approx(1.2, abs=1e-6)


def test_max_nfev_stops():
    fun, jac = _rosenbrock()
    x0, lb, ub = np.array([-2.0, 2.0]), np.array([-3.0, -3.0]), np.array([3.0, 3.0])
    ref = least_squares(fun, x0, jac=jac, bounds=(lb, ub), method="trf", x_scale="jac",
                        ftol=1e-15, xtol=1e-15, gtol=1e-15, max_nfev=5)
    got = trf_least_squares(fun, jac, x0, lb, ub, 1e-15, 1e-15, 1e-15, 5)
    assert got.status == ref.status == 0 and got.nfev == ref.nfev == 5
    np.testing.assert_array_equal(got.x, ref.x)
