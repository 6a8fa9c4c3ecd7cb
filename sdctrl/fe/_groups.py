"""Element groups and lumped masses of an assembled model, and the parameters built from them.

:func:`~sdctrl.fe.assemble` keeps, besides the matrices, an :class:`Assembly` record: the
member elements grouped by kind, material, section and orientation, and the lumped masses.
From it the stiffness and mass of any selection of elements are rebuilt (one vectorised
call per group, the same element matrices as the assembly), so that design parameters
(4.15) are written in the model's own terms:

>>> import sdctrl as sd
>>> fe = sd.testbed()
>>> links = fe.stiffness_parameter("links", section=["post_AB", "post_C"])
>>> plates = fe.mass_parameter("plate A", ["N31", "N32", "N33", "N34", "N35"])

:class:`ElementGroups` holds the :class:`~sdctrl.fe.FEModel` methods that do this.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np
import scipy.sparse as sp

from sdctrl._lib.frozen import FrozenState
from sdctrl._lib.validate import check_bool, check_scalar
from sdctrl.fe._elements import DIRECTIONS, assemble_coo, member_matrices
from sdctrl.fe._parameters import DEFAULT_BOUNDS, Parameter

__all__ = ["Assembly", "ElementGroups"]


def _names(x, what: str) -> tuple[str, ...] | None:
    if x is None:
        return None
    try:
        items = (x,) if isinstance(x, str) else tuple(x)
    except TypeError:
        items = ()
    if not items or not all(isinstance(v, str) for v in items):
        raise TypeError(f"{what} must be a string or a sequence of strings, got {x!r}")
    return items


@dataclass(frozen=True, eq=False)
class Assembly(FrozenState):
    """How :func:`~sdctrl.fe.assemble` built a model: element groups and lumped masses.

    Parameters
    ----------
    N : int
        Number of DOFs of the model.
    names : tuple of str
        Node names.
    xyz : ndarray, shape (nn, 3)
        Node coordinates (m).
    gidx : ndarray of int, shape (nn, 6)
        Global DOF of each node direction (``x, y, z, rx, ry, rz``), -1 when absent.
    groups : tuple
        ``((kind, material, section, orientation), conn)`` per group of bars or beams,
        ``conn`` (ne, 2) node indices.
    materials, sections : mapping
        Material and section properties by name.
    lumped : bool
        Lumped bar masses.
    mass_nodes : ndarray of int, shape (nm,)
        Node of each lumped mass.
    mass_values : ndarray, shape (nm, 6)
        ``(m, m, m, Jx, Jy, Jz)`` of each lumped mass.
    rayleigh : (float, float)
        ``(alpha, beta)`` of the Rayleigh damping ``alpha M + beta K`` the model was
        assembled with (``(0, 0)``: none); the parameters that scale the model's own members
        and masses carry it along (:meth:`ElementGroups.stiffness_parameter`).
    """

    N: int
    names: tuple
    xyz: np.ndarray
    gidx: np.ndarray
    groups: tuple
    materials: Mapping
    sections: Mapping
    lumped: bool
    mass_nodes: np.ndarray
    mass_values: np.ndarray
    rayleigh: tuple = (0.0, 0.0)

    @classmethod
    def from_parsed(cls, els, xyz, gidx, N, materials, sections, lumped,
                    rayleigh=None) -> Assembly:
        """Record of the parsed elements of :func:`~sdctrl.fe.assemble` (internal use).

        Parameters
        ----------
        els : object
            The parsed elements (``groups``, ``masses``, ``names``).
        xyz : ndarray, shape (nn, 3)
            Node coordinates.
        gidx : ndarray, shape (nn, 6)
            Global DOF indices.
        N : int
            Number of DOFs.
        materials, sections : mapping
            Properties by name.
        lumped : bool
            Lumped bar masses.
        rayleigh : (float, float), optional
            Rayleigh damping coefficients ``(alpha, beta)``; None: no Rayleigh damping.

        Returns
        -------
        Assembly
        """
        def ro(a):
            a = np.array(a)
            a.setflags(write=False)
            return a

        groups = tuple((key, ro(np.asarray(conn, dtype=np.int64).reshape(-1, 2)))
                       for key, conn in els.groups.items())
        nodes = ro(np.array([m[0] for m in els.masses], dtype=np.int64))
        vals = ro(np.array([[m[1]] * 3 + list(m[2]) for m in els.masses], float).reshape(-1, 6))
        mats = MappingProxyType({k: MappingProxyType(dict(v)) for k, v in materials.items()})
        secs = MappingProxyType({k: MappingProxyType(dict(v)) for k, v in sections.items()})
        ray = (0.0, 0.0) if rayleigh is None else tuple(float(v) for v in rayleigh)
        return cls(int(N), tuple(els.names), ro(xyz), ro(gidx), groups, mats, secs,
                   bool(lumped), nodes, vals, ray)

    def __repr__(self) -> str:
        ne = sum(len(c) for _, c in self.groups)
        return f"Assembly({ne} members in {len(self.groups)} groups, {self.mass_nodes.size} " \
               f"lumped masses)"

    # --- selection ---------------------------------------------------------------------
    def select(self, elements=None, kind=None, section=None, material=None) -> tuple:
        """Boolean mask per group of the members matching every given filter.

        Parameters
        ----------
        elements : sequence of (str, str), optional
            Node-name pairs (either order); each must name at least one member.
        kind : str or sequence of str, optional
            ``"bar"``, ``"beam"``.
        section : str or sequence of str, optional
            Section names.
        material : str or sequence of str, optional
            Material names.

        Returns
        -------
        tuple of ndarray of bool
            One mask per entry of :attr:`groups`; at least one member is selected.
        """
        kinds, secs, mats = (_names(kind, "kind"), _names(section, "section"),
                             _names(material, "material"))
        for given, known, what in ((kinds, {"bar", "beam"}, "kind"),
                                   (secs, set(self.sections), "section"),
                                   (mats, set(self.materials), "material")):
            unknown = sorted(set(given or ()) - known)
            if unknown:
                raise ValueError(f"{what}: unknown {unknown} (known: {sorted(known)})")
        wanted = None
        if elements is not None:
            wanted = self._pairs(elements)
        masks, found = [], set()
        for (k, mat, sec, _ori), conn in self.groups:
            ok = (kinds is None or k in kinds) and (secs is None or sec in secs) and \
                (mats is None or mat in mats)
            mask = np.full(len(conn), ok)
            if ok and wanted is not None:
                key = [frozenset((int(a), int(b))) for a, b in conn]
                mask = np.array([e in wanted for e in key], bool)
                found.update(e for e in key if e in wanted)
            masks.append(mask)
        if wanted is not None and len(found) < len(wanted):
            missing = [tuple(self.names[i] for i in sorted(e)) for e in wanted - found]
            raise ValueError(f"elements: no member (matching the other filters) joins {missing}")
        if not any(m.any() for m in masks):
            raise ValueError("the selection matches no bar or beam of the model")
        return tuple(masks)

    def _pairs(self, elements) -> set:
        nid = {n: i for i, n in enumerate(self.names)}
        if isinstance(elements, str) or not isinstance(elements, Sequence):
            raise TypeError("elements must be a sequence of (node_a, node_b) pairs")
        out = set()
        for e in elements:
            if isinstance(e, str) or not isinstance(e, Sequence) or len(e) != 2:
                raise ValueError(f"elements must contain node-name pairs, got {e!r}")
            try:
                out.add(frozenset((nid[str(e[0])], nid[str(e[1])])))
            except KeyError as exc:
                raise ValueError(f"elements: unknown node {exc.args[0]!r}") from None
        if not out:
            raise ValueError("elements must name at least one pair")
        return out

    def members(self, masks=None) -> list[tuple[str, str]]:
        """Node-name pairs of the selected members (all when ``masks`` is None).

        Parameters
        ----------
        masks : tuple of ndarray of bool, optional
            From :meth:`select`.

        Returns
        -------
        list of (str, str)
        """
        out = []
        for g, (_key, conn) in enumerate(self.groups):
            sel = conn if masks is None else conn[masks[g]]
            out += [(self.names[a], self.names[b]) for a, b in sel]
        return out

    # --- matrices ----------------------------------------------------------------------
    def matrices(self, masks) -> tuple[sp.csr_matrix, sp.csr_matrix]:
        """Stiffness and mass of the selected members, the element matrices of the assembly.

        Parameters
        ----------
        masks : tuple of ndarray of bool
            From :meth:`select`.

        Returns
        -------
        K, M : scipy.sparse.csr_matrix, shape (N, N)
        """
        K = sp.csr_matrix((self.N, self.N))
        M = sp.csr_matrix((self.N, self.N))
        for ((kind, mat, sec, ori), conn), mask in zip(self.groups, masks):
            if not mask.any():
                continue
            c = conn[mask]
            Ke, Me = member_matrices(kind, self.materials[mat], self.sections[sec], mat, sec,
                                     ori, self.xyz[c[:, 0]], self.xyz[c[:, 1]], self.lumped)
            nd = 3 if kind == "bar" else 6
            idx = np.hstack([self.gidx[c[:, 0], :nd], self.gidx[c[:, 1], :nd]])
            K = K + assemble_coo(idx, Ke, self.N)
            M = M + assemble_coo(idx, Me, self.N)
        return K.tocsr(), M.tocsr()

    def lumped_mass(self, nodes, rotational: bool = True) -> sp.csr_matrix:
        """Diagonal matrix of the lumped masses (and rotary inertias) at some nodes.

        Parameters
        ----------
        nodes : sequence of str
            Node names.
        rotational : bool
            Include the rotary inertias.

        Returns
        -------
        scipy.sparse.csr_matrix, shape (N, N)
        """
        nid = {n: i for i, n in enumerate(self.names)}
        want = set()
        for n in nodes:
            if n not in nid:
                raise ValueError(f"nodes: unknown node {n!r}")
            want.add(nid[n])
        sel = np.array([i in want for i in self.mass_nodes], bool)
        if not sel.any():
            raise ValueError(f"nodes: no lumped mass at {sorted(nodes)}; give mass= to add one")
        vals = self.mass_values[sel].copy()
        if not rotational:
            vals[:, 3:] = 0
        idx = self.gidx[self.mass_nodes[sel]]
        ok = (idx >= 0) & (vals != 0)
        return sp.coo_matrix((vals[ok], (idx[ok], idx[ok])), shape=(self.N, self.N)).tocsr()


class ElementGroups(FrozenState):
    """:class:`~sdctrl.fe.FEModel` methods over its element groups and nodes (mixin).

    Also how an FE model pickles (:class:`~sdctrl._lib.frozen.FrozenState`): its ``_cache``
    of factorisations (``SuperLU``) is left out and rebuilt on first use.
    """

    __slots__ = ()

    def _assembly(self) -> Assembly:
        if self.assembly is None:
            raise ValueError("the model has no element records (it was built from matrices, "
                             "not by sdctrl.fe.assemble): give the matrices to sd.Parameter")
        return self.assembly

    def members(self, kind=None, section=None, material=None) -> list[tuple[str, str]]:
        """Node-name pairs of the model's bars and beams matching the filters.

        Parameters
        ----------
        kind : str or sequence of str, optional
            ``"bar"`` or ``"beam"``.
        section : str or sequence of str, optional
            Section names used at assembly.
        material : str or sequence of str, optional
            Material names used at assembly.

        Returns
        -------
        list of (str, str)
        """
        A = self._assembly()
        return A.members(A.select(None, kind, section, material))

    def member_matrices(self, elements=None, *, kind=None, section=None, material=None):
        """Stiffness and mass (sparse, N x N) of a group of the model's bars and beams.

        Parameters
        ----------
        elements : sequence of (str, str), optional
            Node-name pairs of the members (either order).
        kind : str or sequence of str, optional
            ``"bar"`` or ``"beam"``.
        section : str or sequence of str, optional
            Section names.
        material : str or sequence of str, optional
            Material names.

        Returns
        -------
        K, M : scipy.sparse.csr_matrix
            The same element matrices as the assembly, summed over the selection.
        """
        A = self._assembly()
        return A.matrices(A.select(elements, kind, section, material))

    def stiffness_parameter(self, name: str, elements=None, *, kind=None, section=None,
                            material=None, bounds=DEFAULT_BOUNDS,
                            scale: float | None = None, rayleigh: bool = True) -> Parameter:
        """Parameter (4.15) scaling the stiffness of a group of bars/beams: ``dK = K_group``.

        ``p = 0.3`` makes the selected members 30% stiffer (Young's modulus, or the
        section's stiffness, times ``1 + p``), their mass unchanged.  A model assembled with
        Rayleigh damping ``alpha M + beta K`` keeps it: ``beta K_group`` more damping, the damping
        the stiffer members bring under the model's own law (with ``C`` fixed instead, the
        update meets a damping error the parameters cannot reach and biases them: on the
        family of test structures 5e-5 to 4.5e-4, 3 to 21 standard deviations).

        Parameters
        ----------
        name : str
            Parameter name.
        elements : sequence of (str, str), optional
            Node-name pairs of the members.
        kind : str or sequence of str, optional
            ``"bar"`` or ``"beam"``.
        section : str or sequence of str, optional
            Section names.
        material : str or sequence of str, optional
            Material names.
        bounds : (float, float)
            Bounds of ``p`` (default: stiffness between 10% and 10 times nominal).
        scale : float, optional
            Standard change (default 1: +100%).
        rayleigh : bool
            Carry the model's Rayleigh damping along (``Parameter.rayleigh = (0, beta)``:
            ``beta K_group`` under the model's own damping; nothing when the model has
            none).  False: ``C`` is left as it is.

        Returns
        -------
        Parameter
        """
        check_bool(rayleigh, "rayleigh")
        A = self._assembly()
        masks = A.select(elements, kind, section, material)
        K, _ = A.matrices(masks)
        n = int(sum(m.sum() for m in masks))
        beta = A.rayleigh[1] if rayleigh else 0.0
        return Parameter(name, dK=K, bounds=bounds, scale=scale, rayleigh=(0.0, beta),
                         description=f"stiffness of {n} members" + (
                             f", Rayleigh damping {beta:g} dK" if beta else ""))

    def mass_parameter(self, name: str, nodes, mass: float | None = None, inertia=None, *,
                       rotational: bool = True, bounds=DEFAULT_BOUNDS,
                       scale: float | None = None, rayleigh: bool = True) -> Parameter:
        """Parameter (4.15) of the lumped mass at a node or a set of nodes.

        Without ``mass`` the nodes' own lumped masses are scaled (``dM`` = those masses,
        ``p = -0.2`` removes 20% of them), with the model's mass-proportional Rayleigh
        damping (``alpha dM``, as :meth:`stiffness_parameter` does for ``beta``); with
        ``mass`` (kg) that total is added, spread equally over the nodes' translations (a
        concentrated mass on one node, a distributed one over several), with ``inertia``
        likewise on their rotations -- a body the model did not have, without damping.

        Parameters
        ----------
        name : str
            Parameter name.
        nodes : str or sequence of str
            Node names.
        mass : float, optional
            Total added mass (kg) for ``p = 1``.
        inertia : (float, float, float), optional
            Total added rotary inertia ``(Jx, Jy, Jz)`` (kg m^2) for ``p = 1`` (with ``mass``).
        rotational : bool
            Without ``mass``: include the nodes' lumped rotary inertias.
        bounds : (float, float)
            Bounds of ``p``.
        scale : float, optional
            Standard change (default 1).
        rayleigh : bool
            Without ``mass``: carry the model's Rayleigh damping along
            (``Parameter.rayleigh = (alpha, 0)``; nothing when the model has none).  False:
            ``C`` is left as it is.

        Returns
        -------
        Parameter
        """
        check_bool(rayleigh, "rayleigh")
        if nodes is None:
            raise TypeError("nodes must be a node name or a sequence of node names, got None")
        names = list(_names(nodes, "nodes"))
        if mass is None:
            if inertia is not None:
                raise ValueError("inertia is an added rotary inertia: give mass= with it")
            A = self._assembly()
            dM = A.lumped_mass(names, rotational)
            alpha = A.rayleigh[0] if rayleigh else 0.0
            desc = f"lumped mass at {len(names)} nodes" + (
                f", Rayleigh damping {alpha:g} dM" if alpha else "")
            return Parameter(name, dM=dM, bounds=bounds, scale=scale, description=desc,
                             rayleigh=(alpha, 0.0))
        dM = self._added_mass(names, mass, inertia)
        return Parameter(name, dM=dM, bounds=bounds, scale=scale,
                         description=f"{float(mass):g} kg over {len(names)} nodes")

    def _added_mass(self, names, mass, inertia) -> sp.csr_matrix:
        m = check_scalar(mass, "mass")
        if not np.isfinite(m) or m <= 0:
            raise ValueError(f"mass must be a positive mass in kg, got {mass!r}")
        J = np.zeros(3) if inertia is None else np.asarray(inertia, float)
        if J.shape != (3,) or not np.all(np.isfinite(J)) or np.any(J < 0):
            raise ValueError(f"inertia must be 3 non-negative inertias (kg m^2), got {inertia!r}")
        rows, vals = [], []
        k = len(names)
        for node in names:
            for d, v in zip(DIRECTIONS, [m / k] * 3 + list(J / k)):
                if v == 0:
                    continue
                i = self._index.get(f"{node}.{d}")
                if i is None:
                    raise ValueError(f"nodes: node {node!r} has no DOF {node}.{d} for the "
                                     "added mass/inertia")
                rows.append(i)
                vals.append(v)
        return sp.coo_matrix((vals, (rows, rows)), shape=(self.N, self.N)).tocsr()
