"""Band integral of a system with a fixed block appended, for many systems (internal).

A sweep closes many loops on one model, each changing only part of it: ``A = diag(A1, A2)``
with ``A1`` the changed part (diagonalisable: the closed-loop modes) and ``A2`` the fixed
part that no candidate touches (a residual mass's critically damped correction modes
(2.19)-(2.24), complex-mode residual terms at the tested I/O).  :func:`band_integral` then
falls back to matrix logarithms (``A2`` is defective), about 0.4 s per system.  With the
method of :mod:`sdctrl._lib.bandint` written in the basis ``diag(V1, I)``:

- the logarithm ``L = -j [log(j w2 - A) - log(j w1 - A)]`` is block diagonal: scalars for
  ``A1``'s eigenvalues, and ``L2`` of the fixed block computed once;
- the Lyapunov equation ``A X + X A^H = -(L Q + Q L^H)`` splits into an elementwise
  ``X11``, the fixed ``X22`` (once) and the Sylvester block ``Lambda X12 + X12 A2^H =
  R12``, solved by column substitution in the Schur basis of ``A2^H`` (computed once).

The result equals :func:`band_integral` of the assembled system to rounding.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sdctrl._lib.bandint import cluster_blocks, log_difference

__all__ = ["FixedBlock", "band_integral_appended", "fixed_block"]


@dataclass(frozen=True, eq=False)
class FixedBlock:
    """What :func:`band_integral_appended` reuses of the fixed block ``(A2, B2, C2, D)``.

    ``L2`` its log difference, ``U, T`` the complex Schur form ``A2^H = U T U^H``, ``X22``
    its own Lyapunov solution, ``S`` the inputs' weight, ``band`` ``(w1, w2)`` (rad/s),
    ``lam`` its eigenvalues.
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    S: np.ndarray
    band: tuple
    L2: np.ndarray | None
    U: np.ndarray | None
    T: np.ndarray | None
    X22: np.ndarray | None
    lam: np.ndarray


def fixed_block(A2, B2, C2, D, S, w1: float, w2: float, undamped: bool = False) -> FixedBlock:
    """Precompute the fixed block of :func:`band_integral_appended`.

    Parameters
    ----------
    A2, B2, C2 : ndarray
        Its realisation (stable, ``A2`` may be defective).
    D : ndarray
        The feedthrough of the assembled system.
    S : ndarray
        One-sided input PSD weights, one per input.
    w1, w2 : float
        Band (rad/s), finite.
    undamped : bool
        ``A2`` has poles on the imaginary axis: nothing is precomputed (``L2`` None).

    Returns
    -------
    FixedBlock
    """
    import warnings

    from scipy.linalg import expm, logm, schur, solve_continuous_lyapunov

    lam2 = np.linalg.eigvals(A2)
    if undamped:
        return FixedBlock(A2, B2, C2, D, S, (w1, w2), None, None, None, None, lam2)
    k = A2.shape[0]
    logs = []
    for w in (w2, w1):
        Z = 1j * w * np.eye(k) - A2
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            Lw = logm(Z)
        err = np.linalg.norm(expm(Lw) - Z, 1) / max(np.linalg.norm(Z, 1), 1e-300)
        if err > 1e-6:
            raise ValueError(f"the matrix logarithm of the fixed block is inaccurate "
                             f"(relative error {err:.1e})")
        logs.append(Lw)
    L2 = -1j * (logs[0] - logs[1])
    Q22 = (B2 * S) @ B2.T
    X22 = solve_continuous_lyapunov(A2.astype(complex), -(L2 @ Q22 + Q22 @ L2.conj().T))
    T, U = schur(A2.T.astype(complex), output="complex")     # A2^H = U T U^H (A2 real)
    return FixedBlock(A2, B2, C2, D, S, (w1, w2), L2, U, T, X22, lam2)


def band_integral_appended(A1, B1, C1, fixed: FixedBlock):
    """``int H S H^H dw`` over ``fixed.band`` for ``H = C (sI - diag(A1, A2))^-1 B + D``.

    Parameters
    ----------
    A1, B1, C1 : ndarray
        The changed block (``B1`` its rows of ``B``, ``C1`` its columns of ``C``).
    fixed : FixedBlock
        The rest (:func:`fixed_block`).

    Returns
    -------
    ndarray or None
        ``(ny, ny)`` complex matrix; None when ``A1`` has neither a well-conditioned
        eigenbasis nor the block form of :func:`sdctrl._lib.bandint.band_integral`, or the
        fixed block has undamped poles (``fixed.L2`` None): then integrate the
        assembled system with :func:`band_integral` or :func:`band_integral_undamped`.
    """
    if fixed.L2 is None:
        return None
    basis = _basis(A1)
    if basis is None:
        return None
    lam, V, Vi, N = basis
    w1, w2 = fixed.band
    S, D = fixed.S, fixed.D
    Bt1, Bt2 = Vi @ B1, fixed.B
    Ct = np.hstack([C1 @ V, fixed.C])
    L1 = log_difference(lam, N, w1, w2)
    BS1 = Bt1 * S
    Q11, Q12 = BS1 @ Bt1.conj().T, BS1 @ Bt2.T
    R11 = -(L1 @ Q11 + Q11 @ L1.conj().T)
    R12 = -(L1 @ Q12 + Q12 @ fixed.L2.conj().T)
    K = 1.0 / (lam[:, None] + lam.conj()[None, :])
    X11 = X0 = K * R11
    if N is not None:            # terminating Neumann series, as bandint._diagonal
        for _ in range(3):
            X11 = X0 - K * (N @ X11 + X11 @ N.conj().T)
    X12 = _sylvester(lam, N, fixed.U, fixed.T, R12)
    X = np.block([[X11, X12], [X12.conj().T, fixed.X22]])
    SD = S[:, None] * D.T
    CY = Ct @ np.vstack([L1 @ (Bt1 @ SD), fixed.L2 @ (Bt2 @ SD)])
    return (w2 - w1) * (D @ SD) + Ct @ X @ Ct.conj().T + CY + CY.conj().T


def _basis(A1):
    """``(lam, V, V^-1, N)`` with ``A1 = V (diag(lam) + N) V^-1`` (``N`` None: diagonal),
    as :func:`sdctrl._lib.bandint.band_integral` chooses it; None when neither works."""
    lam, V = np.linalg.eig(A1)
    if np.linalg.cond(V) < 1e6:
        return lam, V, np.linalg.inv(V), None
    return cluster_blocks(A1)


def _sylvester(lam, N, U, T, R):
    """``X`` with ``(diag(lam) + N) X + X M = R`` for ``M = U T U^H`` (``T`` upper
    triangular, ``N`` nilpotent with one entry per 2x2 cluster or None): column
    substitution in the Schur basis of ``M``, two passes for ``N`` (``N^2 = 0``)."""
    Rt = R @ U
    Y = np.zeros_like(Rt)
    for j in range(T.shape[0]):
        rhs = Rt[:, j] - Y[:, :j] @ T[:j, j]
        d = lam + T[j, j]
        y = rhs / d
        if N is not None:
            for _ in range(2):
                y = (rhs - N @ y) / d
        Y[:, j] = y
    return Y @ U.conj().T
