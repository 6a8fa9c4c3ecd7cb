"""Finite element models: the :class:`FEModel` container, its validation and its doors.

``M q'' + C q' + K q = b u``, ``y = c q`` on ``N`` physical DOFs labelled
``"<node>.<x|y|z|rx|ry|rz>"``.  The thesis uses FE models through their normal
modes (2.15) completed by static correction modes (2.21)-(2.22), orthogonalised as
principal static modes (4.24) and, for hybrid models, through the DOF labels that
tie a test to the mesh.  The methods are thin doors into :mod:`sdctrl.fe._eigen` (normal
and rigid-body modes), :mod:`sdctrl.fe._static` (static solutions, 2.21, 4.23, 4.24) and
:mod:`sdctrl.fe._reduction` (normal-mode models, 2.15, 2.22).

Conventions: mass-normalised modes ``phi^T M phi = I``, ``phi^T K phi = diag(omega^2)``
with ``omega`` in rad/s; frequencies returned to users in Hz.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import scipy.sparse as sp

from sdctrl._lib.validate import as_array, check_freq, check_labels, check_quantity, check_scalar
from sdctrl.fe import _eigen as eigen
from sdctrl.fe import _reduction as reduction
from sdctrl.fe import _static as statics
from sdctrl.fe._eigen import RIGID_RTOL
from sdctrl.fe._groups import Assembly, ElementGroups
from sdctrl.fe._fe_checks import (
    check_elements,
    check_matrix,
    check_nodes,
    check_positive_definite,
    dof_indices,
    label_list,
    shapes_on_dofs,
)

__all__ = ["FEModel"]


# ----------------------------------------------------------------------------------------
# the model
# ----------------------------------------------------------------------------------------
class FEModel(ElementGroups):
    """Finite element model ``M q'' + C q' + K q = b u``, ``y = c q`` (thesis 2.1, 4.3).

    Parameters
    ----------
    M : array_like or scipy.sparse matrix, shape (N, N)
        Mass matrix, symmetric positive definite.
    K : array_like or scipy.sparse matrix, shape (N, N)
        Stiffness matrix, symmetric (positive semi-definite; singular for free structures).
    C : array_like or scipy.sparse matrix, shape (N, N), optional
        Viscous damping matrix, symmetric (any, e.g. discrete dashpots: non-proportional).
    dofs : sequence of str, optional
        DOF labels ``"<node>.<x|y|z|rx|ry|rz>"`` such as ``"N12.x"``; default
        ``"q0", "q1", ...``.
    nodes : mapping of str to (3,) coordinates, optional
        Node coordinates (m) by node name.
    elements : sequence of (str, str), optional
        Node-name pairs of the elements (bars, beams, springs) that diagnosis and
        placement studies scan.
    assembly : Assembly, optional
        Element groups and lumped masses, as :func:`~sdctrl.fe.assemble` records them:
        :meth:`stiffness_parameter`, :meth:`mass_parameter` and :meth:`member_matrices`
        rebuild matrices of element groups from it.  Models built from matrices have none.

    Raises
    ------
    ValueError
        Non-square or mismatched matrices, non-symmetric matrices (relative tolerance
        1e-8), a mass matrix that is not positive definite (checked here, at
        construction: one symmetric-mode sparse ``L D L^T`` of M, the cost of one sparse
        factorisation; diagonal M by its diagonal), NaN/inf, bad labels.

    Notes
    -----
    If any matrix is sparse, all three are stored as ``scipy.sparse.csr_matrix``;
    otherwise as read-only dense arrays.  The model is immutable: factorisations and
    computed modes are cached on it, keyed on the request only (``modes(n, method,
    sigma)`` always returns the result of that very request; rigid-body modes come from a
    fixed sequence of solves), so no result depends on the order of the calls.

    Examples
    --------
    >>> import numpy as np, sdctrl as sd
    >>> fe = sd.FEModel(np.eye(2), [[2.0, -1.0], [-1.0, 2.0]], dofs=["A.x", "B.x"])
    >>> f, phi = fe.modes(2)
    >>> np.round(f * 2 * np.pi, 6)
    array([1.      , 1.732051])
    """

    __slots__ = ("C", "K", "M", "_cache", "_index", "assembly", "dofs", "elements", "nodes")

    def __init__(self, M, K, C=None, dofs: Sequence[str] | None = None,
                 nodes: Mapping | None = None, elements: Sequence | None = None, *,
                 assembly: Assembly | None = None):
        Mv = check_matrix(M, "M")
        N = Mv.shape[0]
        Kv = check_matrix(K, "K", N)
        Cv = None if C is None else check_matrix(C, "C", N)
        check_positive_definite(Mv, "M")
        if any(sp.issparse(X) for X in (Mv, Kv, Cv) if X is not None):
            Mv, Kv = sp.csr_matrix(Mv), sp.csr_matrix(Kv)
            Cv = None if Cv is None else sp.csr_matrix(Cv)
        else:
            for X in (Mv, Kv, Cv):
                if X is not None:
                    X.setflags(write=False)
        labels = check_labels(dofs, N, "dofs", "q")
        node_map = check_nodes(nodes)
        elem = check_elements(elements, node_map)
        if assembly is not None and (not isinstance(assembly, Assembly) or assembly.N != N):
            raise ValueError(f"assembly must be the Assembly record of a model of N={N} DOFs")
        sets = object.__setattr__
        sets(self, "assembly", assembly)
        sets(self, "M", Mv)
        sets(self, "K", Kv)
        sets(self, "C", Cv)
        sets(self, "dofs", labels)
        sets(self, "nodes", node_map)
        sets(self, "elements", elem)
        sets(self, "_cache", {})
        sets(self, "_index", {lab: i for i, lab in enumerate(labels)})

    def __setattr__(self, name, value):
        raise AttributeError("FEModel is immutable; build a new one instead")

    def __repr__(self) -> str:
        kind = "sparse" if self.sparse else "dense"
        damp = "no C" if self.C is None else "with C"
        nn = "" if self.nodes is None else f", {len(self.nodes)} nodes"
        return f"FEModel({self.N} DOFs, {kind}, {damp}{nn})"

    # --- sizes ----------------------------------------------------------------------
    @property
    def N(self) -> int:
        """Number of DOFs."""
        return self.M.shape[0]

    @property
    def sparse(self) -> bool:
        """True when the matrices are stored as ``scipy.sparse``."""
        return sp.issparse(self.M)

    def dof_index(self, labels) -> np.ndarray:
        """Indices of DOF labels.

        Parameters
        ----------
        labels : str or sequence of str
            DOF labels such as ``"N12.x"``.

        Returns
        -------
        ndarray of int
        """
        return dof_indices(self.dofs, labels, "labels", self._index)

    # --- input / output shapes --------------------------------------------------------
    def point(self, dofs, direction=None) -> np.ndarray:
        """Point force / point sensor shapes.

        ``b = fe.point(...)`` is the input shape of unit point forces (N, k) and
        ``c = fe.point(...).T`` the output shape of point displacement sensors (k, N):
        a sensor and an actuator built from the same label are collocated (``c = b^T``).

        Parameters
        ----------
        dofs : str or sequence of str
            DOF labels (``"N12.x"``), or node names when ``direction`` is given.
        direction : array_like, shape (3,), optional
            Global direction of the force/measurement at each node (normalised); the
            node's translation DOFs are combined.  Constrained DOFs contribute nothing.

        Returns
        -------
        ndarray, shape (N, k)
        """
        items = label_list(dofs, "dofs")
        if not items:
            raise ValueError("dofs must name at least one DOF")
        B = np.zeros((self.N, len(items)))
        if direction is None:
            idx = dof_indices(self.dofs, items, "dofs", self._index,
                              "; node names need a direction")
            B[idx, np.arange(len(items))] = 1.0
            return B
        d = as_array(direction, "direction", shape=(3,))
        nd = np.linalg.norm(d)
        if nd == 0:
            raise ValueError("direction must be a non-zero vector")
        d = d / nd
        for j, node in enumerate(items):
            hit = False
            for comp, ax in zip(d, "xyz"):
                i = self._index.get(f"{node}.{ax}")
                if i is not None:
                    B[i, j] = comp
                    hit = hit or comp != 0
            if not hit:
                raise ValueError(f"dofs: node {node!r} has no free translation DOF along "
                                 f"direction {tuple(d)}")
        return B

    def strut(self, node_a: str, node_b: str) -> np.ndarray:
        """Relative axial input/output shape of a strut between two nodes (D-strut, 5.4).

        ``c q = e . (u_b - u_a)`` is the elongation along the unit vector ``e`` from
        ``node_a`` to ``node_b``; the dual input ``b = c^T`` applies the pair of equal and
        opposite axial forces of an active strut (positive pushes the nodes apart).

        Parameters
        ----------
        node_a, node_b : str
            Node names; both need coordinates in :attr:`nodes`.

        Returns
        -------
        ndarray, shape (N, 1)
            ``b``; use ``.T`` for the sensor ``c``.
        """
        rows, values = statics.strut_entries(self, node_a, node_b)
        B = np.zeros((self.N, 1))
        B[rows, 0] = values
        return B

    def _input(self, b, name: str = "b"):
        """(N, k) input array and labels (when built from DOF labels)."""
        return shapes_on_dofs(b, self.N, self.dofs, name, index=self._index)

    def _output(self, c, name: str = "c"):
        """(k, N) output array and labels."""
        return shapes_on_dofs(c, self.N, self.dofs, name, output=True, index=self._index)

    # --- eigen solutions (sdctrl.fe._eigen) ----------------------------------------------
    def _scale(self) -> tuple[float, float]:
        """(median, max) of positive ``diag K / diag M`` (rad/s)^2."""
        if "scale" not in self._cache:
            self._cache["scale"] = eigen.diagonal_scale(self.K, self.M)
        return self._cache["scale"]

    def _factor(self):
        """The one factorisation of a fixed sparse model (:func:`eigen.stiffness_factor`)."""
        if "factor" not in self._cache:
            self._cache["factor"] = eigen.stiffness_factor(self.K)
        return self._cache["factor"]

    def _rigid_threshold(self) -> float:
        return RIGID_RTOL * self._scale()[1]

    def _eigen(self, n: int, method: str = "auto", sigma: float | None = None):
        """Eigenvalues (rad/s)^2 and shapes of the lowest ``n`` modes, cached on the request
        (so a result never depends on the calls made before)."""
        method = eigen.check_request(n, self.N, method)
        sigma = check_scalar(sigma, "sigma", optional=True)
        key = ("modes", method, sigma, int(n))
        if key not in self._cache:
            fac = self._factor() if method == "sparse" and sigma is None else None
            self._cache[key] = eigen.eigensolve(self.K, self.M, int(n), method, sigma, fac)
        return self._cache[key]

    def modes(self, n: int, method: str = "auto", sigma: float | None = None):
        """Lowest ``n`` mass-normalised normal modes (rigid-body modes included).

        Parameters
        ----------
        n : int
            Number of modes, ``1 <= n <= N``.
        method : {"auto", "dense", "sparse"}
            ``"dense"``: ``scipy.linalg.eigh`` (subset of the generalised problem);
            ``"sparse"``: shift-invert ``scipy.sparse.linalg.eigsh`` followed by a
            Rayleigh-Ritz clean-up; ``"auto"``: dense up to :data:`DENSE_MAX` DOFs.
        sigma : float, optional
            Shift (rad/s)^2 of the sparse solver.  Default: 0 when ``K`` is positive
            definite (its one factorisation also gives statics), else (free structures)
            ``-1e-6 * median(diag K / diag M)``, so that ``K - sigma M`` is definite.

        Returns
        -------
        freq : ndarray, shape (n,)
            Natural frequencies in Hz (rigid-body modes give ~0; tiny negative
            round-off eigenvalues are clipped to 0).
        phi : ndarray, shape (N, n)
            Mass-normalised shapes, ``phi^T M phi = I``, sign fixed so that the largest
            entry of each shape is positive.
        """
        lam, phi = self._eigen(n, method, sigma)
        return np.sqrt(np.clip(lam, 0, None)) / (2 * np.pi), phi.copy()

    def rigid_modes(self) -> np.ndarray:
        """Mass-normalised rigid-body (zero-frequency) modes, shape (N, r); r = 0 if fixed.

        A mode is rigid when its eigenvalue is below :data:`RIGID_RTOL` times
        ``max(diag K / diag M)``.

        Returns
        -------
        ndarray, shape (N, r)
        """
        if "rigid" not in self._cache:                # none when K is positive definite
            self._cache["rigid"] = (
                np.zeros((self.N, 0)) if self._factor() is not None
                else eigen.rigid_modes(self._eigen, self.N, self._rigid_threshold()))
        return self._cache["rigid"].copy()

    # --- static solutions (sdctrl.fe._static) ---------------------------------------------
    def _static_solver(self):
        if "static_solver" not in self._cache:
            fac = self._factor()
            self._cache["static_solver"] = (
                fac.solve if fac is not None
                else statics.static_solver(self.K, self.M, self.rigid_modes()))
        return self._cache["static_solver"]

    def factorise(self) -> FEModel:
        """Build now the factorisation static solutions use (otherwise built on first use),
        so that threads solving at once share one instead of racing to build it.

        Returns
        -------
        FEModel
            This model (its cache filled; its numbers unchanged).
        """
        self._static_solver()
        return self

    def static_response(self, b) -> np.ndarray:
        """Static response ``K^-1 b`` (factorised once, sparse when the model is sparse).

        For a free structure (rigid-body modes ``R``) ``K`` is singular and the
        inertia-relief flexibility is used instead: the exact solution of
        ``[[K, M R], [R^T M, 0]] [x; l] = [b; 0]``, which is
        ``x = sum over flexible modes phi_j phi_j^T b / omega_j^2`` (the load is balanced
        by rigid-body inertia forces, and ``x`` is mass-orthogonal to ``R``).  No shift
        is involved, so the result is exact.

        Parameters
        ----------
        b : array_like, shape (N, k) or (N,), or DOF label(s)
            Load shapes.

        Returns
        -------
        ndarray, shape (N, k)
        """
        B, _ = self._input(b, "b")
        return np.asarray(self._static_solver()(B), float).reshape(self.N, -1)

    def static_correction(self, b, phi) -> np.ndarray:
        """Static correction modes, eq. (2.21): the static response less the retained modes'.

        ``phi_C = (K^-1 - sum_j phi_j phi_j^T / omega_j^2) b`` over the retained modes,
        computed with one sparse factorisation of ``K`` (never a dense ``K^-1``) as ``K^-1``
        of the load less the retained modes' part (no cancellation when a retained mode is
        soft).  Then ``c phi_C + sum_j c phi_j phi_j^T b / omega_j^2 = c K^-1 b`` to the
        accuracy of the retained modes.  For free
        structures ``K^-1`` is the inertia-relief flexibility of :meth:`static_response`
        and retained rigid-body modes (zero frequency) are skipped.

        Parameters
        ----------
        b : array_like, shape (N, k) or DOF label(s)
            Input shapes.
        phi : array_like, shape (N, m)
            Retained mass-normalised modes (e.g. from :meth:`modes`).

        Returns
        -------
        ndarray, shape (N, k)
            The correction shapes (mass- and stiffness-orthogonal to the retained modes).
        """
        B, _ = self._input(b, "b")
        return statics.static_correction(self, B, phi)

    def principal_static_modes(self, phi_s, rtol: float = 1e-8) -> np.ndarray:
        """Principal static modes of ``phi_s`` (mass-orthogonal SVD, eq. 4.24).

        Parameters
        ----------
        phi_s : array_like, shape (N, k)
            Static correction modes.
        rtol : float
            Directions with mass-orthogonal singular value below ``rtol`` times the
            largest are dropped.

        Returns
        -------
        ndarray, shape (N, k')
            Mass-orthonormal principal static modes, largest singular value first.
        """
        P = as_array(phi_s, "phi_s", ndim=(1, 2))
        if P.shape[0] != self.N:
            raise ValueError(f"phi_s must have shape (N={self.N}, k), got {P.shape}")
        return statics.principal_static_modes(P, self.M, check_scalar(rtol, "rtol",
                                                                      positive=True))

    # --- modal models (sdctrl.fe._reduction) ---------------------------------------------
    def normal_mode_model(self, b, c, n: int, damping=0.01, static=False, *,
                          static_damping: str = "critical",
                          sensors: Sequence[str] | None = None,
                          actuators: Sequence[str] | None = None, damping_paths=False):
        """Truncated normal-mode model (2.15), optionally with static correction modes.

        Parameters
        ----------
        b : array_like, shape (N, na), or DOF label(s)
            Input shapes; labels give point forces (:meth:`point`) and name the inputs.
        c : array_like, shape (ns, N), or DOF label(s), or None
            Output shapes (displacement sensors); labels give point sensors and name the
            outputs; None means the collocated ``c = b^T``.
        n : int
            Number of retained normal modes (lowest, rigid-body modes included).
        damping : float or array_like, shape (n,)
            Modal damping ratio(s) ``zeta_j``, giving ``Gamma = diag(2 zeta_j omega_j)``.
            Used only when the model has no ``C``; with ``C`` the full projected damping
            ``Gamma = phi^T C phi`` is used (non-proportional damping).
        static : bool or {"modes", "E"}
            ``True``/``"modes"``: append static correction modes (2.21) for the inputs,
            made mass-orthonormal as principal static modes (4.24) and diagonalised on
            their projected stiffness ``phi_C^T K phi_C``, with critical damping
            ``2 omega_c`` (2.20), in the augmented model (2.22); the static response
            ``c K^-1 b`` is then exact at ``s = 0``.  ``"E"``: the correction as the
            feedthrough ``E = c phi_C`` (2.18) instead.  False: plain truncation.
        static_damping : {"critical", "projected"}
            Damping of the appended static modes: ``"critical"`` (``2 omega_c``, 2.20; its
            phase lag is about ``2 omega / omega_c`` of the correction in the band) or
            ``"projected"`` (``phi_C^T C phi_C`` with the coupling terms, a Galerkin/Ritz
            reduction of the full damped model; needs ``C``).
        sensors : sequence of str, optional
            Output labels (default: the DOF labels when ``c`` is given as labels).
        actuators : sequence of str, optional
            Input labels (default: the DOF labels when ``b`` is given as labels).
        damping_paths : bool
            Also correct the dashpots' load paths (:func:`sdctrl.fe._reduction.damping_loads`).
        Returns
        -------
        NormalModeModel
            ``Omega`` (rad/s)^2, ``Gamma`` rad/s (full when ``C`` couples modes),
            ``cphi``, ``phib``, ``shapes`` (N, n + k) on :attr:`dofs`;
            ``n_static`` counts the appended correction modes.
        """
        B, alab = self._input(b, "b")
        if c is None:
            Cm, slab = B.T.copy(), alab
        else:
            Cm, slab = self._output(c, "c")
        return reduction.normal_mode_model(
            self, B, Cm, n, damping, static, static_damping=static_damping,
            sensors=slab if sensors is None else sensors,
            actuators=alab if actuators is None else actuators, damping_paths=damping_paths)

    # --- reference response ------------------------------------------------------------------
    def frf(self, freq, b, c=None, quantity: str = "displacement"):
        """Exact FRF ``c (K - w^2 M + j w C)^-1 b`` of the full model (reference solution).

        Batched dense solves of the dynamic stiffness ``K - w^2 M + j w C`` (cost
        ``n_freq N^3``): a reference for models of up to a few thousand DOFs.

        Parameters
        ----------
        freq : array_like
            Frequencies in Hz.
        b : array_like, shape (N, na), or DOF label(s)
            Input shapes.
        c : array_like, shape (ns, N), or DOF label(s), optional
            Output shapes; default ``b^T`` (collocated).
        quantity : {"displacement", "velocity", "acceleration"}
            Response quantity.

        Returns
        -------
        FRF
        """
        from sdctrl.data._frf import FRF

        f = check_freq(freq, "freq")
        q = check_quantity(quantity, "quantity")
        B, alab = self._input(b, "b")
        if c is None:
            Cm, slab = B.T.copy(), alab
        else:
            Cm, slab = self._output(c, "c")
        H = reduction.full_frf(self, f, B, Cm, q)
        return FRF(f, H, quantity=q, sensors=slab, actuators=alab)


def check_fe_model(fe, name: str = "fe") -> None:
    """Raise TypeError unless ``fe`` is an :class:`~sdctrl.fe.FEModel`.

    Parameters
    ----------
    fe : object
        The argument.
    name : str
        Its name in the error message.
    """
    if not isinstance(fe, FEModel):
        raise TypeError(f"{name} must be an FEModel, got {type(fe).__name__}")
