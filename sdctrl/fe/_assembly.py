"""Assembly of an :class:`~sdctrl.fe.FEModel` from nodes and element descriptions.

In small steps, in the manner of scikit-fem:

1. parse and validate the nodes (:func:`_parse_nodes`) and the element tuples, one parser
   per element kind (:func:`_parse_elements`);
2. number the DOFs: a node carries the DOFs its elements use, less the boundary
   conditions, which are removed (:func:`_number_dofs`);
3. element matrices, one vectorised call per group of elements of one type, material,
   section and orientation, scattered into sparse matrices (:func:`_assemble_members`,
   :func:`assemble_coo`);
4. lumped masses and discrete springs/dashpots (:func:`_lumped_masses`, :func:`_discrete`);
5. damping: dashpots plus Rayleigh ``alpha M + beta K`` (:func:`_damping`).

Element matrices are built for all the elements of a kind at once as ``(ne, nd, nd)``
arrays and scattered into a COO sparse matrix in one call (duplicates summed), so that
models of 10^5 DOFs assemble in seconds (see ``benchmarks/bench_fe.py``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from sdctrl.fe._elements import DIRECTIONS, DIR_INDEX, assemble_coo, member_matrices
from sdctrl.fe._fe_model import FEModel
from sdctrl.fe._groups import Assembly
from sdctrl.fe._parameters import check_rayleigh

__all__ = ["assemble"]

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
          (``orientation``: a vector of the local x-y plane, see
          :func:`~sdctrl.fe.beam_axes`)
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
        Proportional damping ``C += alpha M + beta K`` (two finite numbers >= 0).  Recorded
        on ``fe.assembly``: :meth:`FEModel.stiffness_parameter` and
        :meth:`FEModel.mass_parameter` carry it along (``dC = beta dK``, ``alpha dM``), so
        that a model updated through them keeps the damping law it was assembled with.
    lumped : bool
        Lumped mass for bars (beams always use the consistent mass).
    sparse : bool
        Return ``scipy.sparse`` matrices (default) or dense arrays.

    Returns
    -------
    FEModel
        With DOF labels ``"<node>.<x|y|z|rx|ry|rz>"`` (rotations only at nodes touched
        by a beam or a rotary inertia, or named by a spring/dashpot), node coordinates
        and the element node pairs (bars, beams, springs and dashpots between nodes);
        ``fe.assembly`` keeps the element groups and lumped masses, from which
        :meth:`FEModel.stiffness_parameter` and :meth:`FEModel.mass_parameter` rebuild
        the matrices of any group of elements or nodes (chapter IV parameters, 4.15).

    Examples
    --------
    >>> from sdctrl.fe import assemble
    >>> fe = assemble({"A": (0, 0, 0), "B": (1, 0, 0)},
    ...               [("bar", "A", "B", "al", "rod")],
    ...               {"al": {"E": 70e9, "rho": 2700}}, {"rod": {"A": 1e-4}}, bc=["A"])
    >>> fe.dofs
    ('B.x', 'B.y', 'B.z')
    """

    rayleigh = None if rayleigh is None else check_rayleigh(rayleigh)
    names, xyz = _parse_nodes(nodes)
    materials = dict(materials or {})
    sections = dict(sections or {})
    els = _parse_elements(elements, names, materials, sections)
    gidx, dofs = _number_dofs(els.used, bc, names)
    N = len(dofs)
    Ks, Ms = _assemble_members(els.groups, xyz, gidx, N, materials, sections, lumped)
    if els.masses:
        Ms.append(_lumped_masses(els.masses, gidx, N))
    if els.springs:
        Ks.append(_discrete(els.springs, gidx, N))
    K = sum(Ks[1:], Ks[0]) if Ks else sp.csr_matrix((N, N))
    M = sum(Ms[1:], Ms[0]) if Ms else sp.csr_matrix((N, N))
    C = _damping(_discrete(els.dashpots, gidx, N) if els.dashpots else None, M, K, rayleigh)
    if not sparse:
        K, M = K.toarray(), M.toarray()
        C = None if C is None else C.toarray()
    else:
        K, M = K.tocsr(), M.tocsr()
        C = None if C is None else C.tocsr()
    node_xyz = {n: tuple(float(v) for v in xyz[i]) for i, n in enumerate(names)}
    pairs = list(dict.fromkeys(els.pairs))          # unique element node pairs, order kept
    record = Assembly.from_parsed(els, xyz, gidx, N, materials, sections, lumped,
                                  rayleigh)
    return FEModel(M, K, C, dofs=dofs, nodes=node_xyz, elements=pairs, assembly=record)


