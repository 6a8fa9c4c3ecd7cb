"""Which noise field the residual scan may use (issue 22): second differences of the
residual measure the noise only when it is independent between lines.  The check
(``NoiseTest.independent``) on a single mode with known noise: independent noise passes,
the same noise correlated between neighbouring lines as an unrecorded window makes it
(``c_1 = 0.8``) does not; it depends on neither the noise level nor the data's scale.
"""

import numpy as np
import pytest

from sdctrl.identification._noise import NoiseTest, running_median
from sdctrl.identification._residues import stack
from sdctrl.identification._search import PoleProblem


def _independent(noise, c1, scale=1.0, seed=0):
    """NoiseTest.independent on one mode at the exact pole, 4 x 3 channels, 300 lines, with
    relative noise of lag-one correlation ``c1`` between lines (first-order recursion)."""
    from scipy.signal import lfilter

    rng = np.random.default_rng(seed)
    f = np.linspace(5.0, 15.0, 300)
    s = 2j * np.pi * f
    lam = 2 * np.pi * 10.0 * (-0.01 + 1j * np.sqrt(1 - 0.01**2))
    R = rng.standard_normal((4, 1)) @ rng.standard_normal((1, 3))
    H = (R[None] / (s - lam)[:, None, None] + R[None] / (s - np.conj(lam))[:, None, None])
    e = (rng.standard_normal((400, 4, 3)) + 1j * rng.standard_normal((400, 4, 3))) / np.sqrt(2)
    n = lfilter([np.sqrt(1 - c1**2)], [1.0, -c1], e, axis=0)[100:]     # unit variance
    Hn = scale * H * (1 + noise * n)
    prob = PoleProblem(stack(Hn.reshape(f.size, -1)), s, 0, "complex", (True, True))
    w, z = np.array([abs(lam)]), np.array([0.01])
    ev = prob.evaluate(np.concatenate([np.log(w), np.log(z)]))
    return NoiseTest(prob, 2.0).independent(ev)


@pytest.mark.parametrize("noise,scale", [(0.01, 1.0), (0.1, 1.0), (0.01, 1e-9)])
def test_independent_noise_passes_and_correlated_noise_does_not(noise, scale):
    assert _independent(noise, 0.0, scale)
    assert not _independent(noise, 0.8, scale)


@pytest.mark.parametrize("nf,win,k", [(2000, 100, 3), (300, 41, 2), (333, 41, 4),
                                      (50, 41, 1), (7, 5, 2), (100, 101, 2)])
def test_running_median_is_the_median_of_each_window(nf, win, k):
    """At every evaluated line (each ``win // 8``, and the last) the running median is
    np.median of the window (edges held) bit for bit; in between, linear interpolation."""
    X = np.random.default_rng(nf + win).exponential(size=(nf, k))
    w = min(win, nf)
    half = w // 2
    Xp = np.concatenate([np.repeat(X[:1], half, 0), X, np.repeat(X[-1:], w - 1 - half, 0)])
    ref = np.array([np.median(Xp[i:i + w], axis=0) for i in range(nf)])
    out = running_median(X, win)
    centres = np.unique(np.append(np.arange(0, nf, max(1, w // 8)), nf - 1))
    assert out.shape == X.shape
    np.testing.assert_array_equal(out[centres], ref[centres])
    between = np.setdiff1d(np.arange(nf), centres)
    j = np.searchsorted(centres, between) - 1                 # on the chord of its centres
    t = ((between - centres[j]) / (centres[j + 1] - centres[j]))[:, None]
    np.testing.assert_allclose(out[between], (1 - t) * ref[centres[j]] + t * ref[centres[j + 1]],
                               rtol=1e-14)



@pytest.mark.parametrize("nf,win,k", [(2000, 100, 3), (300, 41, 2), (333, 41, 4),
                                      (50, 41, 1), (7, 5, 2), (100, 101, 2)])
def test_running_median_inside_the_data_at_the_edges(nf, win, k):
    """``inside=True``: near an edge the window is shifted to lie inside the data (the
    statistics' noise level, ``_pole_statistics._level``): np.median of those windows at
    every evaluated line, and away from the edges the held-edge median."""
    X = np.random.default_rng(nf + win + 1).exponential(size=(nf, k))
    w = min(win, nf)
    half = w // 2
    ref = np.array([np.median(X[s:s + w], axis=0)
                    for s in np.clip(np.arange(nf) - half, 0, nf - w)])
    out = running_median(X, win, inside=True)
    centres = np.unique(np.append(np.arange(0, nf, max(1, w // 8)), nf - 1))
    np.testing.assert_array_equal(out[centres], ref[centres])
    mid = (np.arange(nf) >= half + w) & (np.arange(nf) < nf - 2 * w)
    np.testing.assert_array_equal(out[mid], running_median(X, win)[mid])
