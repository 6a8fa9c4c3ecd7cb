"""Physical hypotheses a diagnosis scans on an FE model: where an effect could sit.

- **pairs** of nodes: every element of ``fe.elements`` and every pair of nodes that no element
  joins within ``reach`` (a dashpot or a spring need not sit on an existing bar).  The load
  shape is the axial relative shape of a strut between them (:meth:`FEModel.strut`, 5.4):
  ``added_damper`` (``dC = c b b^T``) and ``stiffness_change`` (``dK = dk b b^T``, along the
  element's axis);
- **nodes**: a lumped mass on the three translations, ``mass_change`` (``dM = dm I_3``);
- **DOFs**: a resonator (mass on a spring along one axis) attached to one translation DOF,
  the physical form of a ``missing_mode``;
- **members**: every beam element, its whole stiffness scaled (``dK = (dk / (EA/L)) K_e``: a
  loss of its modulus or section, bending included), ``stiffness_change`` with ``dk`` its
  change along the element's axis -- an axial strut alone barely sees a beam in bending.

Each candidate has a reference size from the model's in-band modes (the dashpot that adds 1%
damping to the most affected mode, the spring or mass that shifts its frequency by 1%), or
the element's own axial stiffness ``EA/L``, so that one grid of relative sizes suits all.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sdctrl.diagnosis._locations import split_locations

__all__ = ["Candidates", "Family", "Group", "candidate_groups", "families"]

#: remaining fraction of an element's axial stiffness on the screen grid (stiffness changes)
RHO_GRID = np.array([0.03, 0.07, 0.13, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.25, 1.7, 2.5])
#: sizes relative to the reference (dampers, added springs, added masses): from a hundredth
#: to a thousand half-power bandwidths of the most affected in-band mode
REL_GRID = 10.0 ** np.linspace(-2.0, 3.0, RHO_GRID.size)
#: masses removed from a node on the screen grid (fraction of its own lumped mass)
MASS_REMOVED = np.array([0.9, 0.6, 0.3])
#: resonator masses relative to the reference
RES_GRID = 10.0 ** np.linspace(-3.0, 2.0, 11)
_AXES = ("x", "y", "z")


@dataclass(frozen=True, eq=False)
class Group:
    """Candidates sharing their kind of load shape (so their transfers are computed together).

    A load shape touches a few candidate DOFs only (a strut: the six translations of its two
    nodes, a node: its three): it is kept as those DOFs and their weights, never as a dense
    (nd,) column, so that memory and work grow with the candidates, not with the FE size.

    Parameters
    ----------
    name : {"pairs", "nodes", "dofs"}
        What the load shapes act on.
    locations : tuple
        Node pairs, node names or DOF labels.
    idx : ndarray of int, shape (nc, w)
        Candidate DOFs (positions in the candidate DOF list) each load touches (padded with
        weight 0).
    val : ndarray, shape (nc, w, k)
        The load shapes' weights on those DOFs.
    """

    name: str
    locations: tuple
    idx: np.ndarray
    val: np.ndarray

    @property
    def size(self) -> int:
        """Number of candidates."""
        return len(self.locations)

    @property
    def rank(self) -> int:
        """Number of columns ``k`` of each load shape."""
        return self.val.shape[2]

    def project(self, X) -> np.ndarray:
        """``beta_c^T X`` of every candidate, ``X`` (nd, m) on the candidate DOFs.

        Parameters
        ----------
        X : ndarray, shape (nd, m)

        Returns
        -------
        ndarray, shape (nc, k, m)
        """
        return np.einsum("cwk,cwm->ckm", self.val, X[self.idx])

    def dense(self, c: int, nd: int) -> np.ndarray:
        """Load shape ``beta`` (nd, k) of candidate ``c`` on the ``nd`` candidate DOFs.

        Parameters
        ----------
        c : int
            Candidate.
        nd : int
            Number of candidate DOFs.

        Returns
        -------
        ndarray, shape (nd, k)
        """
        out = np.zeros((nd, self.rank))
        np.add.at(out, self.idx[c], self.val[c])
        return out


@dataclass(frozen=True, eq=False)
class Family:
    """One kind of effect over a group of candidates.

    Parameters
    ----------
    kind : str
        ``"added_damper"``, ``"stiffness_change"``, ``"mass_change"`` or ``"resonator"``.
    group : Group
        Where it acts.
    members : ndarray of int
        Candidates of the group in the family.
    grid : ndarray, shape (nc, m)
        Screen sizes (SI units).
    base : ndarray, shape (nc,)
        The fit variable is ``log(base + size)``: the element's stiffness or the node's mass
        (relative changes, negative sizes allowed), 0 for added dampers, springs, masses.
    bounds : ndarray, shape (nc, 2)
        Bounds of the size.
    reference : ndarray, shape (nc,)
        Element axial stiffness (N/m) for stiffness changes, NaN otherwise.
    """

    kind: str
    group: Group
    members: np.ndarray
    grid: np.ndarray
    base: np.ndarray
    bounds: np.ndarray
    reference: np.ndarray

    @property
    def size(self) -> int:
        """Number of candidates."""
        return self.members.size


@dataclass(frozen=True, eq=False)
class Candidates:
    """Where one diagnosis looks, built once for all its steps (internal).

    Parameters
    ----------
    dof_idx : ndarray of int
        Candidate DOFs.
    groups : dict of str to Group
        Load shapes (:func:`~._candidates.candidate_groups`).
    n_elements : int
        The first ``n_elements`` pairs are elements.
    kinv : dict
        ``{group name: {member: b^T K^-1 b}}``, filled as the steps solve them: a property
        of the FE model and the load alone, the same for every step's model.
    """

    dof_idx: np.ndarray
    groups: dict
    n_elements: int
    kinv: dict


def _axial_stiffness(fe) -> dict:
    """``EA/L`` of every bar and beam of the assembly, by unordered node-name pair."""
    A = fe.assembly
    if A is None:
        return {}
    out = {}
    for (_kind, mat, sec, _ori), conn in A.groups:
        EA = float(A.materials[mat]["E"]) * float(A.sections[sec]["A"])
        L = np.linalg.norm(A.xyz[conn[:, 1]] - A.xyz[conn[:, 0]], axis=1)
        for (a, b), length in zip(conn, L):
            key = frozenset((A.names[a], A.names[b]))
            out[key] = out.get(key, 0.0) + EA / length
    return out


def _node_dofs(fe, keep=None):
    """Candidate DOFs (translations of the nodes with coordinates, of the nodes in ``keep``
    only when it is given) and their map."""
    index = {lab: i for i, lab in enumerate(fe.dofs)}
    idx, where = [], {}
    for node in fe.nodes:
        if keep is not None and node not in keep:
            continue
        for ax in _AXES:
            i = index.get(f"{node}.{ax}")
            if i is not None:
                where[(node, ax)] = len(idx)
                idx.append(i)
    return np.asarray(idx, int), where


#: elements longer than this many times the median element are not the mesh's scale (a
#: brace, a suspension link, a dashpot across the structure): the default reach ignores them
OUTLIER_LENGTH = 4.0


def default_reach(lengths) -> float:
    """1.5 times the longest element of the mesh's own scale: the longest element no longer
    than :data:`OUTLIER_LENGTH` times the median one (one element across the structure would
    otherwise make every pair of nodes a candidate); ``inf`` without elements."""
    L = np.asarray(lengths, float)
    if not L.size:
        return np.inf
    return 1.5 * float(L[L <= OUTLIER_LENGTH * np.median(L)].max())


def _pairs(fe, reach):
    """Elements first (their own order), then unconnected pairs within ``reach`` (found by a
    k-d tree: the work grows with the pairs, not with the square of the nodes)."""
    from scipy.spatial import cKDTree

    names = list(fe.nodes)
    X = {n: np.asarray(fe.nodes[n], float) for n in names}
    elems, seen = [], set()
    for a, b in fe.elements or ():
        key = frozenset((a, b))
        if a != b and key not in seen and np.linalg.norm(X[a] - X[b]) > 0:
            seen.add(key)
            elems.append((a, b))
    if reach is None:
        reach = default_reach([np.linalg.norm(X[a] - X[b]) for a, b in elems])
    xyz = np.array([X[n] for n in names]).reshape(len(names), -1)
    if not np.isfinite(reach):
        reach = 2.0 * float(np.ptp(xyz, axis=0).max(initial=0.0)) + 1.0
    near = sorted(cKDTree(xyz).query_pairs(reach * (1 + 1e-9), output_type="ndarray").tolist())
    others = [(names[i], names[j]) for i, j in near
              if frozenset((names[i], names[j])) not in seen
              and 0 < np.linalg.norm(xyz[i] - xyz[j]) <= reach]
    return elems, others


def candidate_groups(fe, reach=None, locations=None):
    """Load shapes of the pairs, nodes and DOFs of an FE model.

    Parameters
    ----------
    fe : FEModel
        With node coordinates (``fe.nodes``); elements optional.
    reach : float, optional
        Largest distance (m) between two unconnected nodes of a pair; default
        :func:`default_reach` (1.5 times the longest element of the mesh's scale).
    locations : tuple, optional
        The caller's own locations (:func:`~._locations.checked_locations`): node names
        (masses, resonators on their translations) and node pairs (dampers, stiffness
        changes; the beam elements among them scaled whole) -- only those are scanned.

    Returns
    -------
    dof_idx : ndarray of int, shape (nd,)
        Candidate DOFs (node translations, then the other DOFs of beam elements).
    groups : dict of str to Group
        ``"pairs"``, ``"nodes"``, ``"dofs"`` and, when ``fe`` has beam elements,
        ``"members"``.
    n_elements : int
        The first ``n_elements`` pairs are elements.
    """
    if locations is None:
        elems, others = _pairs(fe, reach)
        listed = keep = None
    else:
        elems, others, listed = split_locations(fe, locations)
        keep = set(listed).union(*map(set, elems + others))
    dof_idx, where = _node_dofs(fe, keep)
    pairs, pi, pv, n_el = [], [], [], 0
    for i, (a, b) in enumerate(elems + others):
        xa, xb = np.asarray(fe.nodes[a], float), np.asarray(fe.nodes[b], float)
        e = (xb - xa) / np.linalg.norm(xb - xa)             # as FEModel.strut (5.4)
        ix, vx = [], []
        for sign, node in ((-1.0, a), (1.0, b)):
            for comp, ax in zip(e, _AXES):
                if (node, ax) in where:
                    ix.append(where[(node, ax)])
                    vx.append(sign * comp)
        if not np.any(vx):
            continue                   # both ends clamped, or no free axial motion: no load
        pairs.append((a, b))
        pi.append(ix + [0] * (6 - len(ix)))
        pv.append(vx + [0.0] * (6 - len(vx)))
        n_el += i < len(elems)
    nodes, ni, nv = [], [], []
    for node in fe.nodes if listed is None else listed:
        js = [j for j, ax in enumerate(_AXES) if (node, ax) in where]
        if js:
            nodes.append(node)
            ni.append([where[(node, _AXES[j])] if j in js else 0 for j in range(3)])
            nv.append(np.diag([1.0 if j in js else 0.0 for j in range(3)]))
    mass_nodes = None if listed is None else set(listed)
    own = [key for key in where if mass_nodes is None or key[0] in mass_nodes]
    labels = [f"{node}.{ax}" for (node, ax) in own]
    order = np.array([where[key] for key in own], int)
    dof_idx, members = _beam_members(
        fe, dof_idx, None if locations is None else {frozenset(p) for p in elems})
    groups = {
        "pairs": Group("pairs", tuple(pairs), np.array(pi, int).reshape(-1, 6),
                       np.array(pv, float).reshape(-1, 6, 1)),
        "nodes": Group("nodes", tuple(nodes), np.array(ni, int).reshape(-1, 3),
                       np.array(nv, float).reshape(-1, 3, 3)),
        "dofs": Group("dofs", tuple(labels), order.reshape(-1, 1),
                      np.ones((order.size, 1, 1))),
    }
    if members is not None:
        groups["members"] = members
    return dof_idx, groups, n_el


def _beam_members(fe, dof_idx, only=None):
    """``(candidate DOFs, Group or None)``: every beam element as the load ``L`` (its DOFs,
    rotations appended to the candidate DOFs) with ``L L^T = K_e / (EA/L)``, so that a change
    ``dk L L^T`` scales the whole element (axial, bending, torsion: a loss of its modulus or
    section, as :meth:`FEModel.stiffness_parameter` does) and ``dk`` is the change of its
    stiffness along its axis.  Bars need none: their axial strut is the element.  ``only``
    (a set of node-name pairs): those beams only."""
    if fe.assembly is None or not any(g[0][0] == "beam" for g in fe.assembly.groups):
        return dof_idx, None
    beams = fe.members(kind="beam")
    ax = _axial_stiffness(fe)
    mats = _beam_matrices(fe.assembly)
    pos = {int(d): i for i, d in enumerate(dof_idx)}
    extra, locs, idx, val = [], [], [], []
    for pair in beams:
        if only is not None and frozenset(pair) not in only:
            continue
        rows, Ke = mats.get(frozenset(pair), (np.zeros(0, int), None))
        kax = ax.get(frozenset(pair), 0.0)
        if rows.size == 0 or not kax > 0:
            continue                                   # clamped at both ends
        d, U = np.linalg.eigh(Ke)
        keep = d > 1e-9 * d.max()
        for r in rows:
            if int(r) not in pos:
                pos[int(r)] = len(dof_idx) + len(extra)
                extra.append(int(r))
        locs.append(tuple(pair))
        idx.append([pos[int(r)] for r in rows])
        val.append(U[:, keep] * np.sqrt(d[keep] / kax))
    if not locs:
        return dof_idx, None
    w = max(len(i) for i in idx)
    k = max(v.shape[1] for v in val)
    I = np.zeros((len(locs), w), int)
    V = np.zeros((len(locs), w, k))
    for c, (i, v) in enumerate(zip(idx, val)):
        I[c, :len(i)] = i
        V[c, :v.shape[0], :v.shape[1]] = v
    return np.r_[dof_idx, np.asarray(extra, int)], Group("members", tuple(locs), I, V)


def _beam_matrices(A) -> dict:
    """``{pair: (free DOFs, K_e on them)}`` of every beam of the assembly ``A``: the element
    matrices of each group of beams computed at once (as the assembly does), those of a pair
    of nodes joined by several beams summed; the DOFs are the element's unconstrained ones
    with a non-zero row, in increasing order (as ``fe.member_matrices(elements=[pair])``
    gives them, without one sparse assembly per element)."""
    from sdctrl.fe._elements import member_matrices

    out = {}
    for (kind, mat, sec, ori), conn in A.groups:
        if kind != "beam" or not len(conn):
            continue
        Ke, _Me = member_matrices(kind, A.materials[mat], A.sections[sec], mat, sec, ori,
                                  A.xyz[conn[:, 0]], A.xyz[conn[:, 1]], A.lumped)
        gi = np.hstack([A.gidx[conn[:, 0], :6], A.gidx[conn[:, 1], :6]])
        for (a, b), g, K in zip(conn, gi, Ke):
            key = frozenset((A.names[a], A.names[b]))
            ok = np.flatnonzero(g >= 0)
            ok = ok[np.argsort(g[ok], kind="stable")]
            blk = (g[ok], K[np.ix_(ok, ok)])
            out[key] = _sum_blocks(out[key], blk) if key in out else blk
    for key, (rows, K) in out.items():
        nz = np.any(K != 0, axis=1)
        out[key] = (rows[nz].astype(int), K[np.ix_(nz, nz)])
    return out


def _sum_blocks(x, y):
    """Sum of two symmetric blocks ``(sorted DOFs, matrix)`` on the union of their DOFs."""
    rows = np.union1d(x[0], y[0])
    K = np.zeros((rows.size, rows.size))
    for r, k in (x, y):
        at = np.searchsorted(rows, r)
        K[np.ix_(at, at)] += k
    return rows, K


def _fam(kind, group, keep, grid, base, lo, hi, reference=None):
    """Family with its grid rows sorted by the fit variable ``log(base + size)``."""
    order = np.argsort(np.log(base[:, None] + grid), axis=1, kind="stable")
    grid = np.take_along_axis(grid, order, axis=1)
    ref = np.full(keep.size, np.nan) if reference is None else reference
    return Family(kind, group, keep, grid, base, np.c_[lo, hi], ref)


def families(fe, groups, n_elements, modal_b, omega, gamma, node_mass):
    """The four families with their size grids, from the in-band modal projections.

    The reference size of a candidate is the one that changes the most affected in-band
    mode by one half-power bandwidth ``gamma_j = Gamma_jj``: a dashpot ``c p_j^2 = gamma_j``,
    a spring ``dk p_j^2 / (2 w_j) = gamma_j``, a mass ``dm q_j^2 w_j / 2 = gamma_j``
    (``p_j = phi_j^T b``, ``q_j^2 = |phi_j|^2`` at the node), the scale at which the logLS
    cost of lightly damped modes responds.

    Parameters
    ----------
    fe : FEModel
        The FE model.
    groups : dict of str to Group
        From :func:`candidate_groups`.
    n_elements : int
        Number of element pairs (first in ``groups["pairs"]``).
    modal_b : dict of str to ndarray, shape (nc, k, nm)
        ``phi_j^T b`` of each candidate for the in-band modes.
    omega : ndarray, shape (nm,)
        In-band modal frequencies (rad/s).
    gamma : ndarray, shape (nm,)
        Their modal damping ``Gamma_jj`` (rad/s).
    node_mass : ndarray, shape (n_nodes,)
        Lumped translational mass of each node of the ``"nodes"`` group (kg).

    Returns
    -------
    list of Family
    """
    w = np.maximum(omega, 1e-12)
    g = np.maximum(gamma, 1e-4 * w)
    out = []
    pairs = groups["pairs"]
    p2 = modal_b["pairs"][:, 0, :] ** 2                                  # (np, nm)
    keep = np.flatnonzero(p2.max(axis=1) > 0)
    c_ref = 1.0 / np.max(p2[keep] / g, axis=1)
    zero = np.zeros(keep.size)
    out.append(_fam("added_damper", pairs, keep, c_ref[:, None] * REL_GRID, zero,
                    1e-3 * c_ref, 1e4 * c_ref))
    k_ref = 1.0 / np.max(p2[keep] / (2 * w * g), axis=1)
    ax = _axial_stiffness(fe)
    kax = np.array([ax.get(frozenset(pairs.locations[i]), np.nan) if i < n_elements else np.nan
                    for i in keep])
    el = np.isfinite(kax)
    grid = np.where(el[:, None], kax[:, None] * (RHO_GRID - 1.0), k_ref[:, None] * REL_GRID)
    out.append(_fam("stiffness_change", pairs, keep, grid, np.where(el, kax, 0.0),
                    np.where(el, -0.999 * kax, 1e-3 * k_ref),
                    np.where(el, 20.0 * kax, 1e4 * k_ref), kax))
    nodes = groups["nodes"]
    q2 = np.sum(modal_b["nodes"] ** 2, axis=1)                           # (nn, nm)
    keep = np.flatnonzero(q2.max(axis=1) > 0)
    m_ref = 1.0 / np.max(q2[keep] * w / (2 * g), axis=1)
    mn = np.asarray(node_mass, float)[keep]
    neg = np.where(mn[:, None] > 0, -mn[:, None] * MASS_REMOVED, 1e-3 * m_ref[:, None])
    out.append(_fam("mass_change", nodes, keep,
                    np.hstack([m_ref[:, None] * REL_GRID[:-MASS_REMOVED.size], neg]), mn,
                    np.where(mn > 0, -0.99 * mn, 1e-4 * m_ref), 1e4 * m_ref))
    dofs = groups["dofs"]
    r2 = modal_b["dofs"][:, 0, :] ** 2
    keep = np.flatnonzero(r2.max(axis=1) > 0)
    m_ref = 1.0 / np.max(r2[keep] * w / (2 * g), axis=1)
    out.append(_fam("resonator", dofs, keep, m_ref[:, None] * RES_GRID, np.zeros(keep.size),
                    1e-5 * m_ref, 1e3 * m_ref))
    if "members" in groups:         # beams: their whole stiffness scaled, dk along the axis
        mem = groups["members"]
        seen = np.sum(modal_b["members"] ** 2, axis=1)                  # (nb, nm)
        keep = np.flatnonzero(seen.max(axis=1) > 0)
        kax = np.array([ax[frozenset(mem.locations[i])] for i in keep])
        out.append(_fam("stiffness_change", mem, keep, kax[:, None] * (RHO_GRID - 1.0), kax,
                        -0.999 * kax, 20.0 * kax, kax))
    return out
