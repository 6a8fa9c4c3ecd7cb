"""Correlation of the noise between the lines of an FRF estimated through an exponential window.

An impact test multiplies each response record ``y(t)`` (length ``T = 1/df``) by
``exp(-t/tau)`` before the DFT, so the white noise of the record becomes correlated between
lines: for lines ``k`` apart,

    c_k = E[n_(l+k) conj(n_l)] / E|n_l|^2
        = int_0^T exp(-2t/tau) exp(-2 pi i k t/T) dt / int_0^T exp(-2t/tau) dt
        = 1 / (1 + i pi k tau / T)                     (exact for integer k).

On a simulated roving-hammer survey (``tau = T/4.6``) the measured correlations are
0.695-0.447i, 0.375-0.458i, 0.223-0.379i for k = 1, 2, 3; this formula gives 0.682-0.466i,
0.350-0.477i, 0.193-0.394i.  The significance test of a pole (3.2.1) and the
noise estimated from second differences assume independent lines; with this correlation

* a pole's cost change due to the noise alone is ``tr(P Sigma)`` with the correlation in
  ``Sigma``: a pole wide against the correlation length fits ``1 + 2 sum Re c_k`` times more
  noise than for independent lines (about 4 for ``tau = T/4.6``);
* the second difference ``n_(l-1) - 2 n_l + n_(l+1)`` has the variance
  ``(6 - 8 Re c_1 + 2 Re c_2) sigma^2`` instead of ``6 sigma^2`` (about 5 times less).

Without an exponential window (``frf.exponential_tau`` None) the lines are taken as
independent, as before.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["LineCorrelation", "correlate", "window_correlation"]

#: correlations below this modulus are neglected
TOL = 0.01


@dataclass(frozen=True, eq=False)
class LineCorrelation:
    """Noise correlation between lines ``k = 1..K`` apart (module notes).

    Attributes
    ----------
    c : ndarray of complex, shape (K,)
        ``c_k = E[n_(l+k) conj(n_l)] / E|n_l|^2``.
    """

    c: np.ndarray

    @property
    def inflation(self) -> float:
        """``1 + 2 sum Re c_k``: the noise a smooth basis function fits, over independent lines."""
        return float(1.0 + 2.0 * np.sum(self.c.real))

    @property
    def second_difference(self) -> float:
        """``(6 - 8 Re c_1 + 2 Re c_2) / 6``: variance of the second difference over the
        independent-line value."""
        c1 = self.c[0].real if self.c.size > 0 else 0.0
        c2 = self.c[1].real if self.c.size > 1 else 0.0
        return float((6.0 - 8.0 * c1 + 2.0 * c2) / 6.0)


def window_correlation(tau, freq) -> LineCorrelation | None:
    """Line correlation of the noise of an FRF measured through ``exp(-t/tau)``.

    Parameters
    ----------
    tau : float or None
        Time constant (s) of the exponential window (``frf.exponential_tau``).
    freq : ndarray
        Frequency lines (Hz); uniform spacing ``df = 1/T``.

    Returns
    -------
    LineCorrelation or None
        None without a window or when the lines are not uniform (then independent).
    """
    freq = np.asarray(freq, float)
    if tau is None or freq.size < 3:
        return None
    d = np.diff(freq)
    df = float(np.median(d))
    if df <= 0 or np.max(np.abs(d - df)) > 1e-6 * df:
        return None
    kmax = int(min(freq.size - 1, np.ceil(1.0 / (np.pi * tau * df * TOL)) + 1))
    k = np.arange(1, kmax + 1)
    c = 1.0 / (1.0 + 1j * np.pi * k * tau * df)
    return LineCorrelation(c=c[np.abs(c) >= TOL])


def correlate(X: np.ndarray, corr: LineCorrelation | None) -> np.ndarray:
    """``C X`` for real-stacked columns ``X = [Re; Im]`` (2 nf, q), ``C`` the noise correlation
    of the lines (unit variance): in complex form ``Y_l = sum_m conj(c_(m-l)) Z_m``,
    ``Z = X_re + i X_im``, ``c_0 = 1``, ``c_(-k) = conj(c_k)``.

    Parameters
    ----------
    X : ndarray, shape (2 nf, ...)
        Real-stacked columns.
    corr : LineCorrelation or None
        None: independent lines (``X`` returned).

    Returns
    -------
    ndarray, shape of ``X``
    """
    if corr is None or corr.c.size == 0:
        return X
    nf = X.shape[0] // 2
    Z = X[:nf] + 1j * X[nf:]
    Y = Z.copy()
    for k, ck in enumerate(corr.c[: nf - 1], start=1):
        Y[:-k] += np.conj(ck) * Z[k:]
        Y[k:] += ck * Z[:-k]
    return np.concatenate([Y.real, Y.imag])
