"""Groups of close modes and the uncertainty of their summed residues (thesis 3.3, 3.58).

Two modes whose resonances overlap contribute nearly the same shape to the FRF, so that a test
determines the sum of their residues much better than each: the noise, the identification and
the properness correction (3.51) trade residue between them.  Judged one by one, a change of
their residues may be within each one's standard deviation and still upset their balance --
the response between and away from the resonances, where their contributions nearly cancel
(a dense cluster of blade modes, a close pair with opposite residues at a transfer).
:func:`close_groups` finds them from the poles alone: the correlation of the contributions
``1/(i w - lambda_j)`` of two modes over all frequencies,
``gamma_jk = 2 sqrt(s_j s_k) / |lambda_j + conj(lambda_k)|`` (``s = -Re lambda``; 1 for equal
poles, ``1/sqrt(1 + (dw/2s)^2)`` for equal damping), links them above :data:`CLOSE`.
:func:`summed_residue_std` gives the standard deviation of a group's summed residue with the
covariance between the modes' residues (3.58), which their separate standard deviations ignore.

Internal module: the functions trust their inputs.
"""

from __future__ import annotations

import numpy as np

from sdctrl.identification._pole_statistics import undetermined

__all__ = ["CLOSE", "close_groups", "summed_residue_std"]

#: two modes are close when their FRF contributions correlate above one half (for equal
#: damping: closer than about 1.7 half-power bandwidths, ``|dw| < 2 sqrt(3) s``)
CLOSE = 0.5


def close_groups(poles) -> np.ndarray:
    """Groups of close modes: connected components of ``gamma_jk > CLOSE`` (module notes).

    Parameters
    ----------
    poles : array_like, shape (n,), complex
        Poles (rad/s), upper half-plane, stable.

    Returns
    -------
    ndarray of int, shape (n,)
        A group label per pole: the smallest index of its group.
    """
    lam = np.asarray(poles, complex)
    s = np.maximum(-lam.real, 0.0)
    den = np.abs(lam[:, None] + lam.conj()[None, :])
    gamma = 2.0 * np.sqrt(np.outer(s, s)) / np.where(den > 0, den, np.inf)
    label = np.arange(lam.size)
    for j, k in zip(*np.nonzero(np.triu(gamma > CLOSE, 1))):
        label[label == label[k]] = label[j]
    return np.array([np.flatnonzero(label == g).min() for g in label], int)


def summed_residue_std(stats, index, shape: tuple) -> np.ndarray:
    """Standard deviation of ``sum_{j in index} R_j`` under the test's noise (3.58).

    Both parts of (3.58), with the covariances between the modes' coefficients (module notes
    of :mod:`~sdctrl.identification._pole_statistics`): for the sum ``g^T C_c`` of channel
    ``c``'s coefficients, ``g^T V_c g - 2 g^T K_c A^-1 M_c^T g + g^T M_c S M_c^T g``.

    Parameters
    ----------
    stats : FitStatistics
        Covariance blocks of the fit (complex parametrisation: ``Re R``, ``Im R`` per pole).
    index : array_like of int
        Poles of the group.
    shape : tuple of int
        ``(n, ns, na)`` of the model's residues.

    Returns
    -------
    ndarray, shape (ns, na)
        ``sqrt(var Re + var Im)`` of each entry of the summed residue; NaN where a pole is
        undetermined or the statistics are of another parametrisation.
    """
    n, ns, na = shape
    index = np.asarray(index, int)
    if (stats is None or stats.n != n or stats.model != "complex"
            or undetermined(stats)[index].any()):
        return np.full((ns, na), np.nan)
    var = np.zeros(stats.V.shape[0])
    for part in (0, 1):                                   # Re R, then Im R
        g = np.zeros(stats.V.shape[1])
        g[2 * index + part] = 1.0
        kg, mg = stats.K.transpose(0, 2, 1) @ g, stats.M.transpose(0, 2, 1) @ g   # (m, 2n)
        var += (np.einsum("mpq,p,q->m", stats.V, g, g)
                - 2.0 * np.einsum("ma,ab,mb->m", kg, stats.A_inv, mg)
                + np.einsum("ma,ab,mb->m", mg, stats.S, mg))
    return np.sqrt(np.maximum(var, 0.0)).reshape(ns, na)
