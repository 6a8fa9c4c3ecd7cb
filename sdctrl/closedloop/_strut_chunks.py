"""Damper placement by chunks of candidates evaluated as arrays (thesis 5.1, 5.4).

The fast path of :func:`sdctrl.placement_study` on a reduced model that is its second-order
part only (2.15): each strut is a few entries (:func:`~sdctrl.fe._static.strut_entries`);
the static correction modes of a chunk's struts (4.23)-(4.24) come from one multi-column
solve with the FE model's factorisation; each closed loop (5.4) is formed as matrices and
all the chunk's poles come from one stacked eigenvalue call -- no model and no StateSpace
per candidate.  The results equal the general path's (a model's ``with_feedback`` and
:func:`sdctrl.rms`) to rounding.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["closed_matrices", "stacked_eigvals", "static_modes", "statics",
           "upper"]

#: relative residual below which a strut's static response is held by the shapes
#: (the default ``rtol`` of :func:`~sdctrl.fe._static.consistent_static_modes`)
STATIC_RTOL = 1e-6


@dataclass(frozen=True, eq=False)
class Statics:
    """What the struts' static correction modes read (4.23)-(4.24), computed once per study.

    ``fe`` gives ``K^-1`` (its cached factorisation), ``M`` and ``K``; ``sensor_c`` (ns, N)
    and ``actuator_b`` (N, na) place the hybrid model's sensors and inputs on its DOFs;
    ``MS = M shapes`` (N, n) and ``SMS = shapes^T M shapes`` (n, n) are the projection of
    :func:`~sdctrl.fe._static.consistent_static_modes`, formed once instead of per strut.
    """

    fe: object
    sensor_c: object
    actuator_b: np.ndarray
    MS: np.ndarray
    SMS: np.ndarray


def statics(model) -> Statics:
    """The once-per-study part of the struts' static correction modes."""
    M, S = model.fe.M, np.asarray(model.shapes, float)
    MS = np.asarray(M @ S)
    return Statics(model.fe, model.sensor_c, np.asarray(model.actuator_b, float), MS, S.T @ MS)


def static_modes(loop, struts) -> list:
    """Static correction mode of each strut of a chunk, all struts at once (4.23)-(4.24).

    For one load ``s`` :func:`~sdctrl.fe._static.consistent_static_modes` is
    ``x = K^-1 s`` made mass-orthogonal to the shapes, ``x_r = x - S (S^T M S)^-1 S^T M x``,
    kept when ``|x_r|_M > 1e-6 |x|_M``, normalised ``v = x_r / |x_r|_M`` with
    ``wc2 = v^T K v`` (a Ritz value).  Here the chunk's loads are one right-hand side:
    one multi-column solve with the FE model's factorisation and a few sparse products,
    and each strut keeps only what the reduced model reads: ``wc2``, ``c v`` (ns,),
    ``v^T b`` (na,), ``v^T s`` and ``v^T C v`` (NaN without a damping matrix).  ``None``
    for a strut whose static response the shapes already hold.
    """
    st = loop.static
    fe, S = st.fe, loop.shapes
    R = np.zeros((fe.N, len(struts)))
    for j, (rows, vals) in enumerate(struts):
        R[rows, j] = vals
    X = fe.static_response(R)
    Xr = X - S @ np.linalg.solve(st.SMS, st.MS.T @ X)
    nx = np.sqrt(np.clip(np.einsum("ij,ij->j", X, np.asarray(fe.M @ X)), 0, None))
    nr2 = np.einsum("ij,ij->j", Xr, np.asarray(fe.M @ Xr))
    nr = np.sqrt(np.clip(nr2, 0, None))
    with np.errstate(divide="ignore", invalid="ignore"):
        V = Xr / nr
    wc2 = np.einsum("ij,ij->j", V, np.asarray(fe.K @ V))
    cV = np.asarray(st.sensor_c @ V)
    Vb = V.T @ st.actuator_b
    cvv = (np.einsum("ij,ij->j", V, np.asarray(fe.C @ V)) if fe.C is not None
           else np.full(V.shape[1], np.nan))
    out = []
    for j, (rows, vals) in enumerate(struts):
        keep = nr[j] > STATIC_RTOL * max(nx[j], 1e-300) and nr2[j] > 0 and wc2[j] > 0
        out.append((wc2[j], cV[:, j], Vb[j], V[rows, j] @ vals, cvv[j]) if keep
                   else None)
    return out


def closed_matrices(loop, strut, ext):
    """``A, B, C`` (2.15) of the strut's closed loop (5.4) on a plain reduced model.

    ``p'' + (Gamma + kv pb pb^T) p' + (Omega + kp pb pb^T) p = phib u`` with
    ``pb = phi^T s`` read at the strut's DOFs, the strut's static correction mode ``ext``
    appended first (2.20), (2.22); ``C`` holds the chosen outputs only.  The same system as
    :meth:`NormalModeModel.with_feedback` in other coordinates (it re-diagonalises
    ``Omega``), so the poles and RMS are equal.
    """
    from sdctrl._lib.statespace import second_order
    from sdctrl.fe._static import with_static_blocks

    rows, vals = strut
    m = loop.reduced
    pb = loop.shapes[rows].T @ vals
    Omega, Gamma, cphi, phib = m.Omega, m.Gamma, m.cphi[loop.out_idx], m.phib
    if ext is not None:
        wc2, cv, vb, vs, cvv = ext
        Omega, Gamma = with_static_blocks(Omega, Gamma, np.array([wc2]),
                                          None if np.isnan(cvv) else np.array([[cvv]]))
        cphi = np.hstack([cphi, cv[loop.out_idx, None]])
        phib = np.vstack([phib, vb[None, :]])
        pb = np.append(pb, vs)
    P = np.outer(pb, pb)
    return second_order(Omega + loop.kp * P, Gamma + loop.kv * P, phib, cphi)[:3]


def stacked_eigvals(As) -> list:
    """Eigenvalues of each matrix, one LAPACK call per group of equal size."""
    out = [None] * len(As)
    for size in {A.shape[0] for A in As}:
        idx = [i for i, A in enumerate(As) if A.shape[0] == size]
        for i, lam in zip(idx, np.linalg.eigvals(np.stack([As[i] for i in idx]))):
            out[i] = lam
    return out


def upper(lam) -> np.ndarray:
    """Poles with Im >= 0 sorted by modulus, as :attr:`NormalModeModel.poles`."""
    scale = max(np.abs(lam).max(), 1.0)
    lam = lam[lam.imag >= -1e-12 * scale]
    return lam[np.argsort(np.abs(lam))]
