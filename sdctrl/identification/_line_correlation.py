"""Correlation of the noise between the lines of windowed data, and the noise covariance
applied to stacked columns (the statistics of :mod:`~sdctrl.identification._pole_statistics`,
thesis 3.4).

Internal module: the functions trust their inputs.
"""

from __future__ import annotations

import numpy as np

from sdctrl.identification._residual_decay import equivalent_tau

__all__ = ["decay_correlation", "difference_gain", "line_correlation", "local_mean",
           "noise_correlation", "noise_times"]


def local_mean(X, win: int) -> np.ndarray:
    """Running mean over ``win`` lines (axis 0, edges held) of ``X`` (nf, m)."""
    from scipy.ndimage import uniform_filter1d

    return uniform_filter1d(X, size=min(win, X.shape[0]), axis=0, mode="nearest")


def line_correlation(freq, tau):
    """Correlation of the noise between lines of data taken with an exponential window.

    White noise ``e(t)`` windowed by ``w(t) = exp(-t/tau)`` over a record of length
    ``T = 1/df`` has at lines ``k`` and ``l = k - d`` the correlation
    ``sum_t w^2 exp(-2 pi j d t/T) / sum_t w^2 = a / (a + 2 pi j d)``, ``a = 2 T / tau``
    (the window's power spectrum): about 0.8 between neighbouring lines for a window ending
    at 1% of its start (``a = 2 ln 100``), decaying as ``1/d``.  Independent lines (None)
    without the window.

    Parameters
    ----------
    freq : ndarray, shape (nf,)
        The lines (Hz), spaced ``df`` (their median spacing).
    tau : float or None
        Time constant of the window (s).

    Returns
    -------
    ndarray, shape (2 nf - 1,) or None
        ``rho(d)`` for ``d = -(nf - 1) .. nf - 1``.
    """
    if tau is None or freq.size < 2:
        return None
    return decay_correlation(2.0 / (float(tau) * float(np.median(np.diff(freq)))), freq.size)


def decay_correlation(a: float, n: int) -> np.ndarray:
    """``rho(d) = a / (a + 2 pi j d)``, ``d = -(n - 1) .. n - 1``: the correlation between
    lines of noise whose power decays by ``exp(a)`` over the record (:func:`line_correlation`,
    ``a = 2 T / tau``; the decay :mod:`~sdctrl.identification._residual_decay` measures)."""
    d = np.arange(-(n - 1), n)
    return a / (a + 2j * np.pi * d)


def noise_correlation(cm, data):
    """Correlation of the noise between the lines of ``data`` (:func:`line_correlation`):
    that of the recorded exponential window; for data without one whose selection found the
    start's residual decaying over the record (``cm.search.residual_decay``,
    :mod:`~sdctrl.identification._residual_decay`), that of the window of the same decay
    ``a`` (:func:`~sdctrl.identification._residual_decay.equivalent_tau`); else None
    (independent lines).  A fit's own residual is not measured here: with given poles it
    holds the model's error (the plate's survey at its five exact in-band poles: -0.07 where
    the selection's start measured 5.8), and an exact fit's is round-off."""
    if data.exponential_tau is not None:
        return line_correlation(data.freq, data.exponential_tau)
    decay = getattr(getattr(cm, "search", None), "residual_decay", None)
    if decay is None:
        return None
    return line_correlation(data.freq, equivalent_tau(decay, data.freq))


def difference_gain(rho, lag: int = 1) -> float:
    """``E|n_(i-lag) - 2 n_i + n_(i+lag)|^2 / sig^2`` for noise correlated as ``rho`` between
    lines (:func:`line_correlation`, None: independent): ``6 - 8 Re rho(lag) + 2 Re
    rho(2 lag)``, 6 for independent lines (1.24 over one line for a window ending at 1%).

    >>> difference_gain(None), difference_gain(np.ones(9), 2)
    (6.0, 0.0)
    """
    if rho is None:
        return 6.0
    c = rho.size // 2
    r1 = rho[c + lag].real if rho.size > c + lag else 0.0
    r2 = rho[c + 2 * lag].real if rho.size > c + 2 * lag else 0.0
    return float(6.0 - 8.0 * r1 + 2.0 * r2)


def noise_times(X, sig, rho):
    """``Sigma_c X_c`` per channel: ``X`` (2nf, p, m) stacked ``[Re; Im]`` columns, ``sig``
    (nf, m) the noise's standard deviation per line (``E|n|^2 = sig^2``), ``rho`` the
    correlation between lines (:func:`line_correlation`, None: independent).  The noise is
    circular, ``E[n_k n_l^*] = sig_k sig_l rho(k - l)``, ``E[n_k n_l] = 0``: in stacked
    form ``Sigma X = [Re; Im] of (sig C (sig z)) / 2`` with ``z = X_re + j X_im``."""
    nf = X.shape[0] // 2
    if rho is None:
        w2 = 0.5 * sig**2
        return X * np.vstack([w2, w2])[:, None, :]
    from scipy.signal import fftconvolve

    z = (X[:nf] + 1j * X[nf:]) * sig[:, None, :]
    cz = fftconvolve(z, rho[:, None, None], axes=0)[nf - 1:2 * nf - 1]
    cz *= 0.5 * sig[:, None, :]
    return np.concatenate([cz.real, cz.imag])
