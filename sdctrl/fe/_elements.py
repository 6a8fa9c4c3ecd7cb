"""Element library: element matrices vectorised over the elements of a kind.

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
arrays; :mod:`sdctrl.fe._assembly` numbers the DOFs and scatters them into sparse matrices.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import scipy.sparse as sp

__all__ = ["DIRECTIONS", "DIR_INDEX", "assemble_coo", "bar_matrices", "beam_axes", "beam_matrices",
           "member_matrices"]


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
# scattering element matrices (the low-level pieces of assembly)
# ----------------------------------------------------------------------------------------
#: DOF direction suffixes, in the order used within a node
DIRECTIONS = ("x", "y", "z", "rx", "ry", "rz")
DIR_INDEX = {d: i for i, d in enumerate(DIRECTIONS)}


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


def member_matrices(kind, mp, sc, mat, sec, ori, xa, xb, lumped):
    """Element stiffness and mass (ne, nd, nd) of a group of bars or beams.

    Parameters
    ----------
    kind : {"bar", "beam"}
        Element kind.
    mp, sc : mapping
        Material and section properties.
    mat, sec : str
        Material and section names (error messages).
    ori : tuple of float or None
        Beam orientation vector.
    xa, xb : ndarray, shape (ne, 3)
        End node coordinates.
    lumped : bool
        Lumped mass for bars.

    Returns
    -------
    K, M : ndarray, shape (ne, nd, nd)
    """
    E = _get(mp, "E", f"material {mat!r}")
    rho = _get(mp, "rho", f"material {mat!r}")
    A = _get(sc, "A", f"section {sec!r}")
    if kind == "bar":
        return bar_matrices(xa, xb, E, A, rho, lumped=lumped)
    G = mp.get("G")
    if G is None:
        G = E / (2 * (1 + _get(mp, "nu", f"material {mat!r}", 0.3)))
    Iy = _get(sc, "Iy", f"section {sec!r}")
    Iz = _get(sc, "Iz", f"section {sec!r}")
    J = _get(sc, "J", f"section {sec!r}", Iy + Iz)
    Ip = _get(sc, "Ip", f"section {sec!r}", Iy + Iz)
    return beam_matrices(xa, xb, E, float(G), A, Iy, Iz, J, rho, ori, Ip)
