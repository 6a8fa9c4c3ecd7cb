"""Reanalysis on a reduced basis (thesis 4.3.3), eq. (4.17).

A modification ``dM, dC, dK`` of the structure, given on the physical DOFs of a model's
shapes ``phi_T``, is predicted by the projected (reduced) model (4.17)

``(I + dmu) p'' + (Gamma + dGamma) p' + (Omega + dOmega) p = phi_T^T b u``,
``dmu = phi_T^T dM phi_T``, ``dGamma = phi_T^T dC phi_T``, ``dOmega = phi_T^T dK phi_T``,

re-expressed on its own normal modes by the reduced eigenproblem
(:meth:`NormalModeModel.modified`).  The projection is exact when all the modes are kept,
and more accurate than first-order perturbation (4.19) for any truncated basis; static
correction modes (4.23)-(4.24) appended to the basis (``FEModel.normal_mode_model(...,
static=True)``) extend its validity to changes whose static response the modes miss.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from sdctrl._lib.validate import as_array

__all__ = ["modification_loads", "reanalysis", "reduced_change"]


def reduced_change(X, shapes: np.ndarray, name: str) -> np.ndarray | None:
    """Projection ``phi_T^T X phi_T`` of a physical change (4.17), symmetrised.

    Parameters
    ----------
    X : array_like or sparse matrix, shape (N, N), or None
        Change of mass, damping or stiffness on the DOFs of ``shapes``.
    shapes : ndarray, shape (N, n)
        The reduction basis ``phi_T``.
    name : str
        Name of ``X`` in error messages.

    Returns
    -------
    ndarray, shape (n, n), or None
        None when ``X`` is None.
    """
    if X is None:
        return None
    N = shapes.shape[0]
    if sp.issparse(X):
        if X.shape != (N, N):
            raise ValueError(f"{name} must have shape ({N}, {N}), got {X.shape}")
        data = X.tocsr().data
        if data.size and not np.all(np.isfinite(data)):
            raise ValueError(f"{name} must contain only finite values (no NaN or inf)")
        R = shapes.T @ np.asarray(X @ shapes)
    else:
        Xa = as_array(X, name, shape=(N, N))
        R = shapes.T @ Xa @ shapes
    return 0.5 * (R + R.T)


def reanalysis(model, dM=None, dC=None, dK=None):
    """Prediction of a modification given on physical DOFs by reanalysis, eq. (4.17).

    Parameters
    ----------
    model : NormalModeModel
        A model with ``shapes`` on physical DOFs (FE-derived or hybrid): the basis
        ``phi_T``.
    dM : array_like or sparse, shape (N, N), optional
        Mass modification on the DOFs of ``model.shapes``.
    dC : array_like or sparse, shape (N, N), optional
        Damping modification.
    dK : array_like or sparse, shape (N, N), optional
        Stiffness modification.

    Returns
    -------
    NormalModeModel
        Same class as ``model``, on the modified normal modes; ``transformation``
        maps the new modal coordinates to the old ones.

    Raises
    ------
    ValueError
        No shapes, wrong shapes, non-finite values, or ``I + dmu`` not positive definite.
    """
    if getattr(model, "shapes", None) is None:
        raise ValueError("model has no shapes on physical DOFs: reanalysis needs a hybrid or "
                         "FE-derived model (or use model.modified with modal changes)")
    S = model.shapes
    return model.modified(dmu=reduced_change(dM, S, "dM"), dGamma=reduced_change(dC, S, "dC"),
                          dOmega=reduced_change(dK, S, "dK"))


def modification_loads(dM=None, dC=None, dK=None, N: int | None = None,
                       rtol: float = 1e-9) -> np.ndarray:
    """Load shapes ``F_U`` spanning a modification, eq. (4.22).

    ``dM q'' + dC q' + dK q`` acts on the structure as loads in the range of the three
    matrices; an orthonormal basis of that range (eigenvectors of the non-zero blocks with
    eigenvalues above ``rtol`` of the largest) gives the inputs of the static correction
    (4.23).  Localised changes give few loads.

    Parameters
    ----------
    dM, dC, dK : array_like or sparse, shape (N, N), optional
        The modification (symmetric).
    N : int, optional
        Number of DOFs (checked against the matrices).
    rtol : float
        Relative threshold of the range.

    Returns
    -------
    ndarray, shape (N, k)
        Orthonormal load shapes (``k = 0`` for no modification).
    """
    cols = []
    for name, X in (("dM", dM), ("dC", dC), ("dK", dK)):
        if X is None:
            continue
        Xc = sp.csr_matrix(X) if sp.issparse(X) else sp.csr_matrix(as_array(X, name, ndim=2))
        if N is None:
            N = Xc.shape[0]
        if Xc.shape != (N, N):
            raise ValueError(f"{name} must have shape ({N}, {N}), got {Xc.shape}")
        if Xc.nnz and not np.all(np.isfinite(Xc.data)):
            raise ValueError(f"{name} must contain only finite values (no NaN or inf)")
        idx = np.unique(np.concatenate([Xc.indices, np.repeat(np.arange(N),
                                                              np.diff(Xc.indptr))]))
        if not idx.size:
            continue
        sub = Xc[idx][:, idx].toarray()
        ev, V = np.linalg.eigh(0.5 * (sub + sub.T))
        big = np.abs(ev) > rtol * max(np.abs(ev).max(), 1e-300)
        U = np.zeros((N, int(big.sum())))
        U[idx] = V[:, big]
        cols.append(U)
    if not cols:
        return np.zeros((N or 0, 0))
    U, s, _ = np.linalg.svd(np.hstack(cols), full_matrices=False)
    return U[:, s > 1e-8 * max(s.max(), 1e-300)] if s.size else U
