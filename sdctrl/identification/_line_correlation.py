"""Correlation of the noise between the lines of windowed data, and the noise covariance
applied to stacked columns (the statistics of :mod:`~sdctrl.identification._pole_statistics`,
thesis 3.4).

Internal module: the functions trust their inputs.
"""

from __future__ import annotations

import numpy as np

__all__ = ["line_correlation", "local_mean", "noise_times"]


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
    a = 2.0 / (float(tau) * float(np.median(np.diff(freq))))
    d = np.arange(-(freq.size - 1), freq.size)
    return a / (a + 2j * np.pi * d)


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
