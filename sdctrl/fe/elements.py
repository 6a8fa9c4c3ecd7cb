"""Element library and vectorised sparse assembler.

Elements (all matrices in SI units, global axes):

- ``bar``: 3-D two-node bar (truss member), axial stiffness ``EA/L``, 6 translational
  DOFs, consistent (default) or lumped mass including the transverse translations so
  that rigid-body translations carry the right mass.
- ``beam``: 3-D Euler-Bernoulli beam, 12 DOFs (translations and rotations at both
  nodes), local axes ``x`` along the beam, ``y`` in the plane of ``x`` and an
  orientation vector, ``z = x ^ y``; consistent mass with torsional inertia.
- ``mass``: lumped mass on the translations of a node, optionally with rotary
  inertia ``(Jx, Jy, Jz)`` about global axes (creates the node's rotation DOFs).
- ``spring`` / ``dashpot``: stiffness / viscous damper between two DOFs, or between a
  DOF and the ground.

Element matrices are built for all the elements of a kind at once as ``(ne, nd, nd)``
arrays and scattered into a COO sparse matrix in one call (duplicates summed), so that
models of 10^5 DOFs assemble in seconds (see ``benchmarks/bench_fe.py``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import scipy.sparse as sp

__all__ = [
    "DIRECTIONS",
    "assemble",
    "assemble_coo",
    "bar_matrices",
    "beam_axes",
    "beam_matrices",
]

#: DOF direction suffixes, in the order used within a node
DIRECTIONS = ("x", "y", "z", "rx", "ry", "rz")
_DIR_INDEX = {d: i for i, d in enumerate(DIRECTIONS)}


# ----------------------------------------------------------------------------------------
# element matrices (vectorised over elements)
# ----------------------------------------------------------------------------------------
def _lengths(xa: np.ndarray, xb: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    d = np.asarray(xb, float) - np.asarray(xa, float)
    L = np.linalg.norm(d, axis=-1)
    if np.any(L <= 0):
        raise ValueError("elements must join two distinct node positions (zero length found)")
    return d / L[:, None], L


def bar_matrices(xa, xb, E, A, rho, lumped: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Stiffness and mass of 3-D bars in global axes, vectorised.

    Parameters
    ----------
    xa, xb : array_like, shape (ne, 3)
        End node coordinates (m).
    E : array_like, shape (ne,) or scalar
        Young's modulus (Pa).
    A : array_like, shape (ne,) or scalar
        Cross-section area (m^2).
    rho : array_like, shape (ne,) or scalar
        Density (kg/m^3).
    lumped : bool
        Lumped (``rho A L / 2`` per node) instead of consistent mass.

    Returns
    -------
    K, M : ndarray, shape (ne, 6, 6)
        DOF order ``[xa, ya, za, xb, yb, zb]``.
    """
    xa = np.atleast_2d(np.asarray(xa, float))
    xb = np.atleast_2d(np.asarray(xb, float))
    e, L = _lengths(xa, xb)
    ne = L.size
    E, A, rho = (np.broadcast_to(np.asarray(v, float), (ne,)) for v in (E, A, rho))
    ee = e[:, :, None] * e[:, None, :]                       # (ne, 3, 3)
    k = (E * A / L)[:, None, None] * ee
    K = np.empty((ne, 6, 6))
    K[:, :3, :3] = k
    K[:, 3:, 3:] = k
    K[:, :3, 3:] = -k
    K[:, 3:, :3] = -k
    m = rho * A * L
    eye = np.eye(3)
    M = np.zeros((ne, 6, 6))
    if lumped:
        M[:, :3, :3] = (m / 2)[:, None, None] * eye
        M[:, 3:, 3:] = (m / 2)[:, None, None] * eye
    else:
        M[:, :3, :3] = (m / 3)[:, None, None] * eye
        M[:, 3:, 3:] = (m / 3)[:, None, None] * eye
        M[:, :3, 3:] = (m / 6)[:, None, None] * eye
        M[:, 3:, :3] = (m / 6)[:, None, None] * eye
    return K, M


