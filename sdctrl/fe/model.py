"""Finite element models: validation, normal modes, static correction modes, modal models.

``M q'' + C q' + K q = b u``, ``y = c q`` on ``N`` physical DOFs labelled
``"<node>.<x|y|z|rx|ry|rz>"``.  The thesis uses FE models through their normal
modes (2.15) completed by static correction modes (2.21)-(2.22), orthogonalised as
principal static modes (4.24) and, for hybrid models, through the DOF labels that
tie a test to the mesh.

Conventions: mass-normalised modes ``phi^T M phi = I``, ``phi^T K phi = diag(omega^2)``
with ``omega`` in rad/s; frequencies returned to users in Hz.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from types import MappingProxyType

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from sdctrl._validate import QUANTITY_POWER, as_array, check_freq, check_labels, check_quantity

__all__ = ["DENSE_MAX", "RIGID_RTOL", "FEModel", "principal_static_modes"]

#: eigenvalues below ``RIGID_RTOL * max(diag K / diag M)`` are rigid-body modes
RIGID_RTOL = 1e-12
#: ``modes(method="auto")`` uses the dense ``eigh`` up to this many DOFs
DENSE_MAX = 1200
_SYM_RTOL = 1e-8


# ----------------------------------------------------------------------------------------
# validation helpers
# ----------------------------------------------------------------------------------------
def _matrix(X, name: str, n: int | None = None):
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


def _check_pd(M, name: str = "M") -> None:
    """Raise ValueError unless ``M`` is positive definite (Cholesky / pivot test)."""
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
    """Input shapes (N, k) or output shapes (k, N) and their labels (internal).

    ``x`` is an array (dense or sparse; a 1-D array is one input/output) or DOF label(s),
    turned into point shapes by ``point(labels) -> (N, k)``; the labels are returned when
    given, else None.
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


def principal_static_modes(phi_s, M, rtol: float = 1e-8) -> np.ndarray:
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
    if sig.size == 0 or sig[0] <= 0:
        return np.zeros((P.shape[0], 0))
    keep = sig > rtol * sig[0]
    return P @ (psi[:, keep] / np.sqrt(sig[keep]))


