"""Reduction of FE models to truncated normal-mode models (2.15), optionally completed by
static correction modes (2.21)-(2.22) made principal (4.24), or by the static feedthrough
``E`` (2.18).

The retained modes come from :meth:`FEModel.modes`, the correction modes from
:mod:`sdctrl.fe._static`; damping is modal (``2 zeta_j omega_j``) without ``C`` and the full
projection ``phi^T C phi`` (non-proportional) with it; appended static modes are critically
damped (2.20) or carry their projected damping.  :func:`full_frf` is the exact response of
the full model they approximate (a dense reference).
"""

from __future__ import annotations

import numpy as np

from sdctrl._lib.threads import single_thread
from sdctrl._lib.validate import QUANTITY_POWER, as_array, check_bool, check_finite_result
from sdctrl.fe._static import principal_static_basis

__all__ = ["damping_loads", "full_frf", "normal_mode_model"]


def normal_mode_model(fe, B, Cm, n: int, damping=0.01, static=False, *,
                      static_damping: str = "critical", sensors=None, actuators=None,
                      damping_paths: bool = False):
    """Truncated normal-mode model of ``fe`` for input shapes ``B`` and outputs ``Cm``.

    Parameters
    ----------
    fe : FEModel
        The model.
    B : ndarray, shape (N, na)
        Input shapes.
    Cm : ndarray, shape (ns, N)
        Output shapes (displacement sensors).
    n : int
        Number of retained normal modes.
    damping : float or array_like, shape (n,)
        Modal damping ratios (used when the model has no ``C``).
    static : bool or {"modes", "E"}
        Static correction as modes (2.22), as the feedthrough ``E`` (2.18), or none.
    static_damping : {"critical", "projected"}
        Damping of the appended static modes.
    sensors, actuators : sequence of str, optional
        Output and input labels.
    damping_paths : bool
        With ``static`` modes and ``static_damping="projected"``: also append the static
        correction modes of :func:`damping_loads` (zero for proportional damping), so that
        the dashpots' local flexibility is carried.  On the built-in truss (28 modes, 6
        shakers, three dashpots) the error against the full model at the tested I/O falls
        from 7.6e-4 to 1.2e-6 (mean logLS, 20-60 Hz) for 3 more states.

    Returns
    -------
    NormalModeModel
        See :meth:`FEModel.normal_mode_model`.
    """
    from sdctrl.modal._normal_model import NormalModeModel

    freq, phi = fe.modes(n)
    n = phi.shape[1]
    lam = np.clip(np.einsum("ij,ij->j", phi, np.asarray(fe.K @ phi)), 0, None)
    z = _check_options(fe, n, damping, static, static_damping)
    paths = check_bool(damping_paths, "damping_paths")
    if paths and (static not in (True, "modes") or static_damping != "projected"):
        raise ValueError("damping_paths=True needs static=True and static_damping='projected' "
                         "(the dampers' forces act through the static modes' projected "
                         f"damping), got static={static!r}, static_damping={static_damping!r}")
    Omega = np.diag(lam)
    E = None
    phiT = phi
    info = {"source": "FEModel", "n_modes": n, "frequency_hz": freq.copy()}
    n_static = 0
    if static in (True, "modes"):
        loads = np.hstack([B, damping_loads(fe, phi)]) if paths else B
        V, wc2 = _static_modes(fe, loads, phi)
        if V.shape[1]:
            phiT = np.hstack([phi, V])
            Omega = np.diag(np.concatenate([lam, wc2]))
            n_static = V.shape[1]
            info["static_frequency_hz"] = np.sqrt(np.clip(wc2, 0, None)) / (2 * np.pi)
    elif static == "E":
        E = Cm @ fe.static_correction(B, phi)
    Gamma = _damping(fe, phiT, Omega, n, z * 2 * np.sqrt(lam), static_damping)
    return NormalModeModel(Omega, Gamma, Cm @ phiT, phiT.T @ B, E=E, sensors=sensors,
                           actuators=actuators, shapes=phiT, dofs=fe.dofs, info=info,
                           n_static=n_static)


#: singular values of the modal damping forces' residual below this fraction of the
#: largest modal damping force are round-off (proportional damping gives ~1e-15)
DAMPING_PATH_RTOL = 1e-8


def damping_loads(fe, phi) -> np.ndarray:
    """Load shapes of the damping forces that the retained modes cannot carry.

    The damping forces of the retained modes ``C phi`` minus what the basis represents,
    ``M phi (phi^T C phi)``, vanish for proportional (Rayleigh, modal) damping; with discrete
    dashpots they span the dashpots' load paths.  Appending the static correction (2.21),
    (4.23) of these loads to the basis carries each damper's local flexibility, as the
    static correction of a D-strut's load path does in the thesis's hybrid models
    (5.2)-(5.4): without it a truncated model misplaces the antiresonances a damper shifts.

    Parameters
    ----------
    fe : FEModel
        The model (no ``C``: no loads).
    phi : ndarray, shape (N, n)
        Mass-normalised retained modes.

    Returns
    -------
    ndarray, shape (N, r)
        Orthonormal load shapes, ``r`` at most the rank of the non-proportional damping.
    """
    if fe.C is None or phi.shape[1] == 0:
        return np.zeros((fe.N, 0))
    F = np.asarray(fe.C @ phi)
    R = F - np.asarray(fe.M @ phi) @ (phi.T @ F)
    U, sv, _ = np.linalg.svd(R, full_matrices=False)
    top = np.linalg.norm(F, 2)
    keep = sv > DAMPING_PATH_RTOL * max(top, 1e-300)
    return U[:, keep]


