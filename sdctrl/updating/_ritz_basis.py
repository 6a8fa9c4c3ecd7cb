"""Ritz bases of reduced predictive models (thesis 4.3.3): normal modes augmented with
static correction modes of the modification loads (4.22)-(4.24).

A modification ``dM, dC, dK`` acts on the nominal structure as the load
``-dM q'' - dC q' - dK q`` (4.22).  The loads lie in the range of the modification matrices,
spanned by load shapes ``F_U`` (here the low-rank factorisation of each parameter matrix,
:func:`~sdctrl.fe._parameters.load_shapes`, or the modal loads ``dX phi`` of the retained
modes).  Their static responses, less what the retained vectors already represent,

``phi_s = (K^-1 - sum_j phi_j phi_j^T / omega_j^2) F_U`` (4.23),

are appended to the basis as principal static modes (4.24): the mass-orthogonal singular
value decomposition keeps the significant directions and avoids the conditioning trouble
of a Schmidt orthogonalisation.  ``K^-1`` comes from the model's one cached factorisation
(sparse for sparse models; inertia relief for free structures); no dense ``N x N`` matrix is
ever formed.

:meth:`ReducedBasis.loads` is the building block for scanning candidate modifications
(diagnosis): for a load shape ``b`` (N, k) (a spring or dashpot between two DOFs,
``dK = b k b^T``; a point mass) it returns the modal projection ``T^T b`` and the static
correction of ``b`` with respect to the whole basis, consistently with the basis (the
correction is ``K``-orthogonal to it); :meth:`ReducedBasis.augmented` appends that correction
as principal static modes.  Both cost one solve with the cached factorisation.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from sdctrl._lib.frozen import FrozenState
from sdctrl.fe._eigen import RIGID_RTOL, diagonal_scale
from sdctrl.fe._parameters import load_shapes
from sdctrl.fe._static import principal_static_modes
from sdctrl.fe._fe_checks import shapes_on_dofs
from sdctrl.fe._fe_model import check_fe_model

__all__ = ["ReducedBasis", "reduced_basis"]

#: principal static modes (4.24) below this relative mass-orthogonal singular value are dropped
STATIC_RTOL = 1e-6
#: parameters touching more DOFs than this use modal load shapes ``dX phi`` (see reduced_basis)
RANGE_MAX = 600
#: a static correction smaller than this fraction of its static response is round-off (the
#: basis already represents that response: all the modes of a small model are retained)
STATIC_ROUNDOFF = 1e-9
#: a new direction keeping less than this fraction of its squared mass norm once the basis's
#: part is removed lies in the basis (round-off of an already complete basis)
NEW_DIRECTION = 1e-8


def _bordered(A, B, D):
    """Symmetric ``[[A, B], [B^T, D]]``."""
    n, k = B.shape
    out = np.empty((n + k, n + k))
    out[:n, :n] = A
    out[:n, n:] = B
    out[n:, :n] = B.T
    out[n:, n:] = 0.5 * (D + D.T)
    return out


def _project(T, X):
    """``T^T X T`` (symmetrised) for a dense or sparse ``X``; a sparse change touching few
    DOFs costs ``O(nnz n + r n^2)`` for its ``r`` touched rows, not ``O(N n^2)``."""
    if sp.issparse(X):
        Xc = sp.csr_matrix(X)
        rows = np.flatnonzero(np.diff(Xc.indptr))
        R = T[rows].T @ np.asarray(Xc[rows] @ T)
    else:
        R = T.T @ np.asarray(X @ T)
    return 0.5 * (R + R.T)


@dataclass(frozen=True, eq=False)
class ReducedBasis(FrozenState):
    """Ritz basis ``T`` (N, n) of an FE model for reanalysis (4.17), mass-orthonormal.

    The first ``n_modes`` columns are normal modes of the model (rigid-body ones first when
    the structure is free), the others static correction modes (4.23)-(4.24).
    ``T^T M T = I`` up to round-off and ``Kr = T^T K T`` (diagonal on the modes).

    Parameters
    ----------
    fe : FEModel
        The model the basis reduces.
    T : ndarray, shape (N, n)
        The basis vectors.
    Kr : ndarray, shape (n, n)
        Projected stiffness ``T^T K T`` (rad/s)^2.
    Mr : ndarray, shape (n, n)
        Projected mass ``T^T M T`` (the identity up to round-off).
    n_modes : int
        Number of normal modes (the leading columns).
    n_rigid : int
        Number of rigid-body modes among them (zero frequency).
    info : dict
        Diagnostics nobody relies on.
    static_from : tuple of (str, int)
        What the static modes correct, in the order of the columns: ``(source, count)``
        per call of :meth:`augmented` (``"inputs"``, a parameter's name...).
    """

    fe: object
    T: np.ndarray
    Kr: np.ndarray
    Mr: np.ndarray
    n_modes: int
    n_rigid: int = 0
    info: dict = field(default_factory=dict, repr=False)
    static_from: tuple = ()

    def __post_init__(self):
        object.__setattr__(self, "static_from", tuple(self.static_from))
        for name in ("T", "Kr", "Mr"):
            a = np.array(getattr(self, name), float)
            a.setflags(write=False)
            object.__setattr__(self, name, a)

    def __repr__(self) -> str:
        return (f"ReducedBasis(N={self.N}, {self.n_modes} modes + {self.n_static} static "
                f"correction modes)")

    @property
    def n(self) -> int:
        """Number of basis vectors."""
        return self.T.shape[1]

    @property
    def N(self) -> int:
        """Number of physical DOFs."""
        return self.T.shape[0]

    @property
    def n_static(self) -> int:
        """Number of static correction modes."""
        return self.n - self.n_modes

    @property
    def frequency(self) -> np.ndarray:
        """Frequencies (Hz) of the normal modes of the basis."""
        lam = np.clip(np.diag(self.Kr)[:self.n_modes], 0, None)
        return np.sqrt(lam) / (2 * np.pi)

    def project(self, X) -> np.ndarray:
        """Reduced matrix ``T^T X T`` (4.17) of a change given on physical DOFs.

        Parameters
        ----------
        X : ndarray or sparse matrix, shape (N, N)
            Mass, damping or stiffness (change).

        Returns
        -------
        ndarray, shape (n, n)
            Symmetrised.
        """
        if X.shape != (self.N, self.N):
            raise ValueError(f"X must have shape ({self.N}, {self.N}), got {X.shape}")
        return _project(self.T, X)

    def static_correction(self, b) -> np.ndarray:
        """Static correction of load shapes with respect to the whole basis, (2.21)/(4.23).

        ``psi = K^-1 b - T_f Kf^-1 T_f^T b`` over the flexible vectors ``T_f`` of the basis
        (``Kf = T_f^T K T_f``): the static response less what the basis represents, so that
        ``psi`` is ``K``-orthogonal to the basis.  One solve with the model's cached
        factorisation (inertia relief for free structures).

        Parameters
        ----------
        b : array_like, shape (N, k) or (N,), or DOF label(s)
            Load shapes.

        Returns
        -------
        ndarray, shape (N, k)
        """
        B, _ = shapes_on_dofs(b, self.N, self.fe.dofs, "b")
        return self._correction(B)[0]

    def _correction(self, B):
        """``(psi, X)``: the static correction of ``B`` and its static response ``K^-1 B``."""
        X = self.fe.static_response(B)
        r = self.n_rigid
        Tf = self.T[:, r:]
        return X - Tf @ np.linalg.solve(self.Kr[r:, r:], Tf.T @ B), X

    def loads(self, b) -> tuple[np.ndarray, np.ndarray]:
        """Modal projection and static correction of load shapes, consistently with the basis.

        For a candidate modification ``dK = b k b^T`` (a spring or, with ``dC``, a dashpot
        between DOFs), ``dM = b m b^T`` (a point mass), the reduced change is
        ``(T^T b) k (T^T b)^T`` and the static correction ``psi`` completes the basis for
        it (:meth:`augmented`); a diagnosis scan evaluates many candidates this way.

        Parameters
        ----------
        b : array_like, shape (N, k) or (N,), or DOF label(s)
            Load shapes.

        Returns
        -------
        phib : ndarray, shape (n, k)
            ``T^T b``.
        psi : ndarray, shape (N, k)
            :meth:`static_correction` of ``b``.
        """
        B, _ = shapes_on_dofs(b, self.N, self.fe.dofs, "b")
        return self.T.T @ B, self.static_correction(B)

    def augmented(self, b, rtol: float = STATIC_RTOL, max_modes: int | None = None,
                  source: str = "loads") -> ReducedBasis:
        """Basis with the principal static correction modes (4.23)-(4.24) of ``b`` appended.

        Parameters
        ----------
        b : array_like, shape (N, k) or DOF label(s)
            Load shapes ``F_U``.
        rtol : float
            Principal directions with a mass-orthogonal singular value below ``rtol``
            times the largest are dropped (4.24).  Corrections that the basis already
            holds up to round-off are dropped too (:data:`STATIC_ROUNDOFF`,
            :data:`NEW_DIRECTION`), so the basis never exceeds ``N`` independent vectors.
        max_modes : int, optional
            Keep at most this many principal static modes (largest first).
        source : str
            Name recorded in :attr:`static_from`.

        Returns
        -------
        ReducedBasis
        """
        B, _ = shapes_on_dofs(b, self.N, self.fe.dofs, "b")
        psi, X = self._correction(B)
        return self._append(psi, X, rtol, max_modes, source)

    def _append(self, psi, X, rtol, max_modes, source) -> ReducedBasis:
        """Append the significant part of the corrections ``psi`` of static responses ``X``.

        A mass-weighted orthonormalisation against the basis with relative tolerances, so
        that the basis stays mass-orthonormal and never holds more than ``N`` independent
        vectors (the reduced mass ``T^T M T`` stays the identity):

        1. ``psi`` is made ``M``-orthogonal to ``T``; a column left with less than
           :data:`STATIC_ROUNDOFF` of the mass norm of its static response ``X`` is
           round-off, not a direction (the basis already represents that response: a small
           model with all its modes retained has nothing to correct);
        2. principal static modes (4.24): directions below ``rtol`` of the largest dropped;
        3. re-orthogonalisation against ``T`` (a second pass, as in Gram-Schmidt with
           reorthogonalisation); a principal direction of unit mass norm keeping less than
           :data:`NEW_DIRECTION` of its squared norm lies in ``span(T)`` and is dropped.
        """
        M, K = self.fe.M, self.fe.K
        T = self.T
        if T.shape[1] >= self.N or not psi.size:
            return self
        psi = psi - T @ (T.T @ np.asarray(M @ psi))          # exact M-orthogonality
        norms = np.sqrt(np.abs(np.einsum("ij,ij->j", psi, np.asarray(M @ psi))))
        xnorms = np.sqrt(np.abs(np.einsum("ij,ij->j", X, np.asarray(M @ X))))
        psi = psi[:, norms > STATIC_ROUNDOFF * xnorms]
        if not psi.shape[1]:
            return self
        V = principal_static_modes(psi, M, rtol)
        if max_modes is not None:
            V = V[:, :max(int(max_modes), 0)]
        V = V - T @ (T.T @ np.asarray(M @ V))                # clean-up after the SVD
        V = principal_static_modes(V, M, rtol, atol=NEW_DIRECTION)[:, :self.N - T.shape[1]]
        if not V.shape[1]:
            return self
        KV = np.asarray(K @ V)
        w2, R = np.linalg.eigh(0.5 * (V.T @ KV + (V.T @ KV).T))  # diagonal static block
        V, KV = V @ R, KV @ R
        MV = np.asarray(M @ V)
        Kr = _bordered(self.Kr, T.T @ KV, np.diag(w2))
        Mr = _bordered(self.Mr, T.T @ MV, V.T @ MV)        # only the new blocks: O(N n k)
        Tn = np.hstack([T, V])
        return ReducedBasis(self.fe, Tn, Kr, Mr, self.n_modes, self.n_rigid, dict(self.info),
                            self.static_from + ((source, V.shape[1]),))


def _normal_modes(fe, n_modes, fmax):
    """The lowest ``n_modes`` modes, or all modes up to ``fmax`` Hz (at least 1)."""
    if n_modes is not None:
        return fe.modes(int(n_modes))
    n = min(fe.N, 20)
    while True:
        f, phi = fe.modes(n)
        if f[-1] > fmax or n >= fe.N:
            break
        n = min(fe.N, 2 * n)
    keep = max(1, int(np.searchsorted(f, fmax, side="right")))
    return f[:keep], phi[:, :keep]


def _parameter_loads(basis, parameter, loads):
    """Load shapes ``F_U`` of one parameter: range of its matrices, or modal loads."""
    mats = [X for X in parameter.matrices() if X is not None]
    out = []
    for X in mats:
        if loads == "range":
            try:
                out.append(load_shapes(X, max_dense=RANGE_MAX))
                continue
            except ValueError:
                pass                        # distributed change: modal loads below
        phi = basis.T[:, :basis.n_modes]
        out.append(np.asarray(X @ phi))
    return np.hstack(out) if out else np.zeros((basis.N, 0))


def reduced_basis(fe, parameters=(), inputs=None, *, fmax: float | None = None,
                  n_modes: int | None = None, loads: str = "range",
                  rtol: float = STATIC_RTOL, max_static: int | None = None) -> ReducedBasis:
    """Reduced basis for reanalysis (4.17): normal modes plus static correction modes.

    Parameters
    ----------
    fe : FEModel
        The model.
    parameters : sequence of Parameter
        Modifications whose static correction modes (4.23) are appended, one principal
        set (4.24) per parameter.
    inputs : array_like, shape (N, k), or DOF label(s), optional
        Input shapes (e.g. the shakers) whose static correction modes (2.21) are appended,
        so that the reduced model also has the right static response to the inputs.
    fmax : float, optional
        Keep the normal modes up to this frequency (Hz).
    n_modes : int, optional
        Keep this many normal modes (instead of ``fmax``).
    loads : {"range", "modal"}
        Load shapes of the parameters: ``"range"`` the low-rank factorisation of their
        matrices (thesis 4.3.3; localised changes: at most ``RANGE_MAX`` touched DOFs,
        wider ones fall back to modal loads), ``"modal"`` the loads ``dX phi`` they
        apply in the retained modes (the static part of the modes' first-order change).
    rtol : float
        Relative threshold of the principal static modes (4.24).  Static corrections that
        the basis already represents up to round-off (e.g. a small model with all its
        modes retained) add no vector: the basis stays mass-orthonormal with at most ``N``
        vectors (see :meth:`ReducedBasis.augmented`).
    max_static : int, optional
        At most this many principal static modes per parameter.

    Returns
    -------
    ReducedBasis

    Examples
    --------
    >>> import sdctrl as sd
    >>> from sdctrl.updating import reduced_basis
    >>> fe = sd.testbed()
    >>> links = fe.stiffness_parameter("links", section=["post_AB", "post_C"])
    >>> basis = reduced_basis(fe, [links], fmax=150.0)
    >>> basis.n_modes, basis.n_static
    (24, 36)
    """
    check_fe_model(fe, "fe")
    if (fmax is None) == (n_modes is None):
        raise ValueError("give exactly one of fmax (Hz) and n_modes")
    if fmax is not None and not (np.isfinite(fmax) and fmax > 0):
        raise ValueError(f"fmax must be a positive frequency in Hz, got {fmax!r}")
    if loads not in ("range", "modal"):
        raise ValueError(f"loads must be 'range' or 'modal', got {loads!r}")
    _f, phi = _normal_modes(fe, n_modes, fmax)
    lam = np.einsum("ij,ij->j", phi, np.asarray(fe.K @ phi))
    rigid = int(np.sum(lam < RIGID_RTOL * diagonal_scale(fe.K, fe.M)[1]))
    basis = ReducedBasis(fe, phi, np.diag(lam), _project(phi, fe.M), phi.shape[1], rigid)
    if inputs is not None:
        B, _ = shapes_on_dofs(inputs, fe.N, fe.dofs, "inputs")
        basis = basis.augmented(B, rtol, source="inputs")
    for par in parameters:
        if par.N != fe.N:
            raise ValueError(f"parameters: {par.name!r} has N={par.N}, the model N={fe.N}")
        F = _parameter_loads(basis, par, loads)
        basis = basis.augmented(F, rtol, max_static, source=par.name)
    return basis

