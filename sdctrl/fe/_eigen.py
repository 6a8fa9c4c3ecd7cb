"""Normal modes of FE models: dense and shift-invert sparse eigensolutions, rigid-body modes.

``K phi = M phi diag(omega^2)`` with mass-normalised modes ``phi^T M phi = I`` (thesis 2.1),
``omega`` in rad/s; the sign of each shape is fixed (largest entry positive) so that a
result depends only on the matrices and the request.  Free structures have rigid-body
modes at zero frequency: eigenvalues below :data:`RIGID_RTOL` times
``max(diag K / diag M)``.

The functions are pure (matrices in, arrays out); :class:`~sdctrl.fe.FEModel` caches their
results keyed on the request only, so no result depends on the order of the calls.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

__all__ = ["DENSE_MAX", "RIGID_RTOL", "check_request", "diagonal_scale", "eigensolve",
           "rigid_modes", "shift_invert", "stiffness_factor"]

#: eigenvalues below ``RIGID_RTOL * max(diag K / diag M)`` are rigid-body modes
RIGID_RTOL = 1e-12
#: ``modes(method="auto")`` uses the dense ``eigh`` up to this many DOFs
DENSE_MAX = 1200


def diagonal_scale(K, M) -> tuple[float, float]:
    """(median, max) of the positive ``diag K / diag M`` in (rad/s)^2 ((1, 1) if none).

    Parameters
    ----------
    K, M : ndarray or sparse matrix, shape (N, N)
        Stiffness and mass.

    Returns
    -------
    (float, float)
    """
    r = np.asarray(K.diagonal(), float) / np.asarray(M.diagonal(), float)
    r = r[r > 0]
    return (float(np.median(r)), float(r.max())) if r.size else (1.0, 1.0)


def check_request(n, N: int, method: str) -> str:
    """Validate a request for ``n`` modes of ``N`` DOFs; returns the resolved method.

    Parameters
    ----------
    n : int
        Number of modes, ``1 <= n <= N``.
    N : int
        Number of DOFs.
    method : {"auto", "dense", "sparse"}
        ``"auto"`` is dense up to :data:`DENSE_MAX` DOFs (or when ``n >= N - 1``).

    Returns
    -------
    {"dense", "sparse"}
    """
    if isinstance(n, bool) or not isinstance(n, int | np.integer):
        raise TypeError(f"n must be an integer number of modes, got {type(n).__name__}")
    if not 1 <= n <= N:
        raise ValueError(f"n must lie in [1, N={N}], got {n}")
    if method not in ("auto", "dense", "sparse"):
        raise ValueError(f"method must be 'auto', 'dense' or 'sparse', got {method!r}")
    if method == "auto":
        method = "dense" if (N <= DENSE_MAX or n >= N - 1) else "sparse"
    return method


def stiffness_factor(K):
    """``L D L^T`` of a sparse ``K`` that is positive definite (a fixed structure), else None.

    One symmetric-mode sparse LU without pivoting (minimum degree ordering of ``K``): every
    pivot positive, none below :data:`RIGID_RTOL` times the largest diagonal entry (the
    rigid-body test of :func:`rigid_modes` on the pivots), proves ``K`` positive definite.
    That one factorisation is then the static solver (``K^-1``, 2.21), the shift-invert
    operator of the modes at ``sigma = 0`` and the proof that the structure has no
    rigid-body mode: a fixed structure is factorised once for all three.

    Parameters
    ----------
    K : sparse matrix, shape (N, N)
        Stiffness.

    Returns
    -------
    scipy.sparse.linalg.SuperLU or None
        None for a dense ``K`` or one that is not (safely) positive definite: free
        structures keep the negative shift and the inertia-relief solver.
    """
    if not sp.issparse(K):
        return None
    A = sp.csc_matrix(K)
    d = np.asarray(A.diagonal())
    if d.size == 0 or np.any(d <= 0):
        return None
    try:
        lu = spla.splu(A, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                       options={"SymmetricMode": True})
    except RuntimeError:
        return None
    if not np.array_equal(lu.perm_r, lu.perm_c):
        return None
    if np.any(lu.U.diagonal() <= RIGID_RTOL * float(d.max())):
        return None
    return lu


def eigensolve(K, M, n: int, method: str, sigma: float | None = None, factor=None):
    """Lowest ``n`` eigenpairs of ``K phi = M phi lambda``, mass-normalised, signs fixed.

    Parameters
    ----------
    K, M : ndarray or sparse matrix, shape (N, N)
        Stiffness and mass (symmetric, ``M`` positive definite).
    n : int
        Number of modes.
    method : {"dense", "sparse"}
        ``scipy.linalg.eigh`` on a subset, or shift-invert ``eigsh`` followed by a
        Rayleigh-Ritz clean-up (exact M-orthonormality, accurate eigenvalues).
    sigma : float, optional
        Shift (rad/s)^2 of the sparse solver; default ``-1e-6 median(diag K / diag M)``,
        or 0 with ``factor``.
    factor : SuperLU, optional
        :func:`stiffness_factor` of ``K``: with ``sigma=None`` the sparse solver shifts at 0
        and reuses it instead of factorising ``K - sigma M``.

    Returns
    -------
    lam : ndarray, shape (n,)
        Eigenvalues (rad/s)^2, increasing (Rayleigh quotients for the dense solver).
    phi : ndarray, shape (N, n)
        Mass-normalised shapes, largest entry of each positive.
    """
    N = M.shape[0]
    if method == "dense":
        lam, phi = _dense(K, M, n)
    else:
        if n >= N - 1:
            raise ValueError(f"n must be < N - 1 = {N - 1} for the sparse eigensolver, "
                             f"got {n}; use method='dense'")
        median, scale = diagonal_scale(K, M)
        if sigma is None and factor is not None:
            return _signs(*_sparse(K, M, n, 0.0, factor))
        if sigma is None:
            sigma = -1e-6 * median
        elif abs(sigma) > 1e12 * scale:
            raise ValueError(f"sigma = {sigma:g} (rad/s)^2 is {abs(sigma) / scale:.1e} times the "
                             "model's own eigenvalue scale (diag K / diag M): K - sigma M is then "
                             "sigma M to machine precision; give sigma near the squared circular "
                             "frequency (2 pi f)^2 of the wanted modes, or leave it None")
        lam, phi = _sparse(K, M, n, float(sigma))
    return _signs(lam, phi)


def _signs(lam, phi):
    """Eigenpairs sorted, the largest entry of each shape positive."""
    order = np.argsort(lam)
    lam, phi = lam[order], phi[:, order]
    idx = np.argmax(np.abs(phi), axis=0)
    sgn = np.sign(phi[idx, np.arange(phi.shape[1])])
    sgn[sgn == 0] = 1.0
    return lam, phi * sgn


def _dense(K, M, n):
    K = K.toarray() if sp.issparse(K) else np.asarray(K)
    M = M.toarray() if sp.issparse(M) else np.asarray(M)
    lam, phi = sla.eigh(K, M, subset_by_index=[0, n - 1])
    # Rayleigh quotients: eigenvalues accurate to second order in the shapes
    # (eigh's small eigenvalues carry an error ~ eps * lambda_max)
    lam = np.einsum("ij,ij->j", phi, K @ phi) / np.einsum("ij,ij->j", phi, M @ phi)
    return lam, phi


def shift_invert(K, M, sigma: float) -> spla.LinearOperator:
    """``(K - sigma M)^-1`` as an operator, from one symmetric-mode sparse LU.

    SuperLU in symmetric mode (minimum degree ordering of ``A + A^T``, diagonal pivots
    preferred) is an ``L D L^T`` for the symmetric positive definite ``K - sigma M`` of the
    default negative shift: on FE matrices it fills in about half as much as the
    unsymmetric ``COLAMD`` factorisation ``eigsh(..., sigma=...)`` does on its own, and
    factorises several times faster.  Pivoting stays allowed (threshold 0.1), so a shift
    inside the spectrum (indefinite ``K - sigma M``) is factorised stably too.

    Parameters
    ----------
    K, M : sparse matrix, shape (N, N)
        Stiffness and mass.
    sigma : float
        Shift (rad/s)^2.

    Returns
    -------
    scipy.sparse.linalg.LinearOperator
        ``x -> (K - sigma M)^-1 x``.
    """
    A = (K - sigma * M).tocsc()
    try:
        lu = spla.splu(A, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.1,
                       options={"SymmetricMode": True})
    except RuntimeError:
        raise ValueError(f"sigma: K - sigma M is singular at sigma = {sigma:g} (rad/s)^2, "
                         "a shift on an eigenvalue; choose another shift") from None
    return spla.LinearOperator(A.shape, matvec=lu.solve, dtype=float)


def _sparse(K, M, n, sigma, factor=None):
    N = M.shape[0]
    v0 = np.random.default_rng(0).standard_normal(N)
    K = sp.csc_matrix(K)
    M = sp.csc_matrix(M)
    op = (shift_invert(K, M, sigma) if factor is None
          else spla.LinearOperator(K.shape, matvec=factor.solve, dtype=float))
    try:
        lam, phi = spla.eigsh(K, k=n, M=M, sigma=sigma, which="LM", v0=v0, OPinv=op,
                              ncv=min(N, max(2 * n + 1, n + 20)))
    except spla.ArpackError as exc:
        raise ValueError(f"the sparse eigensolver failed for n={n}, sigma={sigma:g} (rad/s)^2 "
                         f"({exc}): try sigma nearer the wanted modes' (2 pi f)^2, fewer modes, "
                         "or method='dense' for a small model") from exc
    # Rayleigh-Ritz clean-up: exact M-orthonormality, accurate eigenvalues
    Kr = phi.T @ (K @ phi)
    Mr = phi.T @ (M @ phi)
    lam, V = sla.eigh(0.5 * (Kr + Kr.T), 0.5 * (Mr + Mr.T))
    return lam, phi @ V


def rigid_modes(eigen: Callable, N: int, threshold: float) -> np.ndarray:
    """Rigid-body modes: the eigenvectors below ``threshold``, from a fixed ladder of solves.

    ``eigen(k)`` is asked for ``k = min(N, 12)`` modes, doubled until a flexible mode shows
    (or all ``N`` are computed), so the result depends only on the model.

    Parameters
    ----------
    eigen : callable
        ``eigen(k) -> (lam, phi)``, the lowest ``k`` eigenpairs (e.g. a cached
        :func:`eigensolve`).
    N : int
        Number of DOFs.
    threshold : float
        Eigenvalue (rad/s)^2 below which a mode is rigid.

    Returns
    -------
    ndarray, shape (N, r)
        Mass-normalised rigid-body modes (r = 0 for a fixed structure).
    """
    k = min(N, 12)
    while True:
        lam, phi = eigen(k)
        if not np.all(lam < threshold) or k >= N:
            break
        k = min(N, 2 * k)
    return phi[:, lam < threshold].copy()
