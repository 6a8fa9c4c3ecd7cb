"""Geometry and materials of the test structures of the family (:mod:`sdctrl.testbeds`).

Each builder returns an assembled :class:`~sdctrl.fe.FEModel` (nodes, elements, element
groups, lumped masses, Rayleigh damping plus discrete dashpots: non-proportional damping)
for given error factors, so that the same function builds the true structure (factors 1) and
a deliberately wrong FE model of it.  All in SI units, aluminium beams.
"""

from __future__ import annotations

import numpy as np

__all__ = ["cluster", "ladder", "plate_grid"]

_AL = {"E": 70e9, "rho": 2700.0, "nu": 0.33}


def _box(b: float, h: float) -> dict:
    """Section of a solid rectangle ``b`` (y) by ``h`` (z)."""
    A = b * h
    Iy, Iz = b * h ** 3 / 12, h * b ** 3 / 12
    return {"A": A, "Iy": Iy, "Iz": Iz, "J": 0.3 * min(b, h) ** 3 * max(b, h)}


def _materials(stiff: float) -> dict:
    return {"al": dict(_AL), "al_e": {**_AL, "E": _AL["E"] * stiff}}


def ladder(rung_stiffness: float = 1.0, payload_mass: float = 1.0):
    """A free-free ladder frame on a soft suspension (a boom with four payloads).

    Two rails (x, 2.4 m, 8 segments) 0.5 m apart in y (the right one 40 mm higher, so
    that no plane of symmetry decouples any sensor from any shaker) joined by 9 rungs; four payload
    masses (2 kg, small inertia) on the rails at x = 0.6 and 1.8 m; four soft springs to
    ground (z, 300 N/m; x and y, 150 N/m) at the corners give six suspension modes near
    1-2 Hz, far below the first flexible mode; Rayleigh damping and two dashpots across
    rungs (non-proportional damping).

    Parameters
    ----------
    rung_stiffness : float
        Factor on the Young's modulus of the rungs (section ``rung``).
    payload_mass : float
        Factor on the payload masses and inertias (nodes ``L3``, ``L7``, ``R3``, ``R7``).

    Returns
    -------
    FEModel
    """
    from sdctrl.fe import assemble

    n, L, W = 8, 2.4, 0.5
    nodes, els = {}, []
    for i in range(n + 1):                   # the right rail 40 mm higher: no symmetry plane
        nodes[f"L{i}"] = (i * L / n, 0.0, 0.0)
        nodes[f"R{i}"] = (i * L / n, W, 0.04)
    for i in range(n):
        for side in "LR":
            els.append(("beam", f"{side}{i}", f"{side}{i + 1}", "al", "rail"))
    for i in range(n + 1):
        els.append(("beam", f"L{i}", f"R{i}", "al_e", "rung"))
    for node in ("L3", "R3", "L7", "R7"):
        m = 2.0 * payload_mass
        els.append(("mass", node, m, (0.002 * payload_mass,) * 3))
    for node in ("L0", "R0", f"L{n}", f"R{n}"):
        els += [("spring", f"{node}.z", None, 300.0), ("spring", f"{node}.x", None, 150.0),
                ("spring", f"{node}.y", None, 150.0)]
    els += [("dashpot", "L2.z", "R2.z", 8.0), ("dashpot", "L5.y", "R6.y", 20.0)]
    sections = {"rail": _box(0.03, 0.012), "rung": _box(0.02, 0.008)}
    return assemble(nodes, els, _materials(rung_stiffness), sections, rayleigh=(0.05, 2e-5))