def beam_axes(xa, xb, orientation=None) -> np.ndarray:
    """Local axes of beams: rows ``x`` (along the beam), ``y``, ``z`` in global coordinates.

    Parameters
    ----------
    xa, xb : array_like, shape (ne, 3)
        End node coordinates.
    orientation : array_like, shape (3,) or (ne, 3), optional
        A vector in the local ``x-y`` plane (not parallel to the beam).  Default:
        local ``y = Z ^ x`` (horizontal) for beams more than 8 degrees from vertical,
        the projection of global ``Y`` for (near-)vertical beams.

    Returns
    -------
    ndarray, shape (ne, 3, 3)
        Rotation ``R`` with ``u_local = R u_global``.
    """
    xa = np.atleast_2d(np.asarray(xa, float))
    xb = np.atleast_2d(np.asarray(xb, float))
    ex, _ = _lengths(xa, xb)
    ne = ex.shape[0]
    if orientation is None:
        v = np.tile([0.0, 0.0, 1.0], (ne, 1))
        vert = np.abs(ex[:, 2]) > 0.99
        v[vert] = [0.0, 1.0, 0.0]
        # local y along Z x ex gives a horizontal y for non-vertical beams
        ey = np.cross(v, ex)
        ey[vert] = np.cross(ex[vert], np.cross(v[vert], ex[vert]))
    else:
        v = np.broadcast_to(np.asarray(orientation, float), (ne, 3))
        ey = v - np.sum(v * ex, axis=1)[:, None] * ex
    n = np.linalg.norm(ey, axis=1)
    if np.any(n < 1e-9 * np.linalg.norm(np.broadcast_to(v, (ne, 3)), axis=1)):
        raise ValueError("orientation must not be parallel to the beam axis")
    ey = ey / n[:, None]
    ez = np.cross(ex, ey)
    return np.stack([ex, ey, ez], axis=1)


def beam_matrices(xa, xb, E, G, A, Iy, Iz, J, rho, orientation=None,
                  Ip=None) -> tuple[np.ndarray, np.ndarray]:
    """Stiffness and consistent mass of 3-D Euler-Bernoulli beams in global axes.

    Parameters
    ----------
    xa, xb : array_like, shape (ne, 3)
        End node coordinates (m).
    E, G : array_like, shape (ne,) or scalar
        Young's and shear moduli (Pa).
    A : array_like
        Area (m^2).
    Iy, Iz : array_like
        Second moments of area about the local ``y`` and ``z`` axes (m^4): ``Iz``
        governs bending in the local ``x-y`` plane.
    J : array_like
        Torsion constant (m^4).
    rho : array_like
        Density (kg/m^3).
    orientation : array_like, optional
        Vector in the local ``x-y`` plane; see :func:`beam_axes`.
    Ip : array_like, optional
        Polar moment of area for the torsional inertia (default ``Iy + Iz``).

    Returns
    -------
    K, M : ndarray, shape (ne, 12, 12)
        DOF order ``[x, y, z, rx, ry, rz]`` of node a then node b, global axes.
    """
    xa = np.atleast_2d(np.asarray(xa, float))
    xb = np.atleast_2d(np.asarray(xb, float))
    R = beam_axes(xa, xb, orientation)
    L = np.linalg.norm(xb - xa, axis=1)
    ne = L.size
    E, G, A, Iy, Iz, J, rho = (np.broadcast_to(np.asarray(v, float), (ne,))
                               for v in (E, G, A, Iy, Iz, J, rho))
    Ip = Iy + Iz if Ip is None else np.broadcast_to(np.asarray(Ip, float), (ne,))
    K = np.zeros((ne, 12, 12))
    M = np.zeros((ne, 12, 12))
    L2, L3 = L**2, L**3

    def put(X, idx, coef, mats):
        ii = np.asarray(idx)
        X[:, ii[:, None], ii[None, :]] += coef[:, None, None] * mats

    one = np.ones(ne)
    bar = np.array([[1.0, -1.0], [-1.0, 1.0]])
    put(K, [0, 6], E * A / L, bar)
    put(K, [3, 9], G * J / L, bar)
    cm = np.array([[2.0, 1.0], [1.0, 2.0]]) / 6
    put(M, [0, 6], rho * A * L, cm)
    put(M, [3, 9], rho * Ip * L, cm)

    def bend_k(s):   # s = +1 for (v, rz), -1 for (w, ry)
        Ls = L * s
        k = np.empty((ne, 4, 4))
        rows = [[12 * one, 6 * Ls, -12 * one, 6 * Ls],
                [6 * Ls, 4 * L2, -6 * Ls, 2 * L2],
                [-12 * one, -6 * Ls, 12 * one, -6 * Ls],
                [6 * Ls, 2 * L2, -6 * Ls, 4 * L2]]
        for i in range(4):
            for j in range(4):
                k[:, i, j] = rows[i][j]
        return k

    def bend_m(s):
        Ls = L * s
        m = np.empty((ne, 4, 4))
        rows = [[156 * one, 22 * Ls, 54 * one, -13 * Ls],
                [22 * Ls, 4 * L2, 13 * Ls, -3 * L2],
                [54 * one, 13 * Ls, 156 * one, -22 * Ls],
                [-13 * Ls, -3 * L2, -22 * Ls, 4 * L2]]
        for i in range(4):
            for j in range(4):
                m[:, i, j] = rows[i][j]
        return m

    for idx, s, Ib in (([1, 5, 7, 11], 1.0, Iz), ([2, 4, 8, 10], -1.0, Iy)):
        ii = np.asarray(idx)
        K[:, ii[:, None], ii[None, :]] += (E * Ib / L3)[:, None, None] * bend_k(s)
        M[:, ii[:, None], ii[None, :]] += (rho * A * L / 420)[:, None, None] * bend_m(s)

    T = np.zeros((ne, 12, 12))
    for i in range(4):
        T[:, 3 * i:3 * i + 3, 3 * i:3 * i + 3] = R
    Kg = np.einsum("eji,ejk,ekl->eil", T, K, T, optimize=True)
    Mg = np.einsum("eji,ejk,ekl->eil", T, M, T, optimize=True)
    return Kg, Mg


