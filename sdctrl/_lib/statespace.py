"""State-space kernels shared by the data, uncertainty and robustness modules (internal).

:func:`ss_frf` evaluates ``C (j w I - A)^-1 B + D`` on a frequency grid, vectorised; it sits
before every module of the flow (``frf``, ``uncertainty``, ``robust``...) so that none of
them imports it from another's namespace.
"""

from __future__ import annotations

import numpy as np

__all__ = ["ss_frf"]


def ss_frf(A, B, C, D, omega) -> np.ndarray:
    """``C (j w I - A)^-1 B + D`` for every ``w`` in ``omega`` (rad/s), shape (nw, ny, nu).

    Uses a diagonalisation of ``A`` when its eigenvectors are well conditioned
    (one ``O(n^3)`` step, then ``O(nw n ny nu)``), otherwise a batched solve.

    Parameters
    ----------
    A, B, C, D : array_like
        State-space matrices, shapes (n, n), (n, nu), (ny, n), (ny, nu).
    omega : array_like, shape (nw,)
        Angular frequencies (rad/s).

    Returns
    -------
    ndarray, shape (nw, ny, nu), complex

    Examples
    --------
    >>> import numpy as np
    >>> H = ss_frf([[-1.0]], [[1.0]], [[1.0]], [[0.0]], [0.0, 1.0])
    >>> np.round(H[:, 0, 0], 6)
    array([1. +0.j , 0.5-0.5j])
    """
    A = np.asarray(A)
    B = np.asarray(B)
    C = np.asarray(C)
    D = np.asarray(D)
    s = 1j * np.asarray(omega, dtype=float)
    n = A.shape[0]
    H = np.broadcast_to(D, (s.size,) + D.shape).astype(complex)
    if n == 0:
        return H.copy()
    lam, V = np.linalg.eig(A)
    cond = np.linalg.cond(V)
    if np.isfinite(cond) and cond < 1e5:
        CV = C @ V
        VB = np.linalg.solve(V, B)
        inv = 1.0 / (s[:, None] - lam[None, :])          # (nw, n)
        return H + np.einsum("in,wn,nj->wij", CV, inv, VB, optimize=True)
    # robust path: Hessenberg form, then one batched solve per chunk of frequencies
    from scipy.linalg import hessenberg
    Hh, Q = hessenberg(A, calc_q=True)
    QB = Q.T @ B
    CQ = C @ Q
    eye = np.eye(n)
    out = np.empty_like(H)
    chunk = max(1, int(2e7 // max(n * n, 1)))
    for i in range(0, s.size, chunk):
        ss = s[i:i + chunk]
        Z = ss[:, None, None] * eye - Hh
        try:
            X = np.linalg.solve(Z, np.broadcast_to(QB, (ss.size,) + QB.shape))
        except np.linalg.LinAlgError:
            raise ValueError("the system has a pole on the frequency grid (j w I - A is "
                             "singular at some freq): move the grid or damp the pole") from None
        out[i:i + chunk] = CQ @ X + D
    return out