def _check_options(fe, n, damping, static, static_damping) -> np.ndarray:
    """Validated damping ratios (n,) and options of :func:`normal_mode_model`."""
    z = as_array(damping, "damping", ndim=(0, 1))
    if z.ndim == 0:
        z = np.full(n, float(z))
    if z.shape != (n,) or not np.all(np.isfinite(z)) or np.any(z < 0):
        raise ValueError(f"damping must be a non-negative ratio or an array of {n} ratios")
    if static not in (False, True, "modes", "E"):
        raise ValueError(f"static must be False, True, 'modes' or 'E', got {static!r}")
    if static_damping not in ("critical", "projected"):
        raise ValueError("static_damping must be 'critical' or 'projected', got "
                         f"{static_damping!r}")
    if static_damping == "projected" and fe.C is None:
        raise ValueError("static_damping='projected' needs a damping matrix C")
    return z


def _static_modes(fe, B, phi):
    """Principal static correction modes (2.21), (4.24) of ``B``, diagonalised on their
    stiffness: ``(V, wc2)``, none when nothing is left to correct."""
    Ps = fe.static_correction(B, phi)
    Ps = Ps - phi @ (phi.T @ np.asarray(fe.M @ Ps))    # exact M-orthogonality
    X = fe.static_response(B)
    ref = np.einsum("ij,ij->", X, np.asarray(fe.M @ X))
    if np.einsum("ij,ij->", Ps, np.asarray(fe.M @ Ps)) <= 1e-20 * ref:
        Ps = Ps[:, :0]          # nothing left to correct (e.g. all modes retained)
    return principal_static_basis(Ps, fe.M, fe.K)


def _damping(fe, phiT, Omega, n, gamma, static_damping):
    """``Gamma``: ``diag(gamma)`` on the modes without ``C``, the projection ``phi^T C phi``
    with it; appended static modes critically damped (2.20) unless projected."""
    nT = phiT.shape[1]
    if fe.C is None:
        Gamma = np.zeros((nT, nT))
        Gamma[:n, :n] = np.diag(gamma)
    else:
        Gamma = phiT.T @ np.asarray(fe.C @ phiT)
        Gamma = 0.5 * (Gamma + Gamma.T)
    if nT > n and static_damping == "critical":
        wc = np.sqrt(np.clip(np.diag(Omega)[n:], 0, None))
        Gamma[n:, n:] = np.diag(2 * wc)                        # critical damping
    return Gamma


def full_frf(fe, f, B, Cm, quantity: str) -> np.ndarray:
    """Exact FRF array (nf, ns, na) ``c (K - w^2 M + j w C)^-1 b`` of the full model.

    Parameters
    ----------
    fe : FEModel
        The model (at most 4000 DOFs: batched dense solves, cost ``nf N^3``).
    f : ndarray, shape (nf,)
        Frequencies in Hz.
    B : ndarray, shape (N, na)
        Input shapes.
    Cm : ndarray, shape (ns, N)
        Output shapes.
    quantity : {"displacement", "velocity", "acceleration"}
        Response quantity.

    Returns
    -------
    ndarray, shape (nf, ns, na)
    """
    if fe.N > 4000:
        raise ValueError(f"frf is a dense reference solution; N={fe.N} is too large "
                         "(use normal_mode_model(...).frf)")
    dense = (lambda X: X.toarray()) if fe.sparse else np.asarray
    M, K = dense(fe.M), dense(fe.K)
    C = np.zeros_like(M) if fe.C is None else dense(fe.C)
    w = 2 * np.pi * f
    N = fe.N
    H = np.empty((f.size, Cm.shape[0], B.shape[1]), complex)
    chunk = max(1, int(1.5e7 // (N * N)))          # bound the memory of a batch
    with single_thread():                           # batched small solves: one BLAS thread
        _solve_lines(H, K, M, C, w, B, Cm, chunk)
    H = H * ((1j * w) ** QUANTITY_POWER[quantity])[:, None, None]
    check_finite_result(H, "the FRF", "freq")
    return H


def _solve_lines(H, K, M, C, w, B, Cm, chunk: int) -> None:
    """``H[l] = Cm (K - w_l^2 M + j w_l C)^-1 B``, batched over lines (in place)."""
    for i in range(0, w.size, chunk):               # batched over frequency lines
        ww = w[i:i + chunk, None, None]
        Z = K - ww**2 * M + 1j * ww * C
        try:
            X = np.linalg.solve(Z, np.broadcast_to(B.astype(complex),
                                                   (ww.shape[0],) + B.shape))
        except np.linalg.LinAlgError:
            raise ValueError("the dynamic stiffness K - w^2 M + j w C is singular or not "
                             "finite at some lines of freq: freq (Hz) is out of the range "
                             "double precision can solve for this model") from None
        H[i:i + chunk] = Cm @ X
