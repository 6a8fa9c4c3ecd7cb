"""Band-limited output covariance of a state-space model, closed form (internal).

``W = int_{w1}^{w2} H(jw) S H(jw)^H dw`` for ``H(s) = C (sI - A)^-1 B + D``: with
``R = (jw I - A)^-1``, ``L = int R dw = -j [log(j w2 I - A) - log(j w1 I - A)]`` (principal
logarithms, continuous along the path because ``A`` is stable) and ``X = int R Q R^H dw``
solving ``A X + X A^H = -(L Q + Q L^H)`` with ``Q = B S B^H`` (the frequency-limited Gramian
of Gawronski and Juang).  Three ways, fastest first:

1. the eigenbasis of ``A`` when it is well conditioned: scalar logarithms, an elementwise
   Lyapunov solution;
2. a block-diagonal basis when ``A`` has (nearly) defective clusters of eigenvalues, such as
   the critically damped static correction modes (2.19)-(2.20): each cluster's invariant
   subspace, triangularised, gives ``A = W (D + N) W^-1`` with ``N`` nilpotent inside the
   clusters; the logarithms of the 2x2 triangular blocks are closed form and the Lyapunov
   equation is solved exactly by a terminating Neumann series in ``N``;
3. matrix logarithms (any ``A``), slow.

A system with undamped poles (rigid-body modes, residual-mass double integrators, undamped
modes) outside the band has a finite band integral too, but the Lyapunov equation above is
then singular (``lambda_i + conj(lambda_j) = 0``): :func:`band_integral_undamped` moves
those poles slightly into the left half-plane and extrapolates back (Richardson).
"""

from __future__ import annotations

import numpy as np

__all__ = ["band_integral", "band_integral_undamped"]

#: eigenvalues closer than this (relative) form one cluster (a defective double pole splits
#: by about sqrt(machine epsilon) in floating point)
CLUSTER_RTOL = 1e-6


def band_integral(A, B, C, D, S, w1: float, w2: float) -> np.ndarray:
    """``int_{w1}^{w2} H(jw) diag(S) H(jw)^H dw`` (finite ``w2``) for a stable ``A``.

    Parameters
    ----------
    A, B, C, D : ndarray
        State-space matrices.
    S : ndarray
        One-sided input PSD weights, one per input.
    w1, w2 : float
        Band (rad/s), ``0 <= w1 < w2 < inf``.

    Returns
    -------
    ndarray
        ``(ny, ny)`` complex matrix.
    """
    SD = S[:, None] * D.T                                    # S D^T
    W = (w2 - w1) * (D @ SD)
    if A.shape[0] == 0:
        return W
    lam, V = np.linalg.eig(A)
    if np.linalg.cond(V) < 1e6:
        return W + _diagonal(lam, V, np.linalg.inv(V), None, B, C, SD, S, w1, w2)
    blocks = cluster_blocks(A)
    if blocks is not None:
        return W + _diagonal(*blocks, B, C, SD, S, w1, w2)
    return W + _logm(A, B, C, SD, S, w1, w2)


def _diagonal(lam, V, Vi, N, B, C, SD, S, w1, w2):
    """Integral in a basis where ``A = V (diag(lam) + N) V^-1``, ``N`` nilpotent (or None)."""
    Bt, Ct = Vi @ B, C @ V
    Qt = (Bt * S) @ Bt.conj().T
    L = log_difference(lam, N, w1, w2)
    K = 1.0 / (lam[:, None] + lam.conj()[None, :])
    rhs = -(L @ Qt + Qt @ L.conj().T)
    X = K * rhs
    if N is not None:
        # (D + N) X + X (D + N)^H = rhs: X = X0 - T(X) with T(X) = K o (N X + X N^H); N has
        # one entry per 2x2 cluster, so T^3 = 0 and three passes give the exact solution
        X0 = X
        for _ in range(3):
            X = X0 - K * (N @ X + X @ N.conj().T)
    CY = Ct @ (L @ (Bt @ SD))
    return Ct @ X @ Ct.conj().T + CY + CY.conj().T


def log_difference(lam, N, w1, w2):
    """``-j [log(j w2 - T) - log(j w1 - T)]`` for ``T = diag(lam) + N`` (2x2 clusters)."""
    p2, p1 = 1j * w2 - lam, 1j * w1 - lam
    L = np.diag(-1j * (np.log(p2) - np.log(p1)))
    if N is None:
        return L
    for i, k in zip(*np.nonzero(N)):
        # log of [[p, -b], [0, q]]: off-diagonal -b (log p - log q) / (p - q), divided
        # difference taken through log1p (p and q may agree to ~1e-8)
        b = N[i, k]
        f = [(_divided_log(p[i], p[k])) for p in (p2, p1)]
        L[i, k] = -1j * (-b * f[0] + b * f[1])
    return L


def _divided_log(p, q):
    """``(log p - log q) / (p - q)``, accurate when ``p`` and ``q`` are close."""
    d = p - q
    if abs(d) <= 1e-3 * abs(q):
        x = d / q
        return np.log1p(x) / d if x != 0 else 1.0 / q
    return (np.log(p) - np.log(q)) / d


