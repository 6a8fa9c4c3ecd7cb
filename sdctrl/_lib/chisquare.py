"""Upper quantiles of the chi-square law in numpy (``scipy.special.chdtri`` without its
import on the identification path).

``Q(a, y) = Gamma(a, y) / Gamma(a)`` (regularised upper incomplete gamma function) by its
continued fraction for ``y > a + 1`` and ``1 - P(a, y)`` by the power series of ``P``
below (Abramowitz and Stegun 6.5.29 and 6.5.31; Press et al., *Numerical Recipes*,
section 6.2); the quantile ``x = 2 y`` of ``Q(h / 2, y) = p`` by Newton's method on
``ln Q``, started from the Wilson-Hilferty approximation (A and S 26.4.17).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["chi2_isf"]

_TINY = 1e-300


def _log_prefactor(a, y, lga):
    """``ln(y^a e^-y / Gamma(a))``."""
    return a * np.log(y) - y - lga


def _log_upper(a, y, lga):
    """``ln Q(a, y)`` for arrays ``a`` > 0, ``y`` > 0 (``lga = ln Gamma(a)``)."""
    out = np.empty_like(y)
    cf = y > a + 1
    if np.any(cf):                     # modified Lentz: Q = pre / (b0 - 1(1-a)/(b1 - ...))
        aa, yy = a[cf], y[cf]
        b = yy + 1 - aa
        c = np.full_like(yy, 1 / _TINY)
        d = 1 / b
        h = d.copy()
        for i in range(1, 300):
            an = -i * (i - aa)
            b = b + 2
            d = an * d + b
            d = np.where(np.abs(d) < _TINY, _TINY, d)
            c = b + an / c
            c = np.where(np.abs(c) < _TINY, _TINY, c)
            d = 1 / d
            delta = d * c
            h = h * delta
            if np.max(np.abs(delta - 1)) < 2e-16:
                break
        out[cf] = _log_prefactor(aa, yy, lga[cf]) + np.log(h)
    if np.any(~cf):                    # series of P: sum y^n / (a (a+1) ... (a+n))
        aa, yy = a[~cf], y[~cf]
        term = 1 / aa
        total = term.copy()
        ap = aa.copy()
        for _ in range(500):
            ap = ap + 1
            term = term * yy / ap
            total = total + term
            if np.max(np.abs(term) / np.abs(total)) < 2e-16:
                break
        P = np.exp(_log_prefactor(aa, yy, lga[~cf])) * total
        out[~cf] = np.log(np.maximum(1 - P, _TINY))
    return out


def _normal_isf(p: float) -> float:
    """Standard normal upper quantile by Newton's method on ``erfc`` (scalar)."""
    z = math.sqrt(max(-2 * math.log(p), 0.0)) if p < 0.5 else 0.0
    for _ in range(60):
        q = 0.5 * math.erfc(z / math.sqrt(2))
        dens = math.exp(-0.5 * z * z) / math.sqrt(2 * math.pi)
        step = (q - p) / dens
        z += step
        if abs(step) < 1e-15 * max(1.0, abs(z)):
            break
    return z


def chi2_isf(df, p: float) -> np.ndarray:
    """``x`` with ``P(chi2(df) > x) = p``: ``scipy.special.chdtri(df, p)``.

    Parameters
    ----------
    df : array_like
        Degrees of freedom (> 0, real).
    p : float
        Upper tail probability, in (0, 1).

    Returns
    -------
    ndarray
        The quantiles, shaped like ``df``.
    """
    df = np.asarray(df, float)
    a = np.atleast_1d(df / 2).ravel()
    lga = np.array([math.lgamma(v) for v in a])
    z = _normal_isf(p)
    c = 2 / (9 * df.ravel())
    y = np.maximum(0.5 * df.ravel() * (1 - c + z * np.sqrt(c)) ** 3, 1e-3 * a + 1e-300)
    lp = math.log(p)
    for _ in range(100):               # Newton on ln Q(a, y) = ln p
        lq = _log_upper(a, y, lga)
        dlq = -np.exp(_log_prefactor(a, y, lga) - np.log(y) - lq)   # d ln Q / dy
        step = (lq - lp) / dlq
        y_new = np.where(y - step > 0, y - step, 0.5 * y)
        done = np.abs(y_new - y) <= 1e-14 * y
        y = y_new
        if np.all(done):
            break
    return (2 * y).reshape(df.shape)
