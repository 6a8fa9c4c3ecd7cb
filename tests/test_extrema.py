"""The numpy peak finders of sdctrl._lib.extrema give scipy.signal's results exactly
(identification uses them to stay clear of importing scipy.signal, issue 27)."""

import numpy as np
import pytest
from scipy.signal import argrelmax, find_peaks

from sdctrl._lib.extrema import peaks_with_prominence, relative_maxima


def _curves(n_curves=600, seed=0):
    rng = np.random.default_rng(seed)
    for t in range(n_curves):
        x = rng.normal(size=int(rng.integers(1, 80)))
        if t % 3 == 0:
            x = np.round(x)                      # flat peaks and flat valleys
        if t % 5 == 0:
            x = np.cumsum(x)
        yield t, x


def test_peaks_and_prominences_equal_find_peaks():
    n_peaks = 0
    for t, x in _curves():
        p = 0.5 * (t % 4)
        ref, props = find_peaks(x, prominence=p)
        got, prom = peaks_with_prominence(x, p)
        np.testing.assert_array_equal(got, ref)
        np.testing.assert_array_equal(prom, props["prominences"])
        n_peaks += ref.size
    assert n_peaks > 1000


def test_known_peaks():
    x = np.array([0.0, 2.0, 1.0, 1.0, 5.0, 5.0, 5.0, 0.0, 3.0, 3.0])
    peaks, prom = peaks_with_prominence(x, 0.0)
    assert peaks.tolist() == [1, 5]              # middle of the flat top; an edge is no peak
    assert prom.tolist() == [1.0, 5.0]         # 2 above the higher base (1), 5 above 0
    assert peaks_with_prominence(x, 3.0)[0].tolist() == [5]


@pytest.mark.parametrize("order", [1, 2, 3])
def test_relative_maxima_equal_argrelmax(order):
    for _, x in _curves(300, seed=order):
        np.testing.assert_array_equal(relative_maxima(x, order), argrelmax(x, order=order)[0])
    assert relative_maxima(np.array([0.0, 1.0, 0.5, 0.2, 3.0, 0.0]), 2).tolist() == [1, 4]