# ----------------------------------------------------------------------------------------
# the model
# ----------------------------------------------------------------------------------------
class FEModel:
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

    Raises
    ------
    ValueError
        Non-square or mismatched matrices, non-symmetric matrices (relative tolerance
        1e-8), a mass matrix that is not positive definite, NaN/inf, bad labels.

    Notes
    -----
    If any matrix is sparse, all three are stored as ``scipy.sparse.csr_matrix``;
    otherwise as read-only dense arrays.  The model is immutable: factorisations and
    computed modes are cached on it.

    Examples
    --------
    >>> import numpy as np, sdctrl as sd
    >>> fe = sd.FEModel(np.eye(2), [[2.0, -1.0], [-1.0, 2.0]], dofs=["A.x", "B.x"])
    >>> f, phi = fe.modes(2)
    >>> np.round(f * 2 * np.pi, 6)
    array([1.      , 1.732051])
    """

    __slots__ = ("C", "K", "M", "_cache", "_index", "dofs", "elements", "nodes")

    def __init__(self, M, K, C=None, dofs: Sequence[str] | None = None,
                 nodes: Mapping | None = None, elements: Sequence | None = None):
        Mv = _matrix(M, "M")
        N = Mv.shape[0]
        Kv = _matrix(K, "K", N)
        Cv = None if C is None else _matrix(C, "C", N)
        _check_pd(Mv, "M")
        if any(sp.issparse(X) for X in (Mv, Kv, Cv) if X is not None):
            Mv, Kv = sp.csr_matrix(Mv), sp.csr_matrix(Kv)
            Cv = None if Cv is None else sp.csr_matrix(Cv)
        else:
            for X in (Mv, Kv, Cv):
                if X is not None:
                    X.setflags(write=False)
        labels = check_labels(dofs, N, "dofs", "q")
        node_map = None
        if nodes is not None:
            if not isinstance(nodes, Mapping):
                raise TypeError(f"nodes must be a mapping name -> (x, y, z), got "
                                f"{type(nodes).__name__}")
            node_map = {}
            for name, xyz in nodes.items():
                v = as_array(xyz, f"nodes[{name!r}]", shape=(3,))
                node_map[str(name)] = tuple(float(t) for t in v)
            node_map = MappingProxyType(node_map)
        elem = None
        if elements is not None:
            if isinstance(elements, str) or not isinstance(elements, Sequence | np.ndarray):
                raise TypeError("elements must be a sequence of (node_a, node_b) pairs")
            elem = []
            for e in elements:
                if isinstance(e, str) or len(e) != 2:
                    raise ValueError(f"elements must contain node-name pairs, got {e!r}")
                a, b = str(e[0]), str(e[1])
                if node_map is not None and (a not in node_map or b not in node_map):
                    raise ValueError(f"elements: pair {e!r} names a node missing from nodes")
                elem.append((a, b))
            elem = tuple(elem)
        sets = object.__setattr__
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
        if isinstance(labels, str):
            labels = [labels]
        out = []
        for lab in labels:
            if not isinstance(lab, str | np.str_):
                raise TypeError(f"labels must be DOF label strings, got {lab!r}")
            try:
                out.append(self._index[str(lab)])
            except KeyError:
                raise ValueError(f"unknown DOF label {lab!r} (labels look like "
                                 f"{self.dofs[0]!r})") from None
        return np.asarray(out, dtype=int)

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
        items = [dofs] if isinstance(dofs, str) else list(dofs)
        if not items:
            raise ValueError("dofs must name at least one DOF")
        B = np.zeros((self.N, len(items)))
        if direction is None:
            B[self.dof_index(items), np.arange(len(items))] = 1.0
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
        if self.nodes is None:
            raise ValueError("strut needs node coordinates: build the FEModel with nodes=")
        for nm, node in (("node_a", node_a), ("node_b", node_b)):
            if str(node) not in self.nodes:
                raise ValueError(f"{nm}: unknown node {node!r}")
        xa = np.asarray(self.nodes[str(node_a)])
        xb = np.asarray(self.nodes[str(node_b)])
        L = np.linalg.norm(xb - xa)
        if L == 0:
            raise ValueError("node_a and node_b must be at distinct positions")
        e = (xb - xa) / L
        B = np.zeros((self.N, 1))
        for sign, node in ((-1.0, node_a), (1.0, node_b)):
            for comp, ax in zip(e, "xyz"):
                i = self._index.get(f"{node}.{ax}")
                if i is not None:
                    B[i, 0] += sign * comp
        if not np.any(B):
            raise ValueError("strut: neither node has a free translation DOF")
        return B

    def _input(self, b, name: str = "b"):
        """(N, k) input array and labels (when built from DOF labels)."""
        return io_shapes(b, self.N, self.point, name)

    def _output(self, c, name: str = "c"):
        """(k, N) output array and labels."""
        return io_shapes(c, self.N, self.point, name, output=True)

    # --- eigen solutions ---------------------------------------------------------------
    def _scale(self) -> tuple[float, float]:
        """(median, max) of positive ``diag K / diag M`` (rad/s)^2."""
        if "scale" not in self._cache:
            r = np.asarray(self.K.diagonal(), float) / np.asarray(self.M.diagonal(), float)
            r = r[r > 0]
            self._cache["scale"] = (float(np.median(r)), float(r.max())) if r.size else (1.0, 1.0)
        return self._cache["scale"]

    def _rigid_threshold(self) -> float:
        return RIGID_RTOL * self._scale()[1]

    def _eig(self, n: int, method: str, sigma: float | None):
        N = self.N
        if method == "dense":
            K = self.K.toarray() if self.sparse else np.asarray(self.K)
            M = self.M.toarray() if self.sparse else np.asarray(self.M)
            lam, phi = sla.eigh(K, M, subset_by_index=[0, n - 1])
            # Rayleigh quotients: eigenvalues accurate to second order in the shapes
            # (eigh's small eigenvalues carry an error ~ eps * lambda_max)
            lam = np.einsum("ij,ij->j", phi, K @ phi) / np.einsum("ij,ij->j", phi, M @ phi)
        else:
            if n >= N - 1:
                raise ValueError(f"n must be < N - 1 = {N - 1} for the sparse eigensolver, "
                                 f"got {n}; use method='dense'")
            if sigma is None:
                sigma = -1e-6 * self._scale()[0]
            v0 = np.random.default_rng(0).standard_normal(N)
            K = self.K if self.sparse else sp.csr_matrix(self.K)
            M = self.M if self.sparse else sp.csr_matrix(self.M)
            lam, phi = spla.eigsh(K.tocsc(), k=n, M=M.tocsc(), sigma=float(sigma), which="LM",
                                  v0=v0, ncv=min(N, max(2 * n + 1, n + 20)))
            # Rayleigh-Ritz clean-up: exact M-orthonormality, accurate eigenvalues
            Kr = phi.T @ (K @ phi)
            Mr = phi.T @ (M @ phi)
            lam, V = sla.eigh(0.5 * (Kr + Kr.T), 0.5 * (Mr + Mr.T))
            phi = phi @ V
        order = np.argsort(lam)
        lam, phi = lam[order], phi[:, order]
        idx = np.argmax(np.abs(phi), axis=0)
        sgn = np.sign(phi[idx, np.arange(phi.shape[1])])
        sgn[sgn == 0] = 1.0
        return lam, phi * sgn

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
            Shift (rad/s)^2 of the sparse solver.  The default is negative,
            ``-1e-6 * median(diag K / diag M)``, so that ``K - sigma M`` is positive
            definite even for free structures (rigid-body modes at zero frequency).

        Returns
        -------
        freq : ndarray, shape (n,)
            Natural frequencies in Hz (rigid-body modes give ~0; tiny negative
            round-off eigenvalues are clipped to 0).
        phi : ndarray, shape (N, n)
            Mass-normalised shapes, ``phi^T M phi = I``, sign fixed so that the largest
            entry of each shape is positive.
        """
        if isinstance(n, bool) or not isinstance(n, int | np.integer):
            raise TypeError(f"n must be an integer number of modes, got {type(n).__name__}")
        if not 1 <= n <= self.N:
            raise ValueError(f"n must lie in [1, N={self.N}], got {n}")
        if method not in ("auto", "dense", "sparse"):
            raise ValueError(f"method must be 'auto', 'dense' or 'sparse', got {method!r}")
        if method == "auto":
            method = "dense" if (self.N <= DENSE_MAX or n >= self.N - 1) else "sparse"
        key = ("modes", method, None if sigma is None else float(sigma))
        cached = self._cache.get(key)
        if cached is None or cached[0].size < n:
            lam, phi = self._eig(int(n), method, sigma)
            self._cache[key] = (lam, phi)
        lam, phi = self._cache[key]
        self._cache["last_modes"] = (lam, phi)
        lam, phi = lam[:n], phi[:, :n]
        return np.sqrt(np.clip(lam, 0, None)) / (2 * np.pi), phi.copy()

    def rigid_modes(self) -> np.ndarray:
        """Mass-normalised rigid-body (zero-frequency) modes, shape (N, r); r = 0 if fixed.

        A mode is rigid when its eigenvalue is below :data:`RIGID_RTOL` times
        ``max(diag K / diag M)``.

        Returns
        -------
        ndarray, shape (N, r)
        """
        if "rigid" not in self._cache:
            thr = self._rigid_threshold()
            last = self._cache.get("last_modes")
            if last is None or (np.all(last[0] < thr) and last[0].size < self.N):
                k = min(self.N, 12)
                while True:
                    self.modes(k)
                    last = self._cache["last_modes"]
                    if not np.all(last[0] < thr) or k >= self.N:
                        break
                    k = min(self.N, 2 * k)
            lam, phi = last
            self._cache["rigid"] = phi[:, lam < thr].copy()
        return self._cache["rigid"].copy()

    # --- static solutions ------------------------------------------------------------------
    def _static_solver(self):
        if "static_solver" in self._cache:
            return self._cache["static_solver"]
        N = self.N
        R = self.rigid_modes()
        r = R.shape[1]
        if r == 0:
            if self.sparse:
                lu = spla.splu(self.K.tocsc())
                solve = lu.solve
            else:
                try:
                    fac = sla.cho_factor(np.asarray(self.K))
                    solve = lambda rhs: sla.cho_solve(fac, rhs)
                except np.linalg.LinAlgError:
                    fac = sla.lu_factor(np.asarray(self.K))
                    solve = lambda rhs: sla.lu_solve(fac, rhs)
        else:
            # inertia relief: [[K, M R], [R^T M, 0]] [x; l] = [b; 0] gives
            # K x = (I - M R R^T) b and R^T M x = 0, i.e. x = sum_flexible phi phi^T b / w^2
            MR = np.asarray(self.M @ R)
            if self.sparse:
                A = sp.bmat([[self.K, sp.csr_matrix(MR)], [sp.csr_matrix(MR.T), None]]).tocsc()
                lu = spla.splu(A)
                full = lu.solve
            else:
                A = np.block([[np.asarray(self.K), MR], [MR.T, np.zeros((r, r))]])
                fac = sla.lu_factor(A)
                full = lambda rhs: sla.lu_solve(fac, rhs)

            def solve(rhs):
                rhs = np.vstack([rhs, np.zeros((r, rhs.shape[1]))])
                return full(rhs)[:N]
        self._cache["static_solver"] = solve
        return solve

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
        computed with one sparse factorisation of ``K`` (never a dense ``K^-1``).  Then
        ``c phi_C + sum_j c phi_j phi_j^T b / omega_j^2 = c K^-1 b`` exactly.  For free
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
        P = as_array(phi, "phi", ndim=(1, 2))
        if P.ndim == 1:
            P = P[:, None]
        if P.shape[0] != self.N:
            raise ValueError(f"phi must have shape (N={self.N}, m), got {P.shape}")
        mu = np.einsum("ij,ij->j", P, np.asarray(self.M @ P))
        if np.any(np.abs(mu - 1) > 1e-6):
            raise ValueError("phi must be mass-normalised (phi^T M phi = I), got diagonal "
                             f"entries in [{mu.min():.6g}, {mu.max():.6g}]")
        X = self.static_response(B)
        lam = np.einsum("ij,ij->j", P, np.asarray(self.K @ P))
        flex = lam > self._rigid_threshold()
        Pf = P[:, flex]
        return X - Pf @ ((Pf.T @ B) / lam[flex][:, None])

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
        return principal_static_modes(P, self.M, rtol)

    # --- modal models ----------------------------------------------------------------------
    def normal_mode_model(self, b, c, n: int, damping=0.01, static=False, *,
                          static_damping: str = "critical",
                          sensors: Sequence[str] | None = None,
                          actuators: Sequence[str] | None = None):
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

        Returns
        -------
        NormalModeModel
            ``Omega`` (rad/s)^2, ``Gamma`` rad/s (full when ``C`` couples modes),
            ``cphi``, ``phib``, ``shapes`` (N, n + k) on :attr:`dofs`;
            ``info["n_static"]`` counts the appended correction modes.
        """
        from sdctrl.modal import NormalModeModel

        B, alab = self._input(b, "b")
        if c is None:
            Cm, slab = B.T.copy(), alab
        else:
            Cm, slab = self._output(c, "c")
        freq, phi = self.modes(n)
        n = phi.shape[1]
        lam = np.clip(np.einsum("ij,ij->j", phi, np.asarray(self.K @ phi)), 0, None)
        w = np.sqrt(lam)
        z = np.asarray(damping, float)
        if z.ndim == 0:
            z = np.full(n, float(z))
        if z.shape != (n,) or not np.all(np.isfinite(z)) or np.any(z < 0):
            raise ValueError(f"damping must be a non-negative ratio or an array of {n} ratios")
        if static not in (False, True, "modes", "E"):
            raise ValueError(f"static must be False, True, 'modes' or 'E', got {static!r}")
        if static_damping not in ("critical", "projected"):
            raise ValueError("static_damping must be 'critical' or 'projected', got "
                             f"{static_damping!r}")
        if static_damping == "projected" and self.C is None:
            raise ValueError("static_damping='projected' needs a damping matrix C")
        Omega = np.diag(lam)
        E = None
        phiT = phi
        info = {"source": "FEModel", "n_modes": n, "n_static": 0,
                "frequency_hz": freq.copy()}
        if static in (True, "modes"):
            Ps = self.static_correction(B, phi)
            Ps = Ps - phi @ (phi.T @ np.asarray(self.M @ Ps))    # exact M-orthogonality
            X = self.static_response(B)
            ref = np.einsum("ij,ij->", X, np.asarray(self.M @ X))
            if np.einsum("ij,ij->", Ps, np.asarray(self.M @ Ps)) <= 1e-20 * ref:
                Ps = Ps[:, :0]          # nothing left to correct (e.g. all modes retained)
            V = principal_static_modes(Ps, self.M)
            if V.shape[1]:
                Kc = V.T @ np.asarray(self.K @ V)
                wc2, Rc = np.linalg.eigh(0.5 * (Kc + Kc.T))
                V = V @ Rc
                phiT = np.hstack([phi, V])
                Omega = np.diag(np.concatenate([lam, wc2]))
                info["n_static"] = V.shape[1]
                info["static_frequency_hz"] = np.sqrt(np.clip(wc2, 0, None)) / (2 * np.pi)
        elif static == "E":
            E = Cm @ self.static_correction(B, phi)
        nT = phiT.shape[1]
        if self.C is None:
            Gamma = np.zeros((nT, nT))
            Gamma[:n, :n] = np.diag(2 * z * w)
        else:
            Gamma = phiT.T @ np.asarray(self.C @ phiT)
            Gamma = 0.5 * (Gamma + Gamma.T)
        if nT > n and static_damping == "critical":
            wc = np.sqrt(np.clip(np.diag(Omega)[n:], 0, None))
            Gamma[n:, n:] = np.diag(2 * wc)                        # critical damping
        if sensors is not None:
            slab = sensors
        if actuators is not None:
            alab = actuators
        return NormalModeModel(Omega, Gamma, Cm @ phiT, phiT.T @ B, E=E, sensors=slab,
                               actuators=alab, shapes=phiT, dofs=self.dofs, info=info)

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
        from sdctrl.frf import FRF

        f = check_freq(freq, "freq")
        q = check_quantity(quantity, "quantity")
        B, alab = self._input(b, "b")
        if c is None:
            Cm, slab = B.T.copy(), alab
        else:
            Cm, slab = self._output(c, "c")
        if self.N > 4000:
            raise ValueError(f"frf is a dense reference solution; N={self.N} is too large "
                             "(use normal_mode_model(...).frf)")
        dense = (lambda X: X.toarray()) if self.sparse else np.asarray
        M, K = dense(self.M), dense(self.K)
        C = np.zeros_like(M) if self.C is None else dense(self.C)
        w = 2 * np.pi * f
        N = self.N
        H = np.empty((f.size, Cm.shape[0], B.shape[1]), complex)
        chunk = max(1, int(1.5e7 // (N * N)))          # bound the memory of a batch
        for i in range(0, f.size, chunk):               # batched over frequency lines
            ww = w[i:i + chunk, None, None]
            Z = K - ww**2 * M + 1j * ww * C
            X = np.linalg.solve(Z, np.broadcast_to(B.astype(complex), (ww.shape[0],) + B.shape))
            H[i:i + chunk] = Cm @ X
        H = H * ((1j * w) ** QUANTITY_POWER[q])[:, None, None]
        return FRF(f, H, quantity=q, sensors=slab, actuators=alab)

