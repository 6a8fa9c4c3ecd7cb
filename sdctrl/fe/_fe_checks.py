"""Validation of FE matrices and of input/output shapes given as arrays or DOF labels.

Used by :class:`~sdctrl.fe.FEModel` at its public boundary and by the models whose shapes
live on FE DOFs (:mod:`sdctrl.hybrids._build`).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from types import MappingProxyType

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from sdctrl._lib.validate import as_array

__all__ = ["check_elements", "check_matrix", "check_nodes", "check_positive_definite",
           "dof_indices", "io_shapes", "label_list", "shapes_on_dofs"]

_SYM_RTOL = 1e-8


def check_matrix(X, name: str, n: int | None = None):
    """Validated copy of a square, real, finite, symmetric FE matrix.

    Parameters
    ----------
    X : array_like or sparse matrix, shape (n, n)
        The matrix.
    name : str
        Its name in error messages.
    n : int, optional
        Required size (that of ``M``).

    Returns
    -------
    ndarray or scipy.sparse.csr_matrix
        A copy (CSR with summed duplicates when sparse).
    """
    if X is None:
        raise TypeError(f"{name} must be a square matrix (numpy array or scipy.sparse), got None")
    if sp.issparse(X):
        if X.ndim != 2 or X.shape[0] != X.shape[1]:
            raise ValueError(f"{name} must be a square (n, n) matrix, got shape {X.shape}")
        if np.iscomplexobj(X.data) and np.any(X.data.imag != 0):
            raise TypeError(f"{name} must be real, got complex values")
        out = sp.csr_matrix(X, dtype=float, copy=True)
        out.sum_duplicates()
        if out.nnz and not np.all(np.isfinite(out.data)):
            raise ValueError(f"{name} must contain only finite values (no NaN or inf)")
    else:
        out = as_array(X, name, ndim=2)
        if out.shape[0] != out.shape[1]:
            raise ValueError(f"{name} must be a square (n, n) matrix, got shape {out.shape}")
    if n is not None and out.shape[0] != n:
        raise ValueError(f"{name} must have shape ({n}, {n}) like M, got {out.shape}")
    if out.shape[0] == 0:
        raise ValueError(f"{name} must have at least one DOF, got shape {out.shape}")
    scale = abs(out).max() if out.shape[0] else 0.0
    asym = abs(out - out.T).max()
    if asym > _SYM_RTOL * max(scale, 1e-300):
        raise ValueError(f"{name} must be symmetric (max |{name} - {name}^T| = {asym:.3g}, "
                         f"max |{name}| = {scale:.3g})")
    return out


def check_positive_definite(M, name: str = "M") -> None:
    """Raise ValueError unless ``M`` is positive definite (Cholesky / pivot test).

    Parameters
    ----------
    M : ndarray or sparse matrix, shape (N, N)
        Symmetric matrix.
    name : str
        Its name in error messages.
    """
    msg = f"{name} must be positive definite (every DOF needs mass or inertia)"
    if not sp.issparse(M):
        try:
            np.linalg.cholesky(M)
        except np.linalg.LinAlgError:
            raise ValueError(msg) from None
        return
    d = M.diagonal()
    if np.any(d <= 0):
        bad = int(np.argmin(d))
        raise ValueError(f"{msg}; diagonal entry {bad} is {d[bad]:g}")
    if M.nnz == np.count_nonzero(d):          # diagonal (lumped) mass
        return
    # symmetric-mode sparse LU without row pivoting is an LDL^T factorisation: M is
    # positive definite iff every pivot is positive.
    try:
        lu = spla.splu(M.tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                       options={"SymmetricMode": True})
    except RuntimeError:
        raise ValueError(msg + " (singular)") from None
    if np.array_equal(lu.perm_r, lu.perm_c):
        if np.any(lu.U.diagonal() <= 0):
            raise ValueError(msg)
        return
    lam = spla.eigsh(M, k=1, which="SA", return_eigenvectors=False, tol=1e-8)  # rare path
    if lam[0] <= 0:
        raise ValueError(msg)


def io_shapes(x, N: int, point, name: str, output: bool = False):
    """Input shapes (N, k) or output shapes (k, N) and their labels.

    ``x`` is an array (dense or sparse; a 1-D array is one input/output) or DOF label(s),
    turned into point shapes by ``point(labels) -> (N, k)``; the labels are returned when
    given, else None.

    Parameters
    ----------
    x : array_like, sparse matrix, str or sequence of str
        The shapes, or DOF labels.
    N : int
        Number of DOFs.
    point : callable
        ``point(labels) -> (N, k)`` unit point shapes of DOF labels.
    name : str
        Name of ``x`` in error messages.
    output : bool
        Output shapes (k, N) instead of input shapes (N, k).

    Returns
    -------
    shapes : ndarray
        (N, k) or (k, N).
    labels : tuple of str or None
    """
    if isinstance(x, str) or (isinstance(x, Sequence) and x and
                              all(isinstance(v, str) for v in x)):
        labels = (x,) if isinstance(x, str) else tuple(str(v) for v in x)
        B = point(list(labels))
        return (B.T.copy() if output else B), labels
    if sp.issparse(x):
        x = x.toarray()
    A = as_array(x, name, ndim=(1, 2))
    if output:
        A = A[None, :] if A.ndim == 1 else A
        if A.shape[1] != N:
            raise ValueError(f"{name} must have shape (k, N={N}), got {A.shape}")
    else:
        A = A[:, None] if A.ndim == 1 else A
        if A.shape[0] != N:
            raise ValueError(f"{name} must have shape (N={N}, k), got {A.shape}")
    return A, None


def shapes_on_dofs(x, N: int, dofs, name: str, output: bool = False, index=None):
    """:func:`io_shapes` on a list of DOF labels: labels give unit point shapes.

    Parameters
    ----------
    x : array_like, sparse matrix, str or sequence of str
        The shapes, or labels among ``dofs``.
    N : int
        Number of DOFs.
    dofs : sequence of str or None
        DOF labels of the N rows (None: labels are refused).
    name : str
        Name of ``x`` in error messages.
    output : bool
        Output shapes (k, N) instead of input shapes (N, k).
    index : mapping, optional
        ``label -> row`` of ``dofs`` when already built.

    Returns
    -------
    shapes : ndarray
        (N, k) or (k, N).
    labels : tuple of str or None
    """
    return io_shapes(x, N, lambda labels: _dof_rows(dofs, labels, name, index), name, output)


def label_list(x, name: str) -> list[str]:
    """A DOF label or a sequence of DOF labels as a list of strings.

    Parameters
    ----------
    x : str or sequence of str
        The label(s).
    name : str
        Name of ``x`` in error messages.

    Returns
    -------
    list of str
    """
    if isinstance(x, str):
        return [str(x)]
    if x is None or isinstance(x, bytes | Mapping) or not isinstance(x, Iterable):
        raise TypeError(f"{name} must be a DOF label or a sequence of DOF labels, got "
                        f"{type(x).__name__}")
    labels = list(x)
    for v in labels:
        if not isinstance(v, str):
            raise TypeError(f"{name} must hold DOF label strings, got {v!r:.40}")
    return [str(v) for v in labels]


def dof_indices(dofs: Sequence[str] | None, labels, name: str,
                index: Mapping | None = None, hint: str = "") -> np.ndarray:
    """Indices in ``dofs`` of DOF label(s), the errors naming the argument ``name``.

    Parameters
    ----------
    dofs : sequence of str or None
        The DOF labels of a model (None: labels are refused).
    labels : str or sequence of str
        The labels to find.
    name : str
        Name of ``labels`` in error messages.
    index : mapping, optional
        ``label -> index`` of ``dofs`` when already built.
    hint : str
        Appended to the message about an unknown label.

    Returns
    -------
    ndarray of int
    """
    if dofs is None:
        raise ValueError(f"{name} given as DOF labels but the model has no dofs")
    labels = label_list(labels, name)
    index = {d: i for i, d in enumerate(dofs)} if index is None else index
    out = np.empty(len(labels), dtype=int)
    for j, lab in enumerate(labels):
        if lab not in index:
            raise ValueError(f"{name}: unknown DOF label {lab!r} (labels look like "
                             f"{dofs[0]!r}{hint})")
        out[j] = index[lab]
    return out


def _dof_rows(dofs: Sequence[str], labels, name: str, index=None) -> np.ndarray:
    """(N, k) point shapes of DOF labels on ``dofs``."""
    idx = dof_indices(dofs, labels, name, index)
    B = np.zeros((len(dofs), idx.size))
    B[idx, np.arange(idx.size)] = 1.0
    return B


def check_nodes(nodes) -> Mapping | None:
    """Node coordinates by name, checked: a read-only mapping name -> (x, y, z), or None.

    Parameters
    ----------
    nodes : mapping of str to array_like (3,) or None
        The argument ``nodes`` of :class:`~sdctrl.fe.FEModel`.

    Returns
    -------
    mapping or None
    """
    if nodes is None:
        return None
    if not isinstance(nodes, Mapping):
        raise TypeError(f"nodes must be a mapping name -> (x, y, z), got {type(nodes).__name__}")
    out = {}
    for name, xyz in nodes.items():
        v = as_array(xyz, f"nodes[{name!r}]", shape=(3,))
        out[str(name)] = tuple(float(t) for t in v)
    return MappingProxyType(out)


def check_elements(elements, nodes: Mapping | None) -> tuple | None:
    """Element node pairs, checked against the node table: a tuple of ``(a, b)`` or None.

    Parameters
    ----------
    elements : sequence of (str, str) or None
        The argument ``elements`` of :class:`~sdctrl.fe.FEModel`.
    nodes : mapping or None
        The checked node table (:func:`check_nodes`); pairs must name its nodes.

    Returns
    -------
    tuple of (str, str) or None
    """
    if elements is None:
        return None
    if isinstance(elements, str) or not isinstance(elements, Sequence | np.ndarray):
        raise TypeError("elements must be a sequence of (node_a, node_b) pairs")
    out = []
    for e in elements:
        if isinstance(e, str) or not isinstance(e, Sequence | np.ndarray) or len(e) != 2:
            raise ValueError(f"elements must contain node-name pairs, got {e!r}")
        a, b = str(e[0]), str(e[1])
        if nodes is not None and (a not in nodes or b not in nodes):
            raise ValueError(f"elements: pair {e!r} names a node missing from nodes")
        out.append((a, b))
    return tuple(out)