# ----------------------------------------------------------------------------------------
# assembly
# ----------------------------------------------------------------------------------------
def assemble_coo(index, Ke, n: int) -> sp.csr_matrix:
    """Scatter element matrices into a sparse ``(n, n)`` matrix (duplicates summed).

    Parameters
    ----------
    index : array_like of int, shape (ne, nd)
        Global row/column of each element DOF; entries ``< 0`` (constrained DOFs)
        are dropped.
    Ke : array_like, shape (ne, nd, nd)
        Element matrices.
    n : int
        Number of global DOFs.

    Returns
    -------
    scipy.sparse.csr_matrix
    """
    index = np.asarray(index, dtype=np.int64)
    Ke = np.asarray(Ke, float)
    if index.size == 0:
        return sp.csr_matrix((n, n))
    nd = index.shape[1]
    rows = np.broadcast_to(index[:, :, None], (index.shape[0], nd, nd)).ravel()
    cols = np.broadcast_to(index[:, None, :], (index.shape[0], nd, nd)).ravel()
    data = Ke.ravel()
    keep = (rows >= 0) & (cols >= 0) & (data != 0)
    return sp.coo_matrix((data[keep], (rows[keep], cols[keep])), shape=(n, n)).tocsr()


def _get(props: Mapping, key: str, owner: str, default=None):
    if key in props:
        return float(props[key])
    if default is not None:
        return float(default)
    raise ValueError(f"{owner} must define {key!r}")


