"""The diagnosis' faster paths give the same numbers as the paths they replace (issue 27).

The finalists' size fits evaluate ``ratio_cost(q)`` of the ratio ``q = H / H_d`` they form
directly, where they evaluated ``mean(r.real**2 + r.imag**2)`` of the complex residual
``r = complex_residual(q, 1)``: equal bit for bit, so that the bounded minimisation takes the
same path and returns the same sizes.
"""

import numpy as np
import pytest

from sdctrl.diagnosis._residual_map import complex_residual, cost, log_ratio, ratio_cost


def _ratios(seed):
    """Ratios of every magnitude (1e-30..1e30, so that the -50 floor of log|q| is met) and
    every phase, with exact zeros' neighbours left out (H_d never vanishes)."""
    rng = np.random.default_rng(seed)
    shape = (40, 7, 3)
    mag = 10.0 ** rng.uniform(-30, 30, shape)
    return mag * np.exp(1j * rng.uniform(-np.pi, np.pi, shape))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_ratio_cost_equals_the_residual_path_bit_for_bit(seed):
    q = _ratios(seed)
    r = complex_residual(q, np.ones(1))                 # the former path (division by 1)
    assert ratio_cost(q) == float(np.mean(r.real**2 + r.imag**2))
    np.testing.assert_array_equal(log_ratio(q), r)
    assert np.min(r.real) == -50.0                      # the floor was exercised


@pytest.mark.parametrize("seed", [3, 4])
def test_cost_is_ratio_cost_of_the_ratio(seed):
    rng = np.random.default_rng(seed)
    Hd = rng.standard_normal((30, 4, 2)) + 1j * rng.standard_normal((30, 4, 2))
    H = Hd * (1 + 0.1 * (rng.standard_normal(Hd.shape) + 1j * rng.standard_normal(Hd.shape)))
    q = H / Hd
    assert cost(H, Hd) == ratio_cost(q)
    # a known value: a constant ratio e^(0.2 + 0.3j) costs 0.2^2 + 0.3^2
    assert ratio_cost(np.full((5, 2, 2), np.exp(0.2 + 0.3j))) == pytest.approx(0.13, rel=1e-14)
