"""State-space kernels shared by the data, modal, uncertainty and robust modules (internal).

:func:`second_order` realises the modal equations (2.15) ``p'' + Gamma p' + Omega p = phib u``,
``y = cphi p^(k)`` (states ``[p; p']``), the one realisation of normal-mode models, of uncertain
models and of their perturbations; :func:`correction_filter` realises the improper terms of
velocity/acceleration outputs through critically damped correction modes (2.20), for normal-
and complex-mode models alike.  :func:`ss_frf` evaluates ``C (j w I - A)^-1 B + D`` on a
frequency grid, vectorised.  Both sit before every module of the flow (``data``, ``modal``,
``robust``...) so that none of them imports them from another's namespace.
"""

from __future__ import annotations

import numpy as np

__all__ = ["correction_filter", "modal_states", "second_order", "ss_frf"]


def second_order(Omega, Gamma, phib, cphi, k: int = 0):
    """State-space matrices of the modal second-order system, thesis eq. (2.15).

    ``p'' + Gamma p' + Omega p = phib u`` with output ``y = cphi p``, ``cphi p'`` or
    ``cphi p''`` (displacement, velocity, acceleration), states ``x = [p; p']``:
    ``A = [[0, I], [-Omega, -Gamma]]``, ``B = [0; phib]``, and for ``k = 2``
    ``C = -cphi [Omega, Gamma]``, ``D = cphi phib`` (``p'' = -Omega p - Gamma p' + phib u``).
    Static terms (``E``, ``F``) and correction modes (2.19)-(2.24) are added by the caller.

    Parameters
    ----------
    Omega, Gamma : ndarray, shape (n, n)
        Modal stiffness ((rad/s)^2) and damping (rad/s); full matrices accepted.
    phib : ndarray, shape (n, na)
        Modal controllability.
    cphi : ndarray, shape (ns, n)
        Modal observability (displacement sensors).
    k : {0, 1, 2}
        Time derivative of the output (0 displacement, 1 velocity, 2 acceleration).

    Returns
    -------
    A : ndarray, shape (2n, 2n)
    B : ndarray, shape (2n, na)
    C : ndarray, shape (ns, 2n)
    D : ndarray, shape (ns, na)

    Examples
    --------
    >>> A, B, C, D = second_order([[4.0]], [[0.4]], [[1.0]], [[2.0]], k=2)
    >>> A.tolist(), B.tolist(), C.tolist(), D.tolist()
    ([[0.0, 1.0], [-4.0, -0.4]], [[0.0], [1.0]], [[-8.0, -0.8]], [[2.0]])
    """
    Omega, Gamma = np.asarray(Omega, float), np.asarray(Gamma, float)
    phib, cphi = np.asarray(phib, float), np.asarray(cphi, float)
    n, na, ns = Omega.shape[0], phib.shape[1], cphi.shape[0]
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Omega, -Gamma]])
    B = np.vstack([np.zeros((n, na)), phib])
    if k == 0:
        C, D = np.hstack([cphi, np.zeros((ns, n))]), np.zeros((ns, na))
    elif k == 1:
        C, D = np.hstack([np.zeros((ns, n)), cphi]), np.zeros((ns, na))
    elif k == 2:
        C, D = np.hstack([-cphi @ Omega, -cphi @ Gamma]), cphi @ phib
    else:
        raise ValueError(f"k must be 0, 1 or 2 (output derivative), got {k!r}")
    return A, B, C, D


def correction_filter(P1, P2, wc: float):
    """``(P1 s + P2 s^2) w_c^2 / (s + w_c)^2``: a critically damped mode per input (2.20).

    ``z'' + 2 w_c z' + w_c^2 z = w_c^2 u`` (states ``[z; z']``, one pair per input) and
    ``y = P1 z' + P2 z''``: the terms ``P1 s`` and ``P2 s^2``, which no proper system holds,
    reproduced in the band to a relative error of about ``2 w / w_c``.

    Parameters
    ----------
    P1, P2 : ndarray, shape (ns, na)
        Coefficients of ``s`` and ``s^2``.
    wc : float
        Cut-off (rad/s).

    Returns
    -------
    A : ndarray, shape (2na, 2na)
    B : ndarray, shape (2na, na)
    C : ndarray, shape (ns, 2na)
    D : ndarray, shape (ns, na)

    Examples
    --------
    >>> A, B, C, D = correction_filter([[0.0]], [[1.0]], 10.0)
    >>> A.tolist(), B.tolist(), C.tolist(), D.tolist()
    ([[0.0, 1.0], [-100.0, -20.0]], [[0.0], [100.0]], [[-100.0, -20.0]], [[100.0]])
    """
    P1, P2 = np.asarray(P1, float), np.asarray(P2, float)
    na = P1.shape[1]
    Ii, Zi = np.eye(na), np.zeros((na, na))
    A = np.block([[Zi, Ii], [-wc**2 * Ii, -2 * wc * Ii]])
    B = np.vstack([Zi, wc**2 * Ii])
    C = np.hstack([-wc**2 * P2, P1 - 2 * wc * P2])
    return A, B, C, wc**2 * P2


def modal_states(n: int) -> list[str]:
    """State names of :func:`second_order`: ``p0..p(n-1)`` then ``dp0..dp(n-1)``.

    Parameters
    ----------
    n : int
        Number of modes.

    Returns
    -------
    list of str
    """
    return [f"p{j}" for j in range(n)] + [f"dp{j}" for j in range(n)]


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
