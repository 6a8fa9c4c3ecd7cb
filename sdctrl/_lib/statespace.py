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

__all__ = ["complex_blocks", "correction_filter", "default_omega_f", "mass_correction",
           "modal_states", "pole_moduli", "second_order", "ss_frf"]


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


def complex_blocks(poles, residues):
    """Real 2-state blocks of complex modes, thesis (3.26)-(3.33) with ``a = 1``.

    ``sum_j R_j / (s - lambda_j) + conj(R_j) / (s - conj(lambda_j))`` realised with one
    block ``[[0, 1], [-|lambda|^2, 2 Re(lambda)]]`` per non-negligible dyad of each
    residue (singular values above ``1e-13`` of the largest): the complex-mode terms as
    they are, without any scaling by collocated residues.

    Parameters
    ----------
    poles : ndarray, shape (m,), complex
        Poles (rad/s), upper half-plane.
    residues : ndarray, shape (m, ns, na), complex
        Displacement residues.

    Returns
    -------
    A : ndarray, shape (2r, 2r)
    B : ndarray, shape (2r, na)
    C : ndarray, shape (ns, 2r)
    states : list of str
        ``x{j}_{k}``, ``dx{j}_{k}`` for dyad ``k`` of pole ``j``.

    Examples
    --------
    >>> import numpy as np
    >>> A, B, C, st = complex_blocks(np.array([-1 + 10j]), np.array([[[-0.05j]]]))
    >>> H = ss_frf(A, B, C, np.zeros((1, 1)), [3.0])[0, 0, 0]
    >>> bool(np.isclose(H, -0.05j / (3j + 1 - 10j) + 0.05j / (3j + 1 + 10j)))
    True
    """
    poles = np.asarray(poles, complex)
    residues = np.asarray(residues, complex)
    m, ns, na = residues.shape
    blocks_A, Cs, Bs, states = [], [], [], []
    U, sv, Vh = np.linalg.svd(residues, full_matrices=False) if m else (None, None, None)
    for j in range(m):
        lam = poles[j]
        w, zw, wd = abs(lam), -lam.real, lam.imag
        smax = sv[j, 0] if sv.shape[1] else 0.0
        for k in range(sv.shape[1]):
            if smax == 0 or sv[j, k] <= 1e-13 * smax:
                continue
            cpsi, psib = U[j, :, k], sv[j, k] * Vh[j, k, :]
            blocks_A.append(np.array([[0.0, 1.0], [-w**2, -2 * zw]]))
            Cs.append(np.column_stack([cpsi.real + (zw / wd) * cpsi.imag, cpsi.imag / wd]))
            Bs.append(np.vstack([2 * psib.real, -2 * (zw * psib.real + wd * psib.imag)]))
            states += [f"x{j}_{k}", f"dx{j}_{k}"]
    r = len(blocks_A)
    A = np.zeros((2 * r, 2 * r))
    for i, Aj in enumerate(blocks_A):
        A[2 * i:2 * i + 2, 2 * i:2 * i + 2] = Aj
    B = np.vstack(Bs) if Bs else np.zeros((0, na))
    C = np.hstack(Cs) if Cs else np.zeros((ns, 0))
    return A, B, C, states


def mass_correction(F, wf: float, k: int = 0):
    """``F / s^2`` of a residual mass (2.23): correction modes below the band or rigid (2.24).

    With ``w_f > 0``, stable critically damped correction modes (a triple real pole at
    ``-w_f`` per input), ``F (s + 3 w_f) / (s + w_f)^3``: the low-frequency counterpart of
    (2.19)-(2.20), equal to ``F / s^2`` in the band (``w >> w_f``) to a relative error of
    ``3 (w_f / w)^2`` (3% a decade above ``w_f``, phase included) -- the numerator cancels the
    first-order error ``2 w_f / w`` of the plain critically damped mode ``1 / (s + w_f)^2``,
    which shifts the phase by 11 degrees a decade above ``w_f``.  States ``[z; z'; z'']``
    per input, ``z^(3) + 3 w_f z'' + 3 w_f^2 z' + w_f^3 z = u``, output ``F (z' + 3 w_f z)``
    and its derivatives.  ``w_f = 0`` gives the exact rigid-body form (2.24), double
    integrators ``z'' = u`` (states ``[z; z']``, poles at 0), output ``F z`` and derivatives.

    Parameters
    ----------
    F : ndarray, shape (ns, na)
        Residual mass term of the displacement response.
    wf : float
        Corner (rad/s) of the correction modes, 0 for the rigid-body form.
    k : {0, 1, 2}
        Output derivative.

    Returns
    -------
    A : ndarray, shape (3na, 3na), or (2na, 2na) when ``wf == 0``
    B : ndarray, shape (3na, na) or (2na, na)
    C : ndarray, shape (ns, 3na) or (ns, 2na)
    D : ndarray, shape (ns, na)

    Examples
    --------
    >>> A, B, C, D = mass_correction([[2.0]], 0.0, k=2)
    >>> A.tolist(), B.tolist(), C.tolist(), D.tolist()
    ([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]], [[0.0, 0.0]], [[2.0]])
    >>> A, B, C, D = mass_correction([[2.0]], 1.0, k=0)
    >>> A.tolist(), C.tolist()
    ([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-1.0, -3.0, -3.0]], [[6.0, 2.0, 0.0]])
    """
    F = np.asarray(F, float)
    ns, na = F.shape
    Ii, Zi, Zs = np.eye(na), np.zeros((na, na)), np.zeros((ns, na))
    if wf == 0:
        A = np.block([[Zi, Ii], [Zi, Zi]])
        B = np.vstack([Zi, Ii])
        C = [np.hstack([F, Zs]), np.hstack([Zs, F]), np.hstack([Zs, Zs])][k]
        return A, B, C, (F.copy() if k == 2 else Zs)
    A = np.block([[Zi, Ii, Zi], [Zi, Zi, Ii], [-wf**3 * Ii, -3 * wf**2 * Ii, -3 * wf * Ii]])
    B = np.vstack([Zi, Zi, Ii])
    if k == 0:
        return A, B, np.hstack([3 * wf * F, F, Zs]), Zs
    if k == 1:
        return A, B, np.hstack([Zs, 3 * wf * F, F]), Zs
    return A, B, np.hstack([-wf**3 * F, -3 * wf**2 * F, Zs]), F.copy()


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


def pole_moduli(model) -> np.ndarray:
    """Natural frequencies (rad/s) of a normal-mode model's modes and residual dynamics."""
    w = np.sqrt(np.clip(np.diag(model.Omega), 0, None))
    if model.residual is not None:
        w = np.concatenate([w, np.abs(model.residual.poles)])
    return w


def default_omega_f(model) -> float:
    """Default corner (rad/s) of the residual-mass correction modes: a decade below the band.

    ``model.omega_f`` when set; else a tenth of the lower edge of the identified band
    (``properness.band``) when it is positive, else a tenth of the lowest positive natural
    frequency of the modes and residual dynamics (1 rad/s for a model with none).
    """
    if model.omega_f is not None:
        return model.omega_f
    band = getattr(model.properness, "band", None)
    if band is not None and band[0] > 0:
        return 0.1 * 2 * np.pi * float(band[0])
    w = pole_moduli(model)
    w = w[w > 0]
    return 0.1 * float(w.min()) if w.size else 1.0
