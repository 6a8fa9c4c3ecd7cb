"""Static solutions of FE models: flexibility, static correction modes (2.21), (4.23) and
principal static modes (4.24).

``K^-1 b`` is computed with one factorisation of ``K`` (sparse when the model is); for a
free structure (rigid-body modes ``R``) ``K`` is singular and the inertia-relief
flexibility is used instead: the exact solution of ``[[K, M R], [R^T M, 0]] [x; l] =
[b; 0]``.  The static correction modes remove the retained modes' static part,
``phi_C = (K^-1 - sum_j phi_j phi_j^T / omega_j^2) b`` (2.21), (4.23); the principal static
modes orthonormalise them by the mass-orthogonal SVD (4.24).  :func:`consistent_static_modes`
builds the same correction against an arbitrary set of shapes (expanded or hybrid shapes,
which are not modes of the FE model): the static response made mass-orthogonal to them.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from sdctrl._lib.validate import as_array
from sdctrl.fe._eigen import RIGID_RTOL, diagonal_scale

__all__ = ["consistent_static_modes", "principal_static_basis", "principal_static_modes",
           "static_correction", "static_mode_damping", "static_solver", "strut_entries",
           "with_static_blocks"]


def static_solver(K, M, R):
    """Solver ``rhs (N, k) -> K^-1 rhs`` (inertia relief when there are rigid modes).

    Parameters
    ----------
    K, M : ndarray or sparse matrix, shape (N, N)
        Stiffness and mass.
    R : ndarray, shape (N, r)
        Mass-normalised rigid-body modes (r = 0 for a fixed structure).

    Returns
    -------
    callable
        Factorised once; sparse when ``K`` is.
    """
    N, r = K.shape[0], R.shape[1]
    sparse = sp.issparse(K)
    if r == 0:
        if sparse:
            return spla.splu(K.tocsc()).solve
        try:
            fac = sla.cho_factor(np.asarray(K))
            return lambda rhs: sla.cho_solve(fac, rhs)
        except np.linalg.LinAlgError:
            fac = sla.lu_factor(np.asarray(K))
            return lambda rhs: sla.lu_solve(fac, rhs)
    # inertia relief: [[K, M R], [R^T M, 0]] [x; l] = [b; 0] gives
    # K x = (I - M R R^T) b and R^T M x = 0, i.e. x = sum_flexible phi phi^T b / w^2
    MR = np.asarray(M @ R)
    if sparse:
        A = sp.bmat([[K, sp.csr_matrix(MR)], [sp.csr_matrix(MR.T), None]]).tocsc()
        full = spla.splu(A).solve
    else:
        A = np.block([[np.asarray(K), MR], [MR.T, np.zeros((r, r))]])
        fac = sla.lu_factor(A)
        full = lambda rhs: sla.lu_solve(fac, rhs)

    def solve(rhs):
        rhs = np.vstack([rhs, np.zeros((r, rhs.shape[1]))])
        return full(rhs)[:N]
    return solve


def static_correction(fe, B: np.ndarray, phi) -> np.ndarray:
    """Static correction modes (2.21) of input shapes ``B`` for the retained modes ``phi``.

    ``K^-1 B - sum_j phi_j phi_j^T B / omega_j^2`` is computed as ``K^-1`` of the load less
    the retained modes' part, ``B - M phi phi^T B`` (the same, as ``K^-1 M phi_j = phi_j /
    omega_j^2``), then made mass-orthogonal to ``phi``: the difference of the two terms
    cancels where a retained mode is soft (a suspension mode dominates ``K^-1 B``) and kept
    round-off of ``K^-1 B`` times ``omega_max^2 / omega_j^2`` (suspended truss, 6 static
    states: 1.4e-4 to 2.4e-3 relative, changing with the BLAS threads; now 1e-13).

    Parameters
    ----------
    fe : FEModel
        The model (its ``static_response`` gives ``K^-1 B``).
    B : ndarray, shape (N, k)
        Input shapes.
    phi : array_like, shape (N, m)
        Retained mass-normalised modes; rigid-body modes among them are skipped.

    Returns
    -------
    ndarray, shape (N, k)
    """
    P = as_array(phi, "phi", ndim=(1, 2))
    if P.ndim == 1:
        P = P[:, None]
    if P.shape[0] != fe.N:
        raise ValueError(f"phi must have shape (N={fe.N}, m), got {P.shape}")
    mu = np.einsum("ij,ij->j", P, np.asarray(fe.M @ P))
    if np.any(np.abs(mu - 1) > 1e-6):
        raise ValueError("phi must be mass-normalised (phi^T M phi = I), got diagonal "
                         f"entries in [{mu.min():.6g}, {mu.max():.6g}]")
    lam = np.einsum("ij,ij->j", P, np.asarray(fe.K @ P))
    flex = lam > RIGID_RTOL * diagonal_scale(fe.K, fe.M)[1]
    Pf = P[:, flex]
    MP = np.asarray(fe.M @ Pf)
    X = fe.static_response(B - MP @ (Pf.T @ B))
    return X - Pf @ (MP.T @ X)


def principal_static_modes(phi_s, M, rtol: float = 1e-8, atol: float = 0.0) -> np.ndarray:
    """Principal static modes by the mass-orthogonal SVD, eq. (4.24).

    The eigenvalues ``Sigma_s`` and eigenvectors ``Psi_s`` of ``phi_s^T M phi_s`` give
    ``phi_sp = phi_s Psi_s Sigma_s^{-1/2}``; only directions with
    ``Sigma_s > rtol * max(Sigma_s)`` are kept (largest first), which avoids the
    conditioning problems of a Schmidt orthogonalisation.

    Parameters
    ----------
    phi_s : array_like, shape (N, k)
        Static (correction) modes, e.g. from :meth:`FEModel.static_correction`.
    M : array_like or sparse matrix, shape (N, N)
        Mass matrix.
    rtol : float
        Relative threshold on the mass-orthogonal singular values.
    atol : float
        Absolute threshold on them as well (``Sigma_s > atol``): for vectors of unit mass
        norm, a direction that lost all but ``atol`` of its squared norm to a projection.

    Returns
    -------
    ndarray, shape (N, k')
        Mass-orthonormal basis (``phi_sp^T M phi_sp = I``) of the significant part of
        ``span(phi_s)``, ``k' <= k``.
    """
    P = np.asarray(phi_s, float)
    if P.ndim == 1:
        P = P[:, None]
    S = P.T @ (M @ P)
    S = 0.5 * (S + S.T)
    sig, psi = np.linalg.eigh(S)
    order = np.argsort(sig)[::-1]
    sig, psi = sig[order], psi[:, order]
    if sig.size == 0 or sig[0] <= atol or sig[0] <= 0:
        return np.zeros((P.shape[0], 0))
    keep = sig > max(rtol * sig[0], atol)
    return P @ (psi[:, keep] / np.sqrt(sig[keep]))


def principal_static_basis(phi_s, M, K):
    """Principal static modes (4.24) diagonalised on their projected stiffness.

    Parameters
    ----------
    phi_s : ndarray, shape (N, k)
        Static correction modes.
    M, K : ndarray or sparse matrix, shape (N, N)
        Mass and stiffness.

    Returns
    -------
    V : ndarray, shape (N, k')
        Mass-orthonormal modes with ``V^T K V = diag(wc2)``.
    wc2 : ndarray, shape (k',)
        Their eigenvalues (rad/s)^2, increasing.
    """
    V = principal_static_modes(phi_s, M)
    if not V.shape[1]:
        return V, np.zeros(0)
    Kc = V.T @ np.asarray(K @ V)
    wc2, Rc = np.linalg.eigh(0.5 * (Kc + Kc.T))
    return V @ Rc, wc2


def consistent_static_modes(fe, B: np.ndarray, shapes: np.ndarray, rtol: float = 1e-6, *,
                            response: np.ndarray | None = None):
    """Static correction modes of loads ``B`` consistent with given shapes (4.23)-(4.24).

    The thesis notes (5.1.2) that the FE static correction mode (2.21), built against the
    FE modes, does not fit a model whose shapes are expanded: the residual static
    response must be taken against the shapes actually kept.  Here the FE static response
    ``K^-1 B`` (4.23) is made mass-orthogonal to ``shapes``,
    ``psi = K^-1 B - S (S^T M S)^-1 S^T M K^-1 B``, so that the correction adds only what
    the shapes cannot represent, and orthonormalised by the mass-orthogonal SVD (4.24).
    Each correction mode's stiffness is its projection ``psi^T K psi`` (a Ritz value, the
    "projected stiffness" option of 2.22): it depends on the local FE stiffness around the
    load only, not on the FE modes the shapes replaced.

    Parameters
    ----------
    fe : FEModel
        Gives ``K^-1`` (inertia relief for free structures), ``M`` and ``K``.
    B : ndarray, shape (N, k)
        Load shapes (a strut, inputs, the range of a modification).
    shapes : ndarray, shape (N, n)
        Shapes already in the model (need not be FE modes); linearly independent.
    rtol : float
        Directions whose residual is below ``rtol`` times the static response (in the
        mass norm) are dropped: the shapes already hold them.
    response : ndarray, shape (N, k), optional
        ``K^-1 B`` when the caller has it already (:meth:`FEModel.static_response` of
        ``B``): one solve shared by several calls on the same loads (a hybrid model's
        construction and its folds, :func:`sdctrl.hybrid`); equal to round-off to the
        solve made here without it.

    Returns
    -------
    V : ndarray, shape (N, k')
        Mass-orthonormal correction modes, mass-orthogonal to ``shapes``, ``k' <= k``.
    wc2 : ndarray, shape (k',)
        Their ``omega^2`` (rad/s)^2 (``V^T K V`` diagonal), increasing.
    """
    M = fe.M
    X = fe.static_response(B) if response is None else np.asarray(response, float)
    if X.shape != (fe.N, np.shape(B)[1]):
        raise ValueError(f"response must have the shape (N, k) = {(fe.N, np.shape(B)[1])} "
                         f"of K^-1 B, got {X.shape}")
    S = np.asarray(shapes, float)
    if S.shape[1]:
        MS = np.asarray(M @ S)
        X_res = X - S @ np.linalg.solve(S.T @ MS, MS.T @ X)
    else:
        X_res = X
    nx = np.sqrt(np.clip(np.einsum("ij,ij->j", X, np.asarray(M @ X)), 0, None))
    nr = np.sqrt(np.clip(np.einsum("ij,ij->j", X_res, np.asarray(M @ X_res)), 0, None))
    keep = nr > rtol * np.maximum(nx, 1e-300)
    if not np.any(keep):
        return np.zeros((fe.N, 0)), np.zeros(0)
    V, wc2 = principal_static_basis(X_res[:, keep], M, fe.K)
    # principal directions below rtol of the largest are dropped by (4.24); directions
    # that are (numerically) in span(shapes) go too: they have no stiffness of their own
    good = wc2 > 0
    return V[:, good], wc2[good]


def with_static_blocks(Omega, Gamma, wc2, damping=None):
    """Modal stiffness and damping with static correction modes appended.

    The modes of :func:`consistent_static_modes` enter with their projected stiffness
    ``wc2``, uncoupled from the others (2.22), and with the FE model's own damping
    projected on them, ``V^T C V`` (the Ritz projection that gives their stiffness) when
    the FE model has a damping matrix, else critical damping ``2 sqrt(wc2)`` (2.20).
    Critical damping suits correction modes that only realise a residual term far above
    the band; a static mode inside a loop (a strut's, 5.4) carries the loop's load in the
    band, where a critically damped coordinate adds a damping path the structure does not
    have (a D-strut's added damping over-predicted).

    Parameters
    ----------
    Omega, Gamma : ndarray, shape (n, n)
        Modal stiffness and damping of the model.
    wc2 : ndarray, shape (k,)
        Squared frequencies (rad/s)^2 of the static correction modes.
    damping : ndarray, shape (k, k), optional
        Their damping block (:func:`static_mode_damping`); None: critical.

    Returns
    -------
    (ndarray, ndarray)
        ``Omega``, ``Gamma`` of shape (n + k, n + k).
    """
    n, k = Omega.shape[0], len(wc2)
    Om = np.zeros((n + k, n + k))
    Ga = np.zeros((n + k, n + k))
    Om[:n, :n], Ga[:n, :n] = Omega, Gamma
    Om[n:, n:] = np.diag(wc2)
    if damping is None:
        Ga[n:, n:] = np.diag(2.0 * np.sqrt(wc2))                         # critical (2.20)
    else:
        Ga[n:, n:] = damping
    return Om, Ga


def static_mode_damping(fe, V):
    """``V^T C V``: the FE model's damping projected on static correction modes ``V``
    (mass-normalised, N x k), or None when the FE model has no damping matrix.

    Returns
    -------
    ndarray, shape (k, k), or None
    """
    if fe.C is None or V.shape[1] == 0:
        return None
    D = V.T @ np.asarray(fe.C @ V)
    return 0.5 * (D + D.T)


def strut_entries(fe, node_a: str, node_b: str):
    """Nonzero entries of the strut shape :meth:`FEModel.strut` (D-strut, 5.4), compact.

    ``b = c^T`` has ``-e`` on ``node_a``'s translations and ``+e`` on ``node_b``'s, ``e``
    the unit vector from ``node_a`` to ``node_b``: at most six entries, whatever the size
    of the model (a placement study reads the shapes there only).

    Parameters
    ----------
    fe : FEModel
        The model (its ``nodes`` and DOF labels).
    node_a, node_b : str
        Node names; both need coordinates in ``fe.nodes``.

    Returns
    -------
    rows : ndarray of int
        DOF indices (those of the two nodes' free translations).
    values : ndarray
        ``b`` at these DOFs.

    Raises
    ------
    ValueError
        No node coordinates, an unknown node, coincident nodes, or no free translation DOF.
    """
    if fe.nodes is None:
        raise ValueError("strut needs node coordinates: build the FEModel with nodes=")
    for nm, node in (("node_a", node_a), ("node_b", node_b)):
        if str(node) not in fe.nodes:
            raise ValueError(f"{nm}: unknown node {node!r}")
    xa = np.asarray(fe.nodes[str(node_a)])
    xb = np.asarray(fe.nodes[str(node_b)])
    L = np.linalg.norm(xb - xa)
    if L == 0:
        raise ValueError("node_a and node_b must be at distinct positions")
    e = (xb - xa) / L
    rows, values = [], []
    for sign, node in ((-1.0, node_a), (1.0, node_b)):
        for comp, ax in zip(e, "xyz"):
            i = fe._index.get(f"{node}.{ax}")
            if i is not None:
                rows.append(i)
                values.append(sign * comp)
    values = np.asarray(values, float)
    if not np.any(values):
        raise ValueError("strut: neither node has a free translation DOF")
    return np.asarray(rows, int), values
