"""Design parameters as additive corrections of the FE matrices, eq. (4.15).

A parameter ``p`` changes the model to ``M + p dM``, ``C + p dC``, ``K + p dK``; ``p = 0``
is the nominal model.  The matrices are "normalised incremental matrices" (section
4.3.1): when ``dK`` is the stiffness of a group of elements, ``p = 1`` doubles that
stiffness and ``p = -0.5`` halves it; when ``dM`` is an added mass of 0.5 kg, ``p = 1``
adds 0.5 kg.  :class:`Parameter` lives with the FE models (so that
:meth:`~sdctrl.FEModel.stiffness_parameter` and :meth:`~sdctrl.FEModel.mass_parameter`
can build one from a model's own elements and nodes); chapter IV's update and
identifiability studies (:mod:`sdctrl.updating`) use it.

:func:`load_shapes` gives the low-rank factorisation of a parameter's matrices, the load
shapes ``F_U`` of its static correction modes (4.22)-(4.23).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from sdctrl._lib.validate import check_scalar
from sdctrl.fe._fe_checks import check_matrix

__all__ = ["Parameter", "load_shapes"]

#: default bounds of a parameter: from -90% to +900% of the normalised change
DEFAULT_BOUNDS = (-0.9, 9.0)


@dataclass(frozen=True, eq=False)
class Parameter:
    """An additive correction of the FE matrices (4.15): ``M + p dM``, ``C + p dC``, ``K + p dK``.

    Parameters
    ----------
    name : str
        Unique name (the key of :attr:`UpdateResult.values`).
    dM : array_like or scipy.sparse matrix, shape (N, N), optional
        Mass change for ``p = 1`` (symmetric).
    dK : array_like or scipy.sparse matrix, shape (N, N), optional
        Stiffness change for ``p = 1`` (symmetric).
    dC : array_like or scipy.sparse matrix, shape (N, N), optional
        Viscous damping change for ``p = 1`` (symmetric).
    bounds : (float, float)
        Range ``lo <= p <= hi`` the update respects; it must contain 0 (the nominal
        model).  The default ``(-0.9, 9.0)`` keeps a group's own matrix positive
        (``1 + p >= 0.1``).  Infinite bounds are allowed.
    scale : float, optional
        Size (positive) of the parameter's standard change (Table 4.1): the change used by
        :func:`sdctrl.identifiability`, upwards (downwards when the upper bound is 0).
        Default ``1`` (the matrices at their own size: +100% of a group's stiffness, the
        given added mass), limited to the bounds.
    description : str
        Free text shown in reports (e.g. which elements or nodes); None means "".
    rayleigh : (float, float)
        ``(alpha, beta)``: the change carries the model's Rayleigh damping law, ``C`` gains
        ``p (alpha dM + beta dK)`` besides ``p dC`` wherever the model's own damping matrix
        is used (:func:`sdctrl.update` with ``damping=None``, the updated FE model); a
        modal damping model (a given ratio, ``"data"``) replaces that law and keeps ``dC``
        alone.  Default ``(0, 0)``; :meth:`FEModel.stiffness_parameter` and
        :meth:`FEModel.mass_parameter` set it from the model's assembly.

    Raises
    ------
    ValueError
        No matrix given, matrices not square, symmetric, finite or of one size, an empty
        name, bounds that are not ``lo < hi`` with ``lo <= 0 <= hi``, a ``scale`` that is
        not a positive finite number, ``rayleigh`` not two finite numbers >= 0.
    TypeError
        ``name`` or ``description`` is not a string, a matrix or ``scale`` not numeric.

    Examples
    --------
    >>> import numpy as np, sdctrl as sd
    >>> p = sd.Parameter("spring", dK=np.array([[1.0, -1.0], [-1.0, 1.0]]), bounds=(-0.5, 2))
    >>> p.N, p.bounds, p.standard_change
    (2, (-0.5, 2.0), 1.0)
    """

    name: str
    dM: np.ndarray | sp.csr_matrix | None = None
    dK: np.ndarray | sp.csr_matrix | None = None
    dC: np.ndarray | sp.csr_matrix | None = None
    bounds: tuple[float, float] = DEFAULT_BOUNDS
    scale: float | None = None
    description: str = field(default="")
    rayleigh: tuple[float, float] = (0.0, 0.0)

    def __post_init__(self):
        if not isinstance(self.name, str):
            raise TypeError(f"name must be a string, got {type(self.name).__name__}")
        if not self.name.strip():
            raise ValueError("name must be a non-empty string")
        sets = object.__setattr__
        N = None
        for key in ("dM", "dK", "dC"):
            X = getattr(self, key)
            if X is None:
                continue
            X = check_matrix(X, f"Parameter {self.name!r}: {key}")
            if N is not None and X.shape[0] != N:
                raise ValueError(f"Parameter {self.name!r}: {key} must have shape ({N}, {N}) "
                                 f"like the other matrices, got {X.shape}")
            N = X.shape[0]
            if not sp.issparse(X):
                X.setflags(write=False)
            sets(self, key, X)
        if N is None:
            raise ValueError(f"Parameter {self.name!r} needs at least one of dM, dK, dC")
        sets(self, "bounds", check_bounds(self.bounds, f"Parameter {self.name!r}: bounds"))
        sets(self, "scale", check_scalar(self.scale, f"Parameter {self.name!r}: scale",
                                         positive=True, optional=True))
        sets(self, "rayleigh", check_rayleigh(self.rayleigh, f"Parameter {self.name!r}: rayleigh"))
        if self.description is None:
            sets(self, "description", "")
        elif not isinstance(self.description, str):
            raise TypeError(f"Parameter {self.name!r}: description must be a string, got "
                            f"{type(self.description).__name__}")
        else:
            sets(self, "description", str(self.description))

    def __repr__(self) -> str:
        parts = [k for k in ("dM", "dC", "dK") if getattr(self, k) is not None]
        lo, hi = self.bounds
        return (f"Parameter({self.name!r}, {'+'.join(parts)}, N={self.N}, "
                f"bounds=({lo:g}, {hi:g}))")

    @property
    def N(self) -> int:
        """Number of DOFs of the matrices."""
        return next(X for X in (self.dM, self.dK, self.dC) if X is not None).shape[0]

    @property
    def standard_change(self) -> float:
        """The standard change of ``p`` (Table 4.1): ``scale``, or 1 limited to the bounds."""
        lo, hi = self.bounds
        if self.scale is not None:
            return self.scale if hi > 0 else -self.scale
        return min(1.0, hi) if hi > 0 else max(-1.0, lo)

    def matrices(self, law: bool = True) -> tuple:
        """``(dM, dC, dK)``, each None when absent; with ``law`` the damping change holds the
        Rayleigh law too, ``dC + alpha dM + beta dK`` (:attr:`rayleigh`).

        Parameters
        ----------
        law : bool
            Include the Rayleigh law (the model's own damping matrix is used); False: a
            modal damping model replaces it.

        Returns
        -------
        tuple
        """
        dC = self.dC
        if law:
            for c, X in zip(self.rayleigh, (self.dM, self.dK)):
                if c and X is not None:
                    dC = c * X if dC is None else dC + c * X
        return self.dM, dC, self.dK


def check_rayleigh(law, name: str = "rayleigh") -> tuple[float, float]:
    """Rayleigh coefficients ``(alpha, beta)`` as two finite floats >= 0 (``Parameter.rayleigh``,
    :func:`sdctrl.fe.assemble`)."""
    try:
        vals = tuple(float(v) for v in law)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be two numbers (alpha, beta), got {law!r}") from None
    if len(vals) != 2 or not all(math.isfinite(v) and v >= 0 for v in vals):
        raise ValueError(f"{name} must be two finite numbers >= 0 (alpha, beta), got {law!r}")
    return vals


def check_bounds(bounds, name: str = "bounds") -> tuple[float, float]:
    """Validated ``(lo, hi)`` with ``lo < hi`` and ``lo <= 0 <= hi`` (infinite allowed).

    Parameters
    ----------
    bounds : (float, float)
        The bounds.
    name : str
        Name in error messages.

    Returns
    -------
    (float, float)
    """
    try:
        lo, hi = (float(v) for v in bounds)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a pair (lo, hi) of numbers, got {bounds!r}") from None
    if math.isnan(lo) or math.isnan(hi) or not lo < hi:
        raise ValueError(f"{name} must satisfy lo < hi, got ({lo:g}, {hi:g})")
    if not lo <= 0 <= hi:
        raise ValueError(f"{name} must contain 0 (p = 0 is the nominal FE model), got "
                         f"({lo:g}, {hi:g})")
    return lo, hi


def load_shapes(X, rtol: float = 1e-8, max_dense: int = 3000) -> np.ndarray:
    """Low-rank factorisation ``X = F diag(sign) F^T`` of a symmetric change: the load shapes
    ``F_U`` (N, r) of its static correction modes (4.22)-(4.23).

    A modification ``dK`` acts on the structure as the load ``-dK q`` (4.22), which lies in
    the range of ``dK``: the columns of ``F`` span it.  The matrix is restricted to the DOFs it
    touches (localised changes touch few, section 4.3.3) and factorised there by a dense
    symmetric eigen-decomposition; eigenvalues below ``rtol`` times the largest are dropped.

    Parameters
    ----------
    X : ndarray or sparse matrix, shape (N, N)
        Symmetric matrix (e.g. a parameter's ``dK``).
    rtol : float
        Relative threshold on the eigenvalue magnitudes.
    max_dense : int
        Largest number of touched DOFs factorised densely; beyond it a ValueError asks for
        modal load shapes instead (see :func:`sdctrl.updating.reduced_basis`).

    Returns
    -------
    ndarray, shape (N, r)
        ``F = P V sqrt(|d|)`` (``P`` selects the touched DOFs), largest ``|d|`` first.
    """
    N = X.shape[0]
    if sp.issparse(X):
        Xc = sp.csr_matrix(X)
        Xc.eliminate_zeros()
        idx = np.unique(np.concatenate([Xc.indices, np.repeat(np.arange(N), np.diff(Xc.indptr))]))
        if idx.size > max_dense:
            raise ValueError(f"the change touches {idx.size} DOFs (> {max_dense}): too many "
                             "for a dense factorisation")
        sub = Xc[idx][:, idx].toarray()
    else:
        Xa = np.asarray(X, float)
        idx = np.flatnonzero(np.any(Xa != 0, axis=0) | np.any(Xa != 0, axis=1))
        if idx.size > max_dense:
            raise ValueError(f"the change touches {idx.size} DOFs (> {max_dense}): too many "
                             "for a dense factorisation")
        sub = Xa[np.ix_(idx, idx)]
    if idx.size == 0:
        return np.zeros((N, 0))
    d, V = np.linalg.eigh(0.5 * (sub + sub.T))
    order = np.argsort(np.abs(d))[::-1]
    d, V = d[order], V[:, order]
    keep = np.abs(d) > rtol * max(np.abs(d[0]), 1e-300)
    F = np.zeros((N, int(keep.sum())))
    F[idx] = V[:, keep] * np.sqrt(np.abs(d[keep]))
    return F
