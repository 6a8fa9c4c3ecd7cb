"""A scalable member of the family of test structures: a plate-like lattice of bars.

:func:`lattice` builds a cantilevered two-layer space truss (a lattice plate) of about the
requested number of DOFs -- 10^3, 10^4, 10^5 or more -- with its deliberately wrong FE
model, the two parameters that correct it, 24 accelerometers and 3 shakers, and a simulated
test, in the :class:`~sdctrl.testbeds.TestStructure` pattern of :func:`family`.  It is the
structure that takes the whole chain (FE modes, static correction, update, hybrid,
placement, diagnosis) to industrial sizes (``benchmarks/bench_chain.py``).

Everything that depends on the size follows from the structure itself: the band holds its
first eight modes (from the true model's own modes), Rayleigh damping gives about 1% at the
band edges, sensors and shakers sit at fixed fractions of the plate.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property, lru_cache

import numpy as np

from sdctrl._lib.validate import check_band, check_int, check_quantity, check_scalar, check_seed
from sdctrl.testbeds._measurement_noise import relative_noise
from sdctrl.testbeds._family import TestStructure

__all__ = ["LatticeStructure", "lattice"]

#: bar offsets (i, j, k) from each node: edges, one diagonal per face, a body diagonal
_OFFSETS = ((1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 0), (1, 0, 1), (0, 1, 1), (1, 1, 1))
#: modes in the test band, and modes of the simulated test's modal synthesis
IN_BAND, TEST_MODES = 8, 40
#: bay length and layer distance (m), steel
_D, _H = 0.1, 0.08
_STEEL = {"E": 210e9, "rho": 7800.0}


def _grid(dofs: int) -> tuple[int, int]:
    """``(nx, ny)`` of a 2:1 two-layer plate with about ``dofs`` DOFs (3 per free node)."""
    ny = max(3, int(round(np.sqrt(dofs / 12.0))))
    return 2 * ny + 1, ny


def _geometry(nx: int, ny: int, seed: int):
    """Node names, coordinates (jittered: no symmetry) and bars ``(a, b, section)``."""
    rng = np.random.default_rng(seed)
    ii, jj, kk = np.meshgrid(np.arange(nx), np.arange(ny), np.arange(2), indexing="ij")
    xyz = np.stack([ii * _D, jj * _D, kk * _H], axis=-1).astype(float)
    xyz += 0.03 * _D * rng.uniform(-1, 1, xyz.shape)
    names = np.array([f"L{i}_{j}_{k}" for i, j, k in zip(ii.ravel(), jj.ravel(), kk.ravel())])
    names = names.reshape(nx, ny, 2)
    bars = []
    for di, dj, dk in _OFFSETS:
        a = names[:nx - di, :ny - dj, :2 - dk].ravel()
        b = names[di:, dj:, dk:].ravel()
        ia = ii[:nx - di, :ny - dj, :2 - dk].ravel()
        cls = rng.integers(0, 4, a.size)
        for x, y, i0, c in zip(a, b, ia, cls):
            bars.append((x, y, "root" if i0 == 0 else f"s{c}"))
    return names, xyz, bars


def _build(nx, ny, seed, root_stiffness=1.0, tip_mass=1.0, rayleigh=None):
    """Assembled lattice (``rayleigh=None``: undamped, for the band and the damping rule)."""
    from sdctrl.fe import assemble

    names, xyz, bars = _geometry(nx, ny, seed)
    nodes = dict(zip(names.ravel(), map(tuple, xyz.reshape(-1, 3))))
    rng = np.random.default_rng(seed + 1)
    mass = 0.2 * rng.uniform(0.5, 1.5, names.size)
    tips = set(names[-1].ravel())
    els = [("bar", a, b, "st_root" if s == "root" else "st", s) for a, b, s in bars]
    els += [("mass", n, m * (tip_mass if n in tips else 1.0))
            for n, m in zip(names.ravel(), mass)]
    if rayleigh is not None:              # two dashpots: non-proportional damping
        els += [("dashpot", f"{names[-1, 0, 1]}.z", f"{names[-1, -1, 1]}.z", 2.0),
                ("dashpot", f"{names[nx // 2, 0, 1]}.y", f"{names[nx // 2, -1, 1]}.y", 5.0)]
    areas = 1e-4 * np.array([0.8, 1.0, 1.2, 1.5])
    sections = {"root": {"A": 1e-4}, **{f"s{c}": {"A": a} for c, a in enumerate(areas)}}
    materials = {"st": dict(_STEEL), "st_root": {**_STEEL, "E": _STEEL["E"] * root_stiffness}}
    return assemble(nodes, els, materials, sections, bc=list(names[0].ravel()),
                    rayleigh=rayleigh, lumped=True)


def _io(nx: int, ny: int) -> tuple[tuple, tuple]:
    """3 shakers (z, top layer) and 24 sensors, the first three collocated."""
    top = lambda i, j: f"L{i}_{j}_1.z"                      # noqa: E731
    shakers = (top(nx - 1, 0), top(nx // 2, ny - 1), top((3 * nx) // 4, ny // 2))
    xs = np.linspace(nx // 6, nx - 1, 6).round().astype(int)
    ys = np.linspace(0, ny - 1, 4).round().astype(int)
    others = [top(i, j) for i in xs for j in ys]
    sensors = shakers + tuple(o for o in others if o not in shakers)
    return shakers, sensors[:24]


def _root_parameters(fe):
    tip = _tip_prefix(fe)                  # once: per node it made this quadratic in N
    return [fe.stiffness_parameter("root", section="root"),
            fe.mass_parameter("tips", [n for n in fe.nodes if n.startswith(tip)])]


def _tip_prefix(fe) -> str:
    nx = 1 + max(int(n[1:].split("_")[0]) for n in fe.nodes)
    return f"L{nx - 1}_"


@dataclass(frozen=True, eq=False, repr=False)
class LatticeStructure(TestStructure):
    """The scalable lattice plate (see :func:`lattice`); a :class:`TestStructure`.

    Parameters
    ----------
    nx, ny : int
        Bays along x (from the clamped edge) and y; two layers of nodes.
    seed : int
        Seed of the jitter, masses and bar sections.
    rayleigh : (float, float)
        Rayleigh damping ``alpha`` (1/s), ``beta`` (s) of both models.
    """

    nx: int = 0
    ny: int = 0
    seed: int = 0
    rayleigh: tuple = (0.0, 0.0)

    @cached_property
    def _fe(self):
        return self.builder(self.nx, self.ny, self.seed, rayleigh=self.rayleigh)

    @cached_property
    def _wrong(self):
        return self.builder(self.nx, self.ny, self.seed, rayleigh=self.rayleigh,
                            **self.factors)

    def fe(self):
        """The true structure's FE model (cached, immutable).

        Returns
        -------
        FEModel
        """
        return self._fe

    def wrong(self):
        """The deliberately wrong FE model: root bars 20% too soft, tip masses 25% heavy.

        Returns
        -------
        FEModel
        """
        return self._wrong

    def frf(self, quantity: str = "acceleration", n: int = 600, noise: float = 0.0,
            seed: int | None = None, band=None):
        """The simulated test: modal synthesis of the true structure, optional noise.

        The response is that of the true FE model's first :data:`TEST_MODES` modes with
        their projected (non-proportional) damping plus the exact static correction of the
        rest as the feedthrough ``E`` (2.18): exact in the band up to the dynamic part of
        the truncated modes (the band holds the first :data:`IN_BAND`).

        Parameters
        ----------
        quantity : {"displacement", "velocity", "acceleration"}
            Measured quantity per unit force.
        n : int
            Number of frequency lines (linear grid over the band).
        noise : float
            Relative noise: each line gets ``H (1 + noise e)``, ``e`` complex standard normal.
        seed : int, optional
            Noise seed.
        band : (float, float), optional
            Another band (Hz) than the structure's own.

        Returns
        -------
        FRF
            Labels are FE DOF labels; collocated pairs set.
        """
        from sdctrl.data import FRF

        q = check_quantity(quantity, "quantity")
        lo, hi = check_band(self.band if band is None else band, "band")
        n = check_int(n, "n", minimum=2, maximum=20_000)
        noise = check_scalar(noise, "noise", nonneg=True)
        seed = check_seed(seed, "seed")
        H = self._synthesis.frf(np.linspace(lo, hi, n), q).H
        H = relative_noise(H, noise, seed)
        return FRF(np.linspace(lo, hi, n), H, quantity=q, sensors=self.sensors,
                   actuators=self.shakers, collocated=[(i, i) for i in range(len(self.shakers))])

    @cached_property
    def _synthesis(self):
        return self.fe().normal_mode_model(list(self.shakers), list(self.sensors),
                                           min(TEST_MODES, self.fe().N - 1), static="E")


@lru_cache(maxsize=4)
def _lattice(nx: int, ny: int, seed: int) -> LatticeStructure:
    free = _build(nx, ny, seed)
    f = free.modes(IN_BAND + 1)[0]
    lo, hi = 0.6 * f[0], 0.5 * (f[IN_BAND - 1] + f[IN_BAND])
    # Rayleigh damping of 1% at both band edges (rad/s)
    w1, w2 = 2 * np.pi * lo, 2 * np.pi * hi
    z = 0.01
    alpha, beta = 2 * z * w1 * w2 / (w1 + w2), 2 * z / (w1 + w2)
    shakers, sensors = _io(nx, ny)
    return LatticeStructure(
        name=f"lattice_{nx}x{ny}", band=(float(lo), float(hi)), sensors=sensors,
        shakers=shakers, factors={"root_stiffness": 0.8, "tip_mass": 1.25},
        truth={"root": 0.25, "tips": -0.2}, builder=_build,
        parameter_maker=_root_parameters, nx=nx, ny=ny, seed=seed,
        rayleigh=(float(alpha), float(beta)),
        description=(f"a cantilevered two-layer lattice plate of bars, {nx} x {ny} bays, "
                     f"{free.N} DOFs, {len(free.elements)} bars"))


def lattice(dofs: int = 1000, seed: int = 0) -> LatticeStructure:
    """The scalable member of the family: a cantilevered lattice plate of about ``dofs`` DOFs.

    Two layers of ``nx x ny`` nodes (``nx = 2 ny + 1``, 0.1 m bays, 0.08 m apart, jittered by
    3% so that no symmetry decouples a sensor from a shaker), joined by steel bars along
    the edges, one diagonal of each face and a body diagonal of each cell (four random
    sections), random lumped node masses, clamped along ``x = 0``.  Rayleigh damping of 1%
    at the band edges plus two dashpots (non-proportional damping).  The band holds the
    first eight modes.  The wrong FE model has the first bay's bars (section ``root``) 20%
    too soft and the free edge's masses 25% too heavy; parameters ``root`` (stiffness of
    section ``root``) and ``tips`` (lumped masses of the free edge) correct it at
    ``truth = {"root": 0.25, "tips": -0.2}``.  Three shakers (z, top layer: a free corner,
    the middle of a side, three quarters along the centre line) and 24 accelerometers (z,
    top layer), the first three collocated with the shakers.

    Parameters
    ----------
    dofs : int
        Approximate number of DOFs (at least 200): 10^3, 10^4, 10^5 ...
    seed : int
        Seed of the jitter, the masses and the bar sections.

    Returns
    -------
    LatticeStructure
        A :class:`TestStructure` (``fe()``, ``wrong()``, ``parameters()``, ``frf()``); not
        one of :func:`family`'s five default members.

    Examples
    --------
    >>> import sdctrl as sd
    >>> s = sd.testbeds.lattice(1000)
    >>> s.fe().N, len(s.sensors), len(s.shakers)
    (972, 24, 3)
    """
    dofs = check_int(dofs, "dofs", minimum=200, maximum=10_000_000)
    seed = check_seed(seed, "seed")
    nx, ny = _grid(dofs)
    return _lattice(nx, ny, 0 if seed is None else seed)