def plate_grid(edge_stiffness: float = 1.0, tip_mass: float = 1.0):
    """A cantilevered grid of beams (a plate-like panel clamped along one edge).

    5 x 4 nodes, 0.25 m apart, beams along x and y, slightly twisted (15 mm at the free
    corners, so that bending and in-plane motions couple); clamped at x = 0; two tip masses
    (0.4 kg) at the free corners; Rayleigh damping and a dashpot between the free corners.

    Parameters
    ----------
    edge_stiffness : float
        Factor on the Young's modulus of the beams along the clamped edge's neighbours
        (section ``root``: the first bay in x).
    tip_mass : float
        Factor on the tip masses (nodes ``G4_0``, ``G4_3``).

    Returns
    -------
    FEModel
    """
    from sdctrl.fe import assemble

    nx, ny, d = 5, 4, 0.25
    nodes, els = {}, []
    for i in range(nx):                      # a slight twist: no symmetry plane
        for j in range(ny):
            nodes[f"G{i}_{j}"] = (i * d, j * d, 0.03 * (i / (nx - 1)) * (j / (ny - 1) - 0.5))
    for i in range(nx):
        for j in range(ny):
            if i + 1 < nx:
                mat, sec = ("al_e", "root") if i == 0 else ("al", "strip")
                els.append(("beam", f"G{i}_{j}", f"G{i + 1}_{j}", mat, sec))
            if j + 1 < ny:
                els.append(("beam", f"G{i}_{j}", f"G{i}_{j + 1}", "al", "cross"))
    for node in (f"G{nx - 1}_0", f"G{nx - 1}_{ny - 1}"):
        els.append(("mass", node, 0.4 * tip_mass, (1e-4 * tip_mass,) * 3))
    els.append(("dashpot", f"G{nx - 1}_0.z", f"G{nx - 1}_{ny - 1}.z", 3.0))
    sections = {"root": _box(0.03, 0.006), "strip": _box(0.03, 0.006),
                "cross": _box(0.02, 0.005)}
    bc = [f"G0_{j}" for j in range(ny)]
    return assemble(nodes, els, _materials(edge_stiffness), sections, bc=bc,
                    rayleigh=(0.2, 1e-5))


#: mistuning of the four blades of :func:`cluster` (relative tip-mass offsets)
BLADE_MISTUNING = (0.0, 0.012, -0.009, 0.021)


def cluster(hub_stiffness: float = 1.0, blade_mass: float = 1.0):
    """A hub beam carrying four nearly identical blades (a dense cluster) and a light local
    resonator (a local mode).

    A clamped-clamped hub beam (x, 1.2 m, 6 segments) carries four cantilever blades
    (about z, 0.3 m, 3 segments, leaning a few degrees in x and y) with tip masses of 0.25 kg
    mistuned by
    :data:`BLADE_MISTUNING`: their first bending modes form a cluster within a few
    percent.  A 0.05 kg mass on a soft spring (y) at the hub's centre is a local mode.
    Rayleigh damping and a dashpot between two blade tips.

    Parameters
    ----------
    hub_stiffness : float
        Factor on the Young's modulus of the hub beam (section ``hub``).
    blade_mass : float
        Factor on the blade tip masses (nodes ``T1``-``T4``).

    Returns
    -------
    FEModel
    """
    from sdctrl.fe import assemble

    nodes, els = {}, []
    for i in range(7):
        nodes[f"H{i}"] = (0.2 * i, 0.0, 0.0)
    for i in range(6):
        els.append(("beam", f"H{i}", f"H{i + 1}", "al_e", "hub"))
    for k, (root, dm) in enumerate(zip(("H1", "H2", "H4", "H5"), BLADE_MISTUNING), start=1):
        x = nodes[root][0]
        prev = root
        lean = 0.02 * (-1) ** k                 # blades lean in x and y: no symmetry plane
        for s in (1, 2, 3):
            name = f"T{k}" if s == 3 else f"B{k}_{s}"
            nodes[name] = (x + lean * s, 0.015 * s, 0.1 * s)
            els.append(("beam", prev, name, "al", "blade"))
            prev = name
        els.append(("mass", f"T{k}", 0.25 * (1 + dm) * blade_mass))
    nodes["R"] = (0.6, 0.05, 0.0)
    els += [("mass", "R", 0.05), ("spring", "R.y", "H3.y", 0.05 * (2 * np.pi * 37.0) ** 2),
            ("spring", "R.x", "H3.x", 1e5), ("spring", "R.z", "H3.z", 1e5)]
    els.append(("dashpot", "T1.y", "T2.y", 0.6))
    sections = {"hub": _box(0.05, 0.03), "blade": _box(0.03, 0.004)}
    return assemble(nodes, els, _materials(hub_stiffness), sections, bc=["H0", "H6"],
                    rayleigh=(0.3, 1e-5))
