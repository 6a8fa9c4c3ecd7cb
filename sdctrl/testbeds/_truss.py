"""The built-in test article and its simulated vibration test.

A small structure in the spirit of the interferometer testbed of the thesis (a truss
carrying plates on flexible links, tested by several shakers and many sensors), with
the features that make identification and control design hard: rigid-body suspension
modes below the band, a close pair of modes strongly coupled by non-proportional
damping, a mostly local mode, and several inputs with collocated sensors.  See
:func:`testbed` for the geometry and the modes.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from sdctrl._lib.validate import check_band, check_int, check_quantity, check_scalar, check_seed
from sdctrl.testbeds._measurement_noise import relative_noise

__all__ = ["SENSORS", "SHAKERS", "TESTBED_BAND", "testbed", "testbed_frf"]

#: default test band (Hz)
TESTBED_BAND = (8.0, 60.0)
#: most frequency lines of :func:`testbed_frf` (31 x 6 channels: 300 MB of complex data)
MAX_LINES = 100_000


def _tube(D: float, t: float) -> dict:
    A = np.pi * (D**2 - (D - 2 * t) ** 2) / 4
    Ib = np.pi * (D**4 - (D - 2 * t) ** 4) / 64
    return {"A": A, "Iy": Ib, "Iz": Ib, "J": 2 * Ib}


_NBAY, _BAY, _WIDTH = 6, 0.5, 0.4
_CORNERS = ((-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5))
# name, truss section, mass (kg), centre inertia (kg m^2), post section, post height (m),
# plate half-size (m)
_PLATES = (("A", 0, 6.0, (0.02, 0.02, 0.02), "post_AB", 0.4, 0.15),
           ("B", 6, 6.0, (0.02, 0.02, 0.02), "post_AB", 0.4, 0.15),
           ("C", 3, 3.0, (0.01, 0.01, 0.02), "post_C", 0.3, 0.13))
_SECTIONS = {"longeron": _tube(0.025, 0.0015), "batten": _tube(0.020, 0.0015),
             "diagonal": _tube(0.015, 0.0010), "spider": _tube(0.030, 0.003),
             "post_AB": _tube(0.030, 0.002), "post_C": _tube(0.050, 0.002),
             "plate": _tube(0.060, 0.006)}
_MATERIALS = {"al": {"E": 70e9, "rho": 2700.0, "nu": 0.33}}
_K_SUSPENSION = 800.0          # N/m, each of 12 ground springs
_RAYLEIGH = (0.1, 4e-5)        # C = alpha M + beta K
_CENTRE_FRACTION = 0.4         # share of each plate's mass at its centre node


def _node_names():
    """Node numbering: truss N1-N28 (7 sections x 4 corners), then per plate: post base,
    post middle, plate centre, 4 plate corners."""
    truss = [[f"N{4 * s + k + 1}" for k in range(4)] for s in range(_NBAY + 1)]
    plates = {}
    nid = 4 * (_NBAY + 1)
    for name, *_ in _PLATES:
        ids = [f"N{nid + i + 1}" for i in range(7)]
        nid += 7
        plates[name] = {"base": ids[0], "mid": ids[1], "centre": ids[2], "corners": ids[3:]}
    return truss, plates


def _dashpots(truss, plates):
    A, C = plates["A"], plates["C"]
    return [(f"{A['centre']}.rz", f"{A['base']}.rz", 1.5),      # torsional damper on plate A
            (f"{truss[2][0]}.x", f"{truss[3][1]}.x", 150.0),     # damper across a truss bay
            (f"{C['centre']}.y", f"{C['base']}.y", 5.0)]         # damper on plate C


def _build(link_stiffness: float = 1.0, plate_mass: float = 1.0):
    from sdctrl.fe._assembly import assemble

    truss, plates = _node_names()
    nodes, els = {}, []
    w = _WIDTH
    for s, row in enumerate(truss):
        for k, name in enumerate(row):
            nodes[name] = (s * _BAY, _CORNERS[k][0] * w, _CORNERS[k][1] * w)
    for s, r in enumerate(truss):
        for k in range(4):
            els.append(("bar", r[k], r[(k + 1) % 4], "al", "batten"))
        els.append(("bar", r[0], r[2], "al", "diagonal"))
        if s < _NBAY:
            q = truss[s + 1]
            for k in range(4):
                els.append(("bar", r[k], q[k], "al", "longeron"))
                a, b = (r[k], q[(k + 1) % 4]) if s % 2 == 0 else (r[(k + 1) % 4], q[k])
                els.append(("bar", a, b, "al", "diagonal"))
    materials = dict(_MATERIALS)
    link = "al"
    if link_stiffness != 1.0:               # the posts' Young's modulus scaled, mass kept
        link = "al_link"
        materials[link] = {**_MATERIALS["al"], "E": _MATERIALS["al"]["E"] * link_stiffness}
    for name, s, m, J, post, h, a in _PLATES:
        m, J = m * plate_mass, tuple(plate_mass * j for j in J)
        p = plates[name]
        x, ztop = s * _BAY, w / 2
        nodes[p["base"]] = (x, 0.0, ztop)
        s2 = s + 1 if s < _NBAY else s - 1
        for k in (2, 3):                     # spider: base joined to 4 top truss corners
            els.append(("beam", p["base"], truss[s][k], "al", "spider"))
            els.append(("beam", p["base"], truss[s2][k], "al", "spider"))
        nodes[p["mid"]] = (x, 0.0, ztop + h / 2)
        nodes[p["centre"]] = (x, 0.0, ztop + h)
        els.append(("beam", p["base"], p["mid"], link, post))
        els.append(("beam", p["mid"], p["centre"], link, post))
        els.append(("mass", p["centre"], _CENTRE_FRACTION * m, J))
        mc = (1 - _CENTRE_FRACTION) * m / 4
        for corner, (cx, cy) in zip(p["corners"], _CORNERS):
            nodes[corner] = (x + 2 * cx * a, 2 * cy * a, ztop + h)
            els.append(("beam", p["centre"], corner, "al", "plate"))
            els.append(("mass", corner, mc))
    for s in (0, _NBAY):                     # soft suspension at the bottom corners
        for k in (0, 1):
            for d in "xyz":
                els.append(("spring", f"{truss[s][k]}.{d}", None, _K_SUSPENSION))
    for a, b, c in _dashpots(truss, plates):
        els.append(("dashpot", a, b, c))
    fe = assemble(nodes, els, materials, _SECTIONS, rayleigh=_RAYLEIGH)
    return fe, truss, plates


def _io_sets():
    truss, plates = _node_names()
    A, B, C = plates["A"], plates["B"], plates["C"]
    shakers = (f"{A['corners'][0]}.z", f"{A['corners'][1]}.x", f"{B['corners'][2]}.y",
               f"{C['corners'][1]}.z", f"{truss[0][0]}.y", f"{truss[4][1]}.z")
    others = []
    for s in range(_NBAY + 1):
        others += [f"{truss[s][(s + 1) % 4]}.y", f"{truss[s][(s + 3) % 4]}.z"]
    others += [f"{truss[2][1]}.x", f"{truss[5][3]}.x"]
    others += [f"{A['corners'][2]}.y", f"{A['corners'][3]}.z"]
    others += [f"{B['corners'][0]}.x", f"{B['corners'][0]}.z", f"{B['corners'][3]}.y"]
    others += [f"{C['corners'][0]}.x", f"{C['corners'][2]}.y", f"{C['corners'][3]}.z",
               f"{C['corners'][2]}.z"]
    sensors = tuple(shakers) + tuple(o for o in others if o not in shakers)
    return tuple(shakers), sensors


SHAKERS, SENSORS = _io_sets()


@lru_cache(maxsize=8)
def _cached(link_stiffness: float = 1.0, plate_mass: float = 1.0):
    fe, _truss, _plates = _build(link_stiffness, plate_mass)
    return fe


def _factor(x, name: str) -> float:
    v = check_scalar(x, name)                  # a real number (not text, complex, an array)
    if not 1e-6 <= v <= 1e6:                   # beyond: the matrices leave double range
        raise ValueError(f"{name} must be a positive scale factor in [1e-6, 1e6], got {x!r}")
    return v


def testbed(*, link_stiffness: float = 1.0, plate_mass: float = 1.0):
    """The built-in test article: a suspended truss carrying three plates on flexible posts.

    Geometry (SI units, aluminium ``E = 70 GPa``, ``rho = 2700 kg/m^3``):

    - a 3 m square truss along ``x`` (6 bays of 0.5 m, 0.4 m x 0.4 m section), 28 nodes
      ``N1``-``N28`` (section ``s`` holds ``N{4s+1}``-``N{4s+4}``), bars: longerons
      (25 x 1.5 mm tubes), battens (20 x 1.5), one diagonal per face and per section
      (15 x 1 mm);
    - three plates (``A`` over section 0, ``B`` over section 6, ``C`` over section 3),
      each on a flexible post (two beam elements, 30 x 2 mm tubes 0.4 m high for A and B,
      50 x 2 mm, 0.3 m for C) standing on a spider of four beams tied to the top truss
      corners; a plate is a centre node with 40% of its mass and a small inertia and
      four corner nodes (``+-0.15`` m, ``+-0.13`` m for C) on stiff beams carrying the
      rest: 6 kg for A and B, 3 kg for C.  Nodes ``N29``-``N35`` (A), ``N36``-``N42``
      (B), ``N43``-``N49`` (C): post base, post middle, plate centre, 4 corners;
    - suspension: 12 soft springs (800 N/m) to ground in x, y, z at the bottom corners
      of the end sections;
    - damping: Rayleigh ``C = 0.1 M + 4e-5 K`` (about 0.1-0.6 % in the band) plus three
      discrete dashpots (non-proportional damping): a torsional damper (1.5 N m s/rad)
      between plate A and its post base, a 150 N s/m damper across a truss bay
      (``N9.x``-``N14.x``) and a 5 N s/m damper between plate C and its post base (y).

    246 DOFs.  The test band is :data:`TESTBED_BAND` = 8-60 Hz; the 6 shakers
    (:data:`SHAKERS`) each have a collocated sensor and there are 25 other sensors
    (:data:`SENSORS` lists all 31, collocated ones first).

    Modes (undamped, Hz; computed, and checked against this table by the tests):

    ====  =========  ==========================================================
    mode  frequency  description
    ====  =========  ==========================================================
    1-6   0.45-3.53  suspension (rigid body on the soft springs), below band
    7     9.52       plates A and B rocking about y, opposed (no truss motion)
    8     12.66      plates A, B, C rocking about y with truss bending
    9     15.64      plates A and B torsion (rz), in phase   | close pair strongly
    10    16.01      plates A and B torsion (rz), opposed    | coupled by the A damper
    11    18.15      plates A and B rocking about x, opposed, truss torsion
    12    18.63      plate C rocking about x with plates A and B
    13    27.60      plate C rocking about y
    14    43.83      plates rocking about x with truss lateral bending
    15    48.42      plates A, B, C rocking about y (second family)
    16    52.90      plates A, B, C rocking about y (second family, opposed)
    17    54.73      plate C torsion (rz): local mode (96% of kinetic energy on C)
    18    56.40      plates A, B rocking about y with truss vertical bending
    19    62.98      first mode above the band
    ====  =========  ==========================================================

    In the damped model, modes 9 and 10 have projected damping
    ``Gamma_12 ~ -2.8 rad/s`` for ``Gamma_11 ~ 3.0``, ``Gamma_22 ~ 3.7`` and a frequency
    separation ``2 (w_2 - w_1) ~ 4.7 rad/s``: they are strongly coupled by damping.

    The keyword arguments build a *deliberately wrong* model of the same article, the
    starting point of FE updates (chapter IV): the structure tested by
    :func:`testbed_frf` is always the nominal one.  The plate/post links are the six post
    beams (sections ``post_AB`` and ``post_C``, ``fe.members(section=...)``); the plate
    masses are the lumped masses and inertias of the plate centre and corner nodes
    (``N31``-``N35``, ``N38``-``N42``, ``N45``-``N49``); the Rayleigh damping follows
    the scaled ``M`` and ``K``.

    Parameters
    ----------
    link_stiffness : float
        Factor on the stiffness (Young's modulus) of the post beams, their mass unchanged
        (in ``[1e-6, 1e6]``).
    plate_mass : float
        Factor on the lumped plate masses and inertias (in ``[1e-6, 1e6]``).

    Returns
    -------
    FEModel
        The (cached, immutable) model with node coordinates, element pairs and its
        :class:`~sdctrl.fe._groups.Assembly` record (element groups, lumped masses).

    Examples
    --------
    >>> import sdctrl as sd
    >>> fe = sd.testbed()
    >>> fe.N
    246
    >>> wrong = sd.testbed(link_stiffness=0.75, plate_mass=1.25)   # links -25%, plates +25%
    >>> round(float(wrong.modes(7)[0][6]), 2)          # 9.52 Hz on the nominal model
    7.95
    """
    return _cached(_factor(link_stiffness, "link_stiffness"), _factor(plate_mass, "plate_mass"))


@lru_cache(maxsize=1)
def _modal():
    """The modal model :func:`testbed_frf` computes the test from, on one BLAS thread: cached,
    so computed under whatever thread limit its first caller had, and the solvers' results
    differ by ~1e-9 between thread counts (noise-free data identified differently)."""
    from sdctrl._lib.threads import single_thread

    with single_thread():
        fe = _cached()
        # modes up to ~5x the band top, plus static correction modes for the shakers
        f, _ = fe.modes(min(fe.N, 60))
        n = int(np.searchsorted(f, 5 * TESTBED_BAND[1]))
        return fe.normal_mode_model(list(SHAKERS), list(SENSORS), max(n, 16), static=True,
                                    static_damping="projected")


def testbed_frf(quantity: str = "acceleration", band=TESTBED_BAND, n: int = 1000,
                noise: float = 0.0, seed: int | None = None):
    """Simulated test of :func:`testbed`: 31 sensors x 6 shakers on a linear grid.

    The response is computed from the FE model's modes up to five times the band top,
    with the full projected (non-proportional) damping and static correction modes for
    the shakers (2.21)-(2.22) (damping projected too); it agrees with the exact FE
    response (:meth:`FEModel.frf`) to within 0.3% of each channel's largest value in
    the default band (the rest is the stiffness-proportional damping of the truncated
    modes).

    Parameters
    ----------
    quantity : {"displacement", "velocity", "acceleration"}
        Measured quantity per unit force.
    band : (float, float)
        First and last frequency lines in Hz.
    n : int
        Number of frequency lines (linearly spaced), ``2 <= n <= MAX_LINES``.
    noise : float
        Relative measurement noise: each line gets ``H * (1 + noise * e)`` with ``e``
        complex standard normal (independent real and imaginary parts of variance
        1/2); 0 gives the exact model response.
    seed : int, optional
        Seed of the noise generator (results are deterministic given a seed).

    Returns
    -------
    FRF
        Sensors and actuators labelled by FE DOF labels (``"N30.z"``), collocated pairs
        set (shaker ``i`` with sensor ``i``).
    """
    from sdctrl.data._frf import FRF

    q = check_quantity(quantity, "quantity")
    lo, hi = check_band(band, "band")
    if lo <= 0:
        raise ValueError(f"band must start above 0 Hz, got ({lo:g}, {hi:g})")
    n = check_int(n, "n", minimum=2, maximum=MAX_LINES)
    noise = check_scalar(noise, "noise", nonneg=True)
    seed = check_seed(seed, "seed")
    freq = np.linspace(lo, hi, n)
    try:
        H = _modal().frf(freq, q).H
    except ValueError as exc:           # the only input left to blame is the band
        raise ValueError(f"band ({lo:g}, {hi:g}) Hz: {exc}") from None
    H = relative_noise(H, noise, seed)
    col = [(i, i) for i in range(len(SHAKERS))]
    return FRF(freq, H, quantity=q, sensors=SENSORS, actuators=SHAKERS, collocated=col)