# ----------------------------------------------------------------------------------------
# 1. parsing and validation
# ----------------------------------------------------------------------------------------
def _parse_nodes(nodes):
    """Node names and coordinates (nn, 3) from a mapping or an array."""
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
    if len(set(names)) != len(names):
        raise ValueError("nodes must have unique names")
    return names, xyz


@dataclass(eq=False)
class _Elements:
    """Parsed elements: groups of members, lumped masses, discrete springs/dashpots."""

    names: list
    nid: dict
    groups: dict = field(default_factory=dict)      # (kind, mat, sec, ori) -> [(a, b)]
    masses: list = field(default_factory=list)      # (node, m, (Jx, Jy, Jz))
    springs: list = field(default_factory=list)     # ((node, dir), (node, dir) or None, k)
    dashpots: list = field(default_factory=list)
    used: np.ndarray = None                         # (nn, 6) DOFs touched by an element
    pairs: list = field(default_factory=list)       # element node-name pairs

    def node(self, name, what) -> int:
        try:
            return self.nid[str(name)]
        except KeyError:
            raise ValueError(f"elements: {what} refers to unknown node {name!r}") from None

    def dof(self, label, what) -> tuple[int, int]:
        lab = str(label)
        nodename, _, d = lab.rpartition(".")
        if d not in DIR_INDEX:
            raise ValueError(f"elements: {what} DOF label {lab!r} must look like "
                             f"'<node>.<{'|'.join(DIRECTIONS)}>'")
        return self.node(nodename, what), DIR_INDEX[d]


def _parse_elements(elements, names, materials, sections) -> _Elements:
    """Validate the element tuples and sort them by kind (one parser per kind)."""
    if isinstance(elements, str | bytes) or not isinstance(elements, Sequence):
        raise TypeError("elements must be a sequence of element tuples")
    els = _Elements(names, {n: i for i, n in enumerate(names)})
    els.used = np.zeros((len(names), 6), bool)
    for k, el in enumerate(elements):
        if not isinstance(el, tuple | list) or not el:
            raise TypeError(f"elements[{k}] must be a tuple, got {el!r}")
        kind = str(el[0]).lower()
        parser = _PARSERS.get(kind)
        if parser is None:
            raise ValueError(f"elements[{k}] ({kind}): unknown element kind {kind!r} "
                             "(bar, beam, mass, spring, dashpot)")
        parser(els, el, kind, f"elements[{k}] ({kind})", materials, sections)
    return els


def _parse_member(els, el, kind, what, materials, sections):
    """A bar or a beam between two nodes."""
    if len(el) not in ((5,) if kind == "bar" else (5, 6)):
        raise ValueError(f"{what} must be ({kind!r}, node_a, node_b, material, section"
                         + (", [orientation])" if kind == "beam" else ")"))
    a, b = els.node(el[1], what), els.node(el[2], what)
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
    els.groups.setdefault((kind, mat, sec, ori), []).append((a, b))
    els.used[[a, b], :3] = True
    if kind == "beam":
        els.used[[a, b], 3:] = True
    els.pairs.append((els.names[a], els.names[b]))


def _parse_mass(els, el, kind, what, materials, sections):
    """A lumped mass, optionally with rotary inertia, on a node."""
    if len(el) not in (3, 4):
        raise ValueError(f"{what} must be ('mass', node, m[, (Jx, Jy, Jz)])")
    a = els.node(el[1], what)
    m = float(el[2])
    J = np.zeros(3) if len(el) == 3 or el[3] is None else np.asarray(el[3], float)
    if m < 0 or J.shape != (3,) or np.any(J < 0) or not np.all(np.isfinite(J)):
        raise ValueError(f"{what} must have a non-negative mass and 3 inertias")
    els.masses.append((a, m, J))
    els.used[a, :3] = True
    if np.any(J > 0):
        els.used[a, 3:] = True


