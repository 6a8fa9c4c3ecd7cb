"""Noise correlation between the lines of an exponentially windowed FRF
(``sdctrl.identification._line_correlation.line_correlation``, the statistics of windowed
data and the reason identification keeps the direct noise field for them): the closed form
``rho(d) = 1/(1 + i pi d tau df)`` against the empirical correlation of windowed white
noise, and the second differences it makes small."""

import numpy as np

from sdctrl.identification._line_correlation import line_correlation


def _windowed_noise(n_rec, n, tau_over_T, rng):
    t = np.arange(n) / n                                   # T = 1
    e = rng.standard_normal((n_rec, n)) * np.exp(-t / tau_over_T)
    return np.fft.rfft(e, axis=1)[:, 1:n // 2]             # lines 1/T apart


def test_closed_form_matches_windowed_white_noise():
    rng = np.random.default_rng(0)
    N = _windowed_noise(4000, 512, 0.2, rng)
    nf = N.shape[1]
    rho = line_correlation(np.arange(nf) + 1.0, 0.2)       # df = 1 Hz, tau = 0.2 s
    var = np.mean(np.abs(N) ** 2)
    for k in (1, 2, 3, 5):
        emp = np.mean(N[:, k:] * np.conj(N[:, :-k])) / var
        assert abs(emp - rho[nf - 1 + k]) < 0.02, (k, emp, rho[nf - 1 + k])
    assert rho[nf - 1] == 1 and np.allclose(rho[nf - 1 - 3], np.conj(rho[nf - 1 + 3]))
    # second differences: (6 - 8 Re c1 + 2 Re c2) sigma^2, about 5x below independent lines
    d = N[:, :-2] - 2 * N[:, 1:-1] + N[:, 2:]
    ratio = np.mean(np.abs(d) ** 2) / (6 * var)
    pred = (6 - 8 * rho[nf].real + 2 * rho[nf + 1].real) / 6
    assert abs(ratio / pred - 1) < 0.03 and pred < 0.3


def test_no_window_means_independent_lines():
    assert line_correlation(np.arange(10.0), None) is None
