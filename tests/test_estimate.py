"""H1 estimation from simulated time records of a known system.

The reference is exact: the structure is discretised with a zero-order hold and
simulated with that discrete system, whose FRF ``C (e^{jwT} I - A_d)^-1 B_d + D``
is what the estimator must recover.  With ``K`` Welch segments (Hann, 50% overlap,
about ``n_d = K / 1.06`` independent averages) and true coherence ``g2``, the
normalised complex error of H1 has variance ``(1 - g2) / (g2 n_d)`` (Bendat &
Piersol); the tests check the errors against that prediction.
"""

import numpy as np
import pytest
from scipy import signal

import sdctrl as sd


def _modal_ss(freqs_hz, zetas, ns, na, seed):
    rng = np.random.default_rng(seed)
    n = len(freqs_hz)
    w = 2 * np.pi * np.asarray(freqs_hz)
    A = np.block([[np.zeros((n, n)), np.eye(n)],
                  [-np.diag(w**2), -np.diag(2 * np.asarray(zetas) * w)]])
    B = np.vstack([np.zeros((n, na)), rng.standard_normal((n, na))])
    C = np.hstack([rng.standard_normal((ns, n)) * 1e3, np.zeros((ns, n))])
    return A, B, C, np.zeros((ns, na))


def _simulate(A, B, C, D, fs, u):
    Ad, Bd, Cd, Dd, _ = signal.cont2discrete((A, B, C, D), 1 / fs, method="zoh")
    ns, na = Cd.shape[0], Bd.shape[1]
    y = np.zeros((u.shape[0], ns))
    for a in range(na):
        num, den = signal.ss2tf(Ad, Bd, Cd, Dd, input=a)
        for s in range(ns):
            y[:, s] += signal.lfilter(num[s], den, u[:, a])
    return y, (Ad, Bd, Cd, Dd)


def _dfrf(Ad, Bd, Cd, Dd, freq, fs):
    z = np.exp(2j * np.pi * freq / fs)
    n = Ad.shape[0]
    X = np.linalg.solve(z[:, None, None] * np.eye(n) - Ad,
                        np.broadcast_to(Bd, (z.size,) + Bd.shape))
    return Cd @ X + Dd


@pytest.mark.parametrize("na, ns", [(1, 1), (2, 3)])
def test_h1_recovers_known_frf(na, ns):
    fs, nt, nperseg = 64.0, 2**20, 8192
    rng = np.random.default_rng(10 + na)
    A, B, C, D = _modal_ss([3.0, 7.5, 11.0], [0.05, 0.04, 0.06], ns, na, seed=na)
    u = rng.standard_normal((nt, na))                       # uncorrelated inputs, unit variance
    y0, dsys = _simulate(A, B, C, D, fs, u)
    sigma_n = 0.05 * y0.std(axis=0)                          # output noise: coherence < 1
    y = y0 + sigma_n * rng.standard_normal(y0.shape)
    frf = sd.estimate_frf(u if na > 1 else u[:, 0], y if ns > 1 else y[:, 0], fs, nperseg=nperseg)
    assert frf.H.shape[1:] == (ns, na) and frf.freq[0] == pytest.approx(fs / nperseg)
    band = (frf.freq > 1.0) & (frf.freq < 20.0)
    Href = _dfrf(*dsys, frf.freq, fs)
    # true (multiple) coherence: |H|^2 S_uu summed over inputs / (that + S_nn); S_uu = 2/fs
    Syy = (np.abs(Href) ** 2).sum(axis=2) * 2 / fs
    g2 = Syy / (Syy + 2 * sigma_n**2 / fs)
    K = (nt - nperseg) // (nperseg // 2) + 1
    n_d = K / 1.06
    # H1 error variance: S_nn / (n_d S_uu) per input (white unit inputs: sigma_n^2 / n_d)
    err2 = (np.abs(frf.H - Href) ** 2)[band]                                 # (nl, ns, na)
    pred = np.broadcast_to(sigma_n[None, :, None] ** 2 / (n_d - na + 1), err2.shape)
    ratio = err2 / pred
    # |e|^2 / sigma^2 is exponential(1) (complex Gaussian error): median ln 2 = 0.693; the
    # sample median of ~10^3 lines has a spread of ~0.03
    assert 0.6 < np.median(ratio) < 0.8, np.median(ratio)
    # the tail: P(ratio > 9) = 1.2e-4 for the random error; the Hann leakage bias,
    # ~(df/B)^2/6 ~ 1e-4 of the peak here, adds a few lines near the resonances
    assert np.mean(ratio > 9) < 0.02
    # coherence estimate agrees with the true multiple coherence
    assert np.median(np.abs(frf.coherence[band][:, :, 0] - g2[band])) < 0.02
    assert np.all((frf.coherence >= 0) & (frf.coherence <= 1))


def test_h1_noise_free_is_accurate():
    fs, nt = 64.0, 2**16
    rng = np.random.default_rng(0)
    A, B, C, D = _modal_ss([5.0, 9.0], [0.05, 0.05], 2, 2, seed=3)
    u = rng.standard_normal((nt, 2))
    y, dsys = _simulate(A, B, C, D, fs, u)
    frf = sd.estimate_frf(u, y, fs, nperseg=4096, sensors=["y1", "y2"], actuators=["f1", "f2"],
                          quantity="displacement")
    Href = _dfrf(*dsys, frf.freq, fs)
    band = (frf.freq > 1) & (frf.freq < 20)
    rel = np.abs(frf.H - Href)[band] / np.abs(Href)[band]
    # no noise: only leakage (a few 1e-3 at resonance with df/B ~ 0.25) and the transient
    assert np.median(rel) < 1e-3 and rel.max() < 0.02
    assert frf.sensors == ("y1", "y2") and np.median(frf.coherence[band]) > 0.999


def test_estimate_frf_bad_input():
    u = np.random.default_rng(0).standard_normal(1000)
    with pytest.raises(ValueError, match="same number of samples"):
        sd.estimate_frf(u, u[:-1], 10.0)
    with pytest.raises(ValueError, match="fs must be a positive"):
        sd.estimate_frf(u, u, -1.0)
    with pytest.raises(ValueError, match="nperseg must lie"):
        sd.estimate_frf(u, u, 10.0, nperseg=5000)
    with pytest.raises(TypeError, match="nperseg must be an integer"):
        sd.estimate_frf(u, u, 10.0, nperseg=100.5)
    bad = u.copy()
    bad[3] = np.nan
    with pytest.raises(ValueError, match="y must contain only finite"):
        sd.estimate_frf(u, bad, 10.0)
    u0 = u.copy()
    sd.estimate_frf(u, 2 * u, 10.0)
    assert np.array_equal(u, u0)