def _parse_discrete(els, el, kind, what, materials, sections):
    """A spring or a dashpot between two DOFs, or between a DOF and the ground."""
    if len(el) != 4:
        raise ValueError(f"{what} must be ({kind!r}, dof_a, dof_b or None, value)")
    a = els.dof(el[1], what)
    b = None if el[2] is None else els.dof(el[2], what)
    val = float(el[3])
    if not np.isfinite(val) or val < 0:
        raise ValueError(f"{what} must have a finite non-negative value, got {val}")
    (els.springs if kind == "spring" else els.dashpots).append((a, b, val))
    els.used[a] = True
    if b is not None:
        els.used[b] = True
        if b[0] != a[0]:
            els.pairs.append((els.names[a[0]], els.names[b[0]]))


_PARSERS = {"bar": _parse_member, "beam": _parse_member, "mass": _parse_mass,
            "spring": _parse_discrete, "dashpot": _parse_discrete}


# ----------------------------------------------------------------------------------------
# 2. DOF numbering and boundary conditions
# ----------------------------------------------------------------------------------------
def _number_dofs(used, bc, names):
    """Global index (nn, 6) of each node DOF (-1: absent or constrained) and DOF labels."""
    nid = {n: i for i, n in enumerate(names)}
    fixed = np.zeros(used.shape, bool)
    for item in bc or ():
        s = str(item)
        if s in nid:
            fixed[nid[s]] = True
        else:
            nodename, _, d = s.rpartition(".")
            if nodename not in nid or d not in DIR_INDEX:
                raise ValueError(f"bc entries must be node names or DOF labels, got {s!r}")
            fixed[nid[nodename], DIR_INDEX[d]] = True
    active = used & ~fixed
    N = int(active.sum())
    if N == 0:
        raise ValueError("the model has no free DOF (check elements and bc)")
    gidx = -np.ones(used.shape, np.int64)
    gidx[active] = np.arange(N)
    ni, di = np.nonzero(active)
    return gidx, [f"{names[i]}.{DIRECTIONS[d]}" for i, d in zip(ni, di)]


# ----------------------------------------------------------------------------------------
# 3.-5. element matrices, discrete elements, damping
# ----------------------------------------------------------------------------------------
def _assemble_members(groups, xyz, gidx, N, materials, sections, lumped):
    """Sparse stiffness and mass matrices of each group of members (lists, group order)."""
    Ks, Ms = [], []
    for (kind, mat, sec, ori), conn in groups.items():
        conn = np.asarray(conn)
        xa, xb = xyz[conn[:, 0]], xyz[conn[:, 1]]
        Ke, Me = member_matrices(kind, materials[mat], sections[sec], mat, sec, ori, xa, xb,
                                  lumped)
        nd = 3 if kind == "bar" else 6                   # translations, or all six DOFs
        idx = np.hstack([gidx[conn[:, 0], :nd], gidx[conn[:, 1], :nd]])
        Ks.append(assemble_coo(idx, Ke, N))
        Ms.append(assemble_coo(idx, Me, N))
    return Ks, Ms


def _lumped_masses(masses, gidx, N):
    """Diagonal mass matrix of the lumped masses and rotary inertias."""
    a = np.array([m[0] for m in masses])
    vals = np.array([[m[1]] * 3 + list(m[2]) for m in masses])
    idx = gidx[a]
    ok = idx >= 0
    return sp.coo_matrix((vals[ok], (idx[ok], idx[ok])), shape=(N, N)).tocsr()


def _discrete(items, gidx, N):
    """Matrix of springs or dashpots ``v [[1, -1], [-1, 1]]`` between two DOFs (or one)."""
    ia = np.array([gidx[a] for a, _, _ in items])
    ib = np.array([gidx[b] if b is not None else -1 for _, b, _ in items])
    v = np.array([x for _, _, x in items])
    Ke = v[:, None, None] * np.array([[1.0, -1.0], [-1.0, 1.0]])
    return assemble_coo(np.stack([ia, ib], axis=1), Ke, N)


def _damping(C, M, K, rayleigh):
    """Dashpots ``C`` (or None) plus Rayleigh damping ``alpha M + beta K``."""
    if rayleigh is None:
        return C
    alpha, beta = (float(v) for v in rayleigh)
    Cr = alpha * M + beta * K
    return Cr if C is None else C + Cr
