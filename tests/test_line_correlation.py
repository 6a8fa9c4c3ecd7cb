"""Noise correlation between the lines of an exponentially windowed FRF
(sdctrl.identification._line_correlation): the closed form against the empirical
correlation of windowed white noise, and the significance test's noise term tr(P Sigma)
against the cost that a pole's projection takes from such noise."""

import numpy as np

from sdctrl.identification._line_correlation import correlate, window_correlation


def _windowed_noise(n_rec, n, tau_over_T, rng):
    t = np.arange(n) / n                                   # T = 1
    e = rng.standard_normal((n_rec, n)) * np.exp(-t / tau_over_T)
    return np.fft.rfft(e, axis=1)[:, 1:n // 2]             # lines 1/T apart


def test_closed_form_matches_windowed_white_noise():
    rng = np.random.default_rng(0)
    N = _windowed_noise(4000, 512, 0.2, rng)
    corr = window_correlation(0.2, np.arange(N.shape[1]) + 1.0)
    var = np.mean(np.abs(N) ** 2)
    for k in (1, 2, 3, 5):
        emp = np.mean(N[:, k:] * np.conj(N[:, :-k])) / var
        assert abs(emp - corr.c[k - 1]) < 0.02, (k, emp, corr.c[k - 1])
    d = N[:, :-2] - 2 * N[:, 1:-1] + N[:, 2:]
    ratio = np.mean(np.abs(d) ** 2) / (6 * var)
    assert abs(ratio / corr.second_difference - 1) < 0.03
    assert corr.second_difference < 0.3 and corr.inflation > 3     # far from independent


def test_projected_noise_is_trace_of_P_sigma():
    rng = np.random.default_rng(1)
    N = _windowed_noise(3000, 512, 0.2, rng)
    nf = N.shape[1]
    f = np.arange(nf) + 1.0
    corr = window_correlation(0.2, f)
    lam = -0.8 + 1j * 2 * np.pi * 100.0 / (2 * np.pi)       # a pole 1.6 lines wide at line 100
    g = 1 / (1j * f - lam) + 1 / (1j * f - np.conj(lam))
    B = np.concatenate([np.stack([g.real, -g.imag], 1), np.stack([g.imag, g.real], 1)])
    Q, _ = np.linalg.qr(B)                                  # projector P = Q Q^T
    X = np.concatenate([N.real, N.imag], axis=1).T          # (2 nf, records)
    emp = np.mean(np.sum((Q.T @ X) ** 2, axis=0))
    sig2 = np.mean(np.abs(N) ** 2)                          # E|n|^2 = E[re^2 + im^2]
    pred = 0.5 * sig2 * np.sum(Q * correlate(Q, corr))
    indep = 0.5 * sig2 * np.sum(Q * Q)
    assert abs(emp / pred - 1) < 0.06, (emp, pred)
    assert emp / indep > 1.5                                # the independent-line test is off


def test_no_window_means_independent_lines():
    assert window_correlation(None, np.arange(10.0)) is None
    assert window_correlation(1.0, np.array([1.0, 2.0, 4.0, 5.0])) is None
    X = np.arange(8.0).reshape(4, 2)
    assert correlate(X, None) is X
