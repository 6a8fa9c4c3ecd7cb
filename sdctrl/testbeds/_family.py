"""The family of test structures: each with its FE model, a deliberately wrong FE model, the
parameters that correct it and a simulated test.

The built-in truss (:func:`sdctrl.testbed`) is one member; the others change what the truss
has by luck -- where its band is cut, how its rigid-body modes sit, how close its modes are:

========== ================================================================================
name        what it tests
========== ================================================================================
truss       the built-in truss, 8-60 Hz (suspension modes far below, a damping-coupled
            close pair, a local mode)
truss_high  the same structure and test over 20-60 Hz: six suspension/plate modes between
            9.5 and 18.6 Hz just below the band
ladder      a free-free ladder frame on a soft suspension (1-2.5 Hz) tested over 12-90 Hz:
            two flexible modes just below the band (8.0, 10.0 Hz), one just above (98 Hz)
plate       a cantilevered, slightly twisted grid of beams tested over 20-62 Hz: modes 6%
            below (18.8 Hz) and 4% above (64.6 Hz) the band edges, a pair at 26.3/28.3 Hz
cluster     a hub with four mistuned blades (four modes within 1.4% near 10.2 Hz) and a
            light local resonator (37 Hz), tested over 6-45 Hz
========== ================================================================================

Accuracy tests run over the whole family (``for name in family()``), and each member's
figures are locked by a test, so that no change trades one structure for another.

A sixth, scalable member is built on demand rather than listed by :func:`family`:
:func:`sdctrl.testbeds.lattice` (``lattice(dofs)``, a cantilevered lattice plate of bars of
10^3 to 10^5+ DOFs, :mod:`sdctrl.testbeds._scalable`) takes the whole chain to industrial
sizes with the same :class:`TestStructure` interface.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from sdctrl._lib.validate import check_band, check_int, check_quantity, check_scalar, check_seed
from sdctrl.testbeds._measurement_noise import relative_noise
from sdctrl.testbeds import _structures as st
from sdctrl.testbeds._truss import SENSORS, SHAKERS, testbed, testbed_frf

__all__ = ["TestStructure", "family", "structure"]


@dataclass(frozen=True, eq=False)
class TestStructure:
    """One member of the family of test structures.

    Parameters
    ----------
    name : str
        Its name in :func:`family`.
    description : str
        What it tests.
    band : (float, float)
        Test band (Hz).
    sensors, shakers : tuple of str
        DOF labels of the test's sensors and shakers; shaker ``i`` has a collocated sensor
        ``sensors[i]``.
    factors : dict
        Keyword arguments of the builder that make the deliberately wrong FE model.
    truth : dict
        Parameter name -> the value ``p`` (4.15) that corrects the wrong model exactly.
    builder : callable
        ``builder(**factors) -> FEModel`` (factors 1: the true structure).
    parameter_maker : callable
        ``parameter_maker(fe) -> list of Parameter`` in the order of :attr:`truth`.
    """

    __test__ = False                    # not a pytest test class despite its name

    name: str
    description: str
    band: tuple
    sensors: tuple
    shakers: tuple
    factors: dict
    truth: dict
    builder: Callable
    parameter_maker: Callable

    def __repr__(self) -> str:
        return (f"TestStructure({self.name!r}, {self.band[0]:g}-{self.band[1]:g} Hz, "
                f"{len(self.sensors)} sensors x {len(self.shakers)} shakers)")

    def fe(self):
        """The true structure's FE model (cached, immutable).

        Returns
        -------
        FEModel
        """
        return _built(self.builder, ())

    def wrong(self):
        """The deliberately wrong FE model (its errors in :attr:`factors`).

        Returns
        -------
        FEModel
        """
        return _built(self.builder, tuple(sorted(self.factors.items())))

    def parameters(self, fe=None) -> list:
        """The update parameters (4.15) built on ``fe`` (default: the wrong model).

        Parameters
        ----------
        fe : FEModel, optional
            The model they correct.

        Returns
        -------
        list of Parameter
            In the order of :attr:`truth`.
        """
        return self.parameter_maker(self.wrong() if fe is None else fe)

    def frf(self, quantity: str = "acceleration", n: int = 600, noise: float = 0.0,
            seed: int | None = None, band=None):
        """The simulated test: exact FRFs of the true structure, optional noise.

        Parameters
        ----------
        quantity : {"displacement", "velocity", "acceleration"}
            Measured quantity per unit force.
        n : int
            Number of frequency lines (linear grid over the band).
        noise : float
            Relative noise: each line gets ``H (1 + noise e)``, ``e`` complex standard
            normal.
        seed : int, optional
            Noise seed.
        band : (float, float), optional
            Another band (Hz) than the structure's own.

        Returns
        -------
        FRF
            Labels are FE DOF labels; collocated pairs set.
        """
        q = check_quantity(quantity, "quantity")
        lo, hi = check_band(self.band if band is None else band, "band")
        n = check_int(n, "n", minimum=2, maximum=20_000)
        noise = check_scalar(noise, "noise", nonneg=True)
        seed = check_seed(seed, "seed")
        if self.builder is _truss_builder:
            return testbed_frf(q, (lo, hi), n, noise, seed)
        frf = _exact(self, q, lo, hi, n)
        if noise > 0:
            from sdctrl.data import FRF

            frf = FRF(frf.freq, relative_noise(frf.H, noise, seed), quantity=q,
                      sensors=frf.sensors, actuators=frf.actuators, collocated=frf.collocated)
        return frf


# ----------------------------------------------------------------------------------------
# parameters of each member (module-level functions: the records pickle)
# ----------------------------------------------------------------------------------------
def _truss_parameters(fe):
    plates = [f"N{k}" for k in (*range(31, 36), *range(38, 43), *range(45, 50))]
    return [fe.stiffness_parameter("links", section=["post_AB", "post_C"]),
            fe.mass_parameter("plates", plates)]


def _ladder_parameters(fe):
    return [fe.stiffness_parameter("rungs", section="rung"),
            fe.mass_parameter("payloads", ["L3", "R3", "L7", "R7"])]


def _plate_parameters(fe):
    return [fe.stiffness_parameter("root", section="root"),
            fe.mass_parameter("tips", ["G4_0", "G4_3"])]


def _cluster_parameters(fe):
    return [fe.stiffness_parameter("hub", section="hub"),
            fe.mass_parameter("blades", ["T1", "T2", "T3", "T4"])]


def _truss_builder(link_stiffness=1.0, plate_mass=1.0):
    return testbed(link_stiffness=link_stiffness, plate_mass=plate_mass)


def _ladder_io():
    shakers = ("L3.z", "R6.z", "R8.y")
    others = [f"{s}{i}.z" for i in range(9) for s in "LR"]
    others += ["L0.y", "R4.y", "L8.y", "L4.x"]
    return shakers, shakers + tuple(o for o in others if o not in shakers)


def _plate_io():
    shakers = ("G4_0.z", "G2_3.z")
    others = [f"G{i}_{j}.z" for i in range(1, 5) for j in range(4)]
    others += ["G4_1.y", "G3_2.x"]
    return shakers, shakers + tuple(o for o in others if o not in shakers)


def _cluster_io():
    shakers = ("H3.y", "T1.y")
    others = [f"T{k}.{d}" for k in range(1, 5) for d in "xy"]
    others += [f"B{k}_2.y" for k in range(1, 5)]
    others += [f"H{i}.{d}" for i in (1, 2, 4, 5) for d in "yz"] + ["R.y"]
    return shakers, shakers + tuple(o for o in others if o not in shakers)


def _members() -> dict:
    sh, se = _ladder_io()
    ladder = dict(band=(12.0, 90.0), sensors=se, shakers=sh, builder=st.ladder,
                  factors={"rung_stiffness": 0.8, "payload_mass": 1.25},
                  truth={"rungs": 0.25, "payloads": -0.2}, parameter_maker=_ladder_parameters)
    sh, se = _plate_io()
    plate = dict(band=(20.0, 62.0), sensors=se, shakers=sh, builder=st.plate_grid,
                 factors={"edge_stiffness": 1.3, "tip_mass": 0.8},
                 truth={"root": 1 / 1.3 - 1, "tips": 0.25}, parameter_maker=_plate_parameters)
    sh, se = _cluster_io()
    cluster = dict(band=(6.0, 45.0), sensors=se, shakers=sh, builder=st.cluster,
                   factors={"hub_stiffness": 0.85, "blade_mass": 1.1},
                   truth={"hub": 1 / 0.85 - 1, "blades": 1 / 1.1 - 1},
                   parameter_maker=_cluster_parameters)
    truss = dict(sensors=SENSORS, shakers=SHAKERS, builder=_truss_builder,
                 factors={"link_stiffness": 0.75, "plate_mass": 1.25},
                 truth={"links": 1 / 0.75 - 1, "plates": -0.2},
                 parameter_maker=_truss_parameters)
    doc = {line.split()[0]: " ".join(line.split()[1:]) for line in _TABLE}
    out = {"truss": {**truss, "band": (8.0, 60.0)},
           "truss_high": {**truss, "band": (20.0, 60.0)},
           "ladder": ladder, "plate": plate, "cluster": cluster}
    return {k: TestStructure(k, doc[k], **v) for k, v in out.items()}


_TABLE = ("truss the built-in truss, 8-60 Hz",
          "truss_high the truss over 20-60 Hz, six modes just below the band",
          "ladder a free-free ladder frame on a soft suspension, modes just outside the band",
          "plate a cantilevered grid of beams, modes just outside both band edges",
          "cluster four mistuned blades (a dense cluster) and a local resonator")


@lru_cache(maxsize=1)
def _table() -> dict:
    return _members()


@lru_cache(maxsize=16)
def _built(builder, factors: tuple):
    """``builder(**factors)``, cached (a structure built alike is built once, in the family
    or not)."""
    return builder(**dict(factors))


@lru_cache(maxsize=8)
def _exact(s: TestStructure, q: str, lo: float, hi: float, n: int):
    fe = s.fe()
    frf = fe.frf(np.linspace(lo, hi, n), list(s.shakers), list(s.sensors), q)
    from sdctrl.data import FRF

    return FRF(frf.freq, frf.H, quantity=q, sensors=s.sensors, actuators=s.shakers,
               collocated=[(i, i) for i in range(len(s.shakers))])


def family() -> tuple[str, ...]:
    """Names of the test structures, the built-in truss first.

    Returns
    -------
    tuple of str
    """
    return tuple(_table())


def structure(name: str) -> TestStructure:
    """One test structure of the family by name.

    Parameters
    ----------
    name : str
        One of :func:`family`.

    Returns
    -------
    TestStructure

    Examples
    --------
    >>> import sdctrl as sd
    >>> s = sd.testbeds.structure("plate")
    >>> s.band, len(s.sensors), s.truth["tips"]
    ((20.0, 62.0), 18, 0.25)
    """
    if not isinstance(name, str) or name not in _table():
        raise ValueError(f"name must be one of {family()}, got {name!r}")
    return _table()[name]