def cluster_blocks(A):
    """``(lam, W, Wi, N)`` with ``A = W (diag(lam) + N) W^-1`` and ``N`` strictly upper
    triangular inside clusters of at most two close eigenvalues; None when that fails.

    ``A`` is balanced first (diagonal similarity: correction modes put ``omega_c^2`` next to
    1 in it); a cluster's invariant subspace is its eigenvector and the generalised
    eigenvector solving ``(A - mu I) u = v`` (least squares), orthonormalised.
    """
    from scipy.linalg import matrix_balance, schur

    Ab, (t, _) = matrix_balance(A, permute=False, separate=True)   # Ab = t^-1 A t
    lam, V = np.linalg.eig(Ab)
    n, scale = lam.size, np.abs(lam).max()
    groups, used = [], np.zeros(n, bool)
    for i in np.argsort(lam.real + 1e-3 * lam.imag):
        if not used[i]:
            tol = CLUSTER_RTOL * max(abs(lam[i]), 1e-12 * scale)
            close = np.flatnonzero(~used & (np.abs(lam - lam[i]) <= tol))
            used[close] = True
            groups.append(close)
    if max(len(g) for g in groups) > 2:
        return None
    cols = []
    for g in groups:
        v = V[:, g[:1]]
        if len(g) == 2:
            u = np.linalg.lstsq(Ab - lam[g].mean() * np.eye(n), v, rcond=None)[0]
            v = np.linalg.qr(np.hstack([v, u]))[0]
        cols.append(v)
    W = np.hstack(cols).astype(complex)
    if np.linalg.cond(W) > 1e8:
        return None
    Wi = np.linalg.inv(W)
    T = Wi @ Ab @ W
    out_lam, N, k = np.empty(n, complex), np.zeros((n, n), complex), 0
    for g in groups:
        if len(g) == 2:
            Tk, Z = schur(T[k:k + 2, k:k + 2], output="complex")
            W[:, k:k + 2] = W[:, k:k + 2] @ Z
            Wi[k:k + 2] = Z.conj().T @ Wi[k:k + 2]
            out_lam[k:k + 2] = np.diag(Tk)
            N[k, k + 1] = Tk[0, 1]
        else:
            out_lam[k] = T[k, k]
        k += len(g)
    if np.abs(Wi @ Ab @ W - (np.diag(out_lam) + N)).max() > 1e-9 * max(scale, 1e-300):
        return None
    return out_lam, t[:, None] * W, Wi / t[None, :], N


def _logm(A, B, C, SD, S, w1, w2):
    """The general case: matrix logarithms and a dense Lyapunov solution."""
    import warnings

    from scipy.linalg import expm, logm, solve_continuous_lyapunov

    n = A.shape[0]
    Id = np.eye(n)
    logs = []
    for w in (w2, w1):
        Z = 1j * w * Id - A
        with warnings.catch_warnings():          # scipy's own estimate is checked below
            warnings.simplefilter("ignore", RuntimeWarning)
            Lw = logm(Z)
        err = np.linalg.norm(expm(Lw) - Z, 1) / np.linalg.norm(Z, 1)
        if err > 1e-6:
            warnings.warn(f"rms: the matrix logarithm of a defective A is inaccurate "
                          f"(relative error {err:.1e})", RuntimeWarning, stacklevel=4)
        logs.append(Lw)
    L = -1j * (logs[0] - logs[1])
    Q = (B * S) @ B.T
    X = solve_continuous_lyapunov(A.astype(complex), -(L @ Q + Q @ L.conj().T))
    CY = C @ (L @ (B @ SD))
    return C @ X @ C.T + CY + CY.conj().T


def band_integral_undamped(A, B, C, D, S, w1: float, w2: float, axis) -> np.ndarray:
    """:func:`band_integral` of a system with undamped poles outside the band.

    The poles selected by ``axis`` (a predicate on eigenvalues) are moved left by ``eps``
    inside an ordered real Schur form (the others, and the coupling, unchanged), the closed
    form is taken at ``eps``, ``2 eps`` and ``4 eps`` and extrapolated to ``eps = 0``
    (Richardson, error ``O((eps / d)^3)`` with ``d`` the distance of those poles to the band;
    ``eps = 5e-3 d``: about 1e-5 relative, the shifted closed form losing digits as ``1/eps^2``).
    The integral is analytic in ``eps`` because no shifted pole reaches
    the band.

    Parameters
    ----------
    A, B, C, D, S, w1, w2
        As for :func:`band_integral` (``w2`` finite).
    axis : callable
        ``axis(re, im) -> bool`` for the undamped eigenvalues ``re + j im``.

    Returns
    -------
    ndarray
        ``(ny, ny)`` complex matrix.
    """
    from scipy.linalg import schur

    T, U, k = schur(A, output="real", sort=axis)
    lam = np.linalg.eigvals(T[:k, :k])
    w = np.abs(lam.imag)
    dist = np.min(np.minimum(np.abs(w - w1), np.abs(w - w2)))
    eps = 5e-3 * dist
    Bu, Cu = U.T @ B, C @ U
    shift = np.zeros(A.shape[0])
    shift[:k] = 1.0

    def at(e):
        return band_integral(T - np.diag(e * shift), Bu, Cu, D, S, w1, w2)

    return (8 * at(eps) - 6 * at(2 * eps) + at(4 * eps)) / 3