def assemble(nodes, elements, materials=None, sections=None, bc=None, *,
             rayleigh=None, lumped: bool = False, sparse: bool = True):
    """Assemble an :class:`~sdctrl.fe.FEModel` from nodes and element descriptions.

    Parameters
    ----------
    nodes : mapping of str to (3,) coordinates, or array_like (nn, 3)
        Node coordinates in metres; an array gets names ``"N1"``, ``"N2"``, ...
    elements : sequence of tuple
        One tuple per element:

        - ``("bar", node_a, node_b, material, section)``
        - ``("beam", node_a, node_b, material, section[, orientation])``
          (``orientation``: a vector of the local x-y plane, see :func:`beam_axes`)
        - ``("mass", node, m[, (Jx, Jy, Jz)])`` lumped mass (kg) and rotary inertia
          (kg m^2, global axes)
        - ``("spring", dof_a, dof_b, k)`` stiffness (N/m or N m/rad) between DOF labels
          such as ``"N3.x"``; ``dof_b=None`` grounds the spring
        - ``("dashpot", dof_a, dof_b, c)`` viscous damper (N s/m), same convention.
    materials : mapping of str to mapping, optional
        ``{"E": Pa, "rho": kg/m^3, "G": Pa or "nu": Poisson ratio}``.
    sections : mapping of str to mapping, optional
        ``{"A": m^2, "Iy": m^4, "Iz": m^4, "J": m^4[, "Ip": m^4]}`` (bars need ``A``).
    bc : sequence of str, optional
        Boundary conditions: node names (all the node's DOFs clamped) or DOF labels
        (``"N1.z"``) that are removed from the model.
    rayleigh : (float, float), optional
        Proportional damping ``C += alpha M + beta K``.
    lumped : bool
        Lumped mass for bars (beams always use the consistent mass).
    sparse : bool
        Return ``scipy.sparse`` matrices (default) or dense arrays.

    Returns
    -------
    FEModel
        With DOF labels ``"<node>.<x|y|z|rx|ry|rz>"`` (rotations only at nodes touched
        by a beam or a rotary inertia, or named by a spring/dashpot), node coordinates
        and the element node pairs (bars, beams, springs and dashpots between nodes).

    Examples
    --------
    >>> from sdctrl.fe import assemble
    >>> fe = assemble({"A": (0, 0, 0), "B": (1, 0, 0)},
    ...               [("bar", "A", "B", "al", "rod")],
    ...               {"al": {"E": 70e9, "rho": 2700}}, {"rod": {"A": 1e-4}}, bc=["A"])
    >>> fe.dofs
    ('B.x', 'B.y', 'B.z')
    """
    from sdctrl.fe.model import FEModel

    # ---- nodes
    if isinstance(nodes, Mapping):
        names = [str(k) for k in nodes]
        xyz = np.array([np.asarray(nodes[k], float) for k in nodes], float).reshape(-1, 3)
    else:
        xyz = np.asarray(nodes, float)
        if xyz.ndim != 2 or xyz.shape[1] != 3:
            raise ValueError(f"nodes must be a mapping name -> (x, y, z) or an (nn, 3) array, "
                             f"got shape {xyz.shape}")
        names = [f"N{i + 1}" for i in range(xyz.shape[0])]
    if not np.all(np.isfinite(xyz)):
        raise ValueError("nodes must have finite coordinates")
    nid = {n: i for i, n in enumerate(names)}
    if len(nid) != len(names):
        raise ValueError("nodes must have unique names")
    nn = len(names)
    materials = dict(materials or {})
    sections = dict(sections or {})
    if isinstance(elements, str | bytes) or not isinstance(elements, Sequence):
        raise TypeError("elements must be a sequence of element tuples")

    def node(name, what):
        try:
            return nid[str(name)]
        except KeyError:
            raise ValueError(f"elements: {what} refers to unknown node {name!r}") from None

    def dof(label, what):
        lab = str(label)
        nodename, _, d = lab.rpartition(".")
        if d not in _DIR_INDEX:
            raise ValueError(f"elements: {what} DOF label {lab!r} must look like "
                             f"'<node>.<{'|'.join(DIRECTIONS)}>'")
        return node(nodename, what), _DIR_INDEX[d]

    groups: dict[tuple, list] = {}
    masses, springs, dashpots = [], [], []
    used = np.zeros((nn, 6), bool)
    pairs = []
    for k, el in enumerate(elements):
        if not isinstance(el, tuple | list) or not el:
            raise TypeError(f"elements[{k}] must be a tuple, got {el!r}")
        kind = str(el[0]).lower()
        what = f"elements[{k}] ({kind})"
        if kind in ("bar", "beam"):
            if len(el) not in ((5,) if kind == "bar" else (5, 6)):
                raise ValueError(f"{what} must be ({kind!r}, node_a, node_b, material, section"
                                 + (", [orientation])" if kind == "beam" else ")"))
            a, b = node(el[1], what), node(el[2], what)
            if a == b:
                raise ValueError(f"{what} joins node {el[1]!r} to itself")
            mat, sec = el[3], el[4]
            if mat not in materials:
                raise ValueError(f"{what}: unknown material {mat!r}")
            if sec not in sections:
                raise ValueError(f"{what}: unknown section {sec!r}")
            ori = None
            if kind == "beam" and len(el) == 6 and el[5] is not None:
                ori = tuple(float(v) for v in el[5])
            groups.setdefault((kind, mat, sec, ori), []).append((a, b))
            used[[a, b], :3] = True
            if kind == "beam":
                used[[a, b], 3:] = True
            pairs.append((names[a], names[b]))
        elif kind == "mass":
            if len(el) not in (3, 4):
                raise ValueError(f"{what} must be ('mass', node, m[, (Jx, Jy, Jz)])")
            a = node(el[1], what)
            m = float(el[2])
            J = np.zeros(3) if len(el) == 3 or el[3] is None else np.asarray(el[3], float)
            if m < 0 or J.shape != (3,) or np.any(J < 0) or not np.all(np.isfinite(J)):
                raise ValueError(f"{what} must have a non-negative mass and 3 inertias")
            masses.append((a, m, J))
            used[a, :3] = True
            if np.any(J > 0):
                used[a, 3:] = True
        elif kind in ("spring", "dashpot"):
            if len(el) != 4:
                raise ValueError(f"{what} must be ({kind!r}, dof_a, dof_b or None, value)")
            a = dof(el[1], what)
            b = None if el[2] is None else dof(el[2], what)
            val = float(el[3])
            if not np.isfinite(val) or val < 0:
                raise ValueError(f"{what} must have a finite non-negative value, got {val}")
            (springs if kind == "spring" else dashpots).append((a, b, val))
            used[a] = True
            if b is not None:
                used[b] = True
                if b[0] != a[0]:
                    pairs.append((names[a[0]], names[b[0]]))
        else:
            raise ValueError(f"{what}: unknown element kind {kind!r} "
                             "(bar, beam, mass, spring, dashpot)")

    # ---- DOF numbering, boundary conditions
    fixed = np.zeros((nn, 6), bool)
    for item in bc or ():
        s = str(item)
        if s in nid:
            fixed[nid[s]] = True
        else:
            nodename, _, d = s.rpartition(".")
            if nodename not in nid or d not in _DIR_INDEX:
                raise ValueError(f"bc entries must be node names or DOF labels, got {s!r}")
            fixed[nid[nodename], _DIR_INDEX[d]] = True
    active = used & ~fixed
    gidx = -np.ones((nn, 6), np.int64)
    gidx[active] = np.arange(int(active.sum()))
    N = int(active.sum())
    if N == 0:
        raise ValueError("the model has no free DOF (check elements and bc)")
    ni, di = np.nonzero(active)
    dofs = [f"{names[i]}.{DIRECTIONS[d]}" for i, d in zip(ni, di)]

    Ks, Ms, _Cs = [], [], []
    for (kind, mat, sec, ori), conn in groups.items():
        conn = np.asarray(conn)
        mp, sc = materials[mat], sections[sec]
        E = _get(mp, "E", f"material {mat!r}")
        rho = _get(mp, "rho", f"material {mat!r}")
        A = _get(sc, "A", f"section {sec!r}")
        xa, xb = xyz[conn[:, 0]], xyz[conn[:, 1]]
        if kind == "bar":
            Ke, Me = bar_matrices(xa, xb, E, A, rho, lumped=lumped)
            idx = np.hstack([gidx[conn[:, 0], :3], gidx[conn[:, 1], :3]])
        else:
            G = mp.get("G")
            if G is None:
                G = E / (2 * (1 + _get(mp, "nu", f"material {mat!r}", 0.3)))
            Iy = _get(sc, "Iy", f"section {sec!r}")
            Iz = _get(sc, "Iz", f"section {sec!r}")
            J = _get(sc, "J", f"section {sec!r}", Iy + Iz)
            Ip = _get(sc, "Ip", f"section {sec!r}", Iy + Iz)
            Ke, Me = beam_matrices(xa, xb, E, float(G), A, Iy, Iz, J, rho, ori, Ip)
            idx = np.hstack([gidx[conn[:, 0]], gidx[conn[:, 1]]])
        Ks.append(assemble_coo(idx, Ke, N))
        Ms.append(assemble_coo(idx, Me, N))
    if masses:
        a = np.array([m[0] for m in masses])
        vals = np.array([[m[1]] * 3 + list(m[2]) for m in masses])
        idx = gidx[a]
        ok = idx >= 0
        Ms.append(sp.coo_matrix((vals[ok], (idx[ok], idx[ok])), shape=(N, N)).tocsr())

    def discrete(items):
        if not items:
            return None
        ia = np.array([gidx[a] for a, _, _ in items])
        ib = np.array([gidx[b] if b is not None else -1 for _, b, _ in items])
        v = np.array([x for _, _, x in items])
        Ke = v[:, None, None] * np.array([[1.0, -1.0], [-1.0, 1.0]])
        return assemble_coo(np.stack([ia, ib], axis=1), Ke, N)

    Ksp = discrete(springs)
    if Ksp is not None:
        Ks.append(Ksp)
    K = sum(Ks[1:], Ks[0]) if Ks else sp.csr_matrix((N, N))
    M = sum(Ms[1:], Ms[0]) if Ms else sp.csr_matrix((N, N))
    C = discrete(dashpots)
    if rayleigh is not None:
        alpha, beta = (float(v) for v in rayleigh)
        Cr = alpha * M + beta * K
        C = Cr if C is None else C + Cr
    if not sparse:
        K, M = K.toarray(), M.toarray()
        C = None if C is None else C.toarray()
    else:
        K, M = K.tocsr(), M.tocsr()
        C = None if C is None else C.tocsr()
    node_xyz = {n: tuple(float(v) for v in xyz[i]) for i, n in enumerate(names)}
    # unique element node pairs, order kept
    seen, uniq = set(), []
    for p in pairs:
        if p not in seen:
            seen.add(p)
            uniq.append(p)
    return FEModel(M, K, C, dofs=dofs, nodes=node_xyz, elements=uniq)
