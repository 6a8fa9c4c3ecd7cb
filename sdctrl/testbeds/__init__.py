"""The built-in test structures and their simulated vibration tests: a family, not one.

- ``_truss``: the suspended truss carrying three plates (246 DOFs), :func:`testbed` and its
  simulated test :func:`testbed_frf` (the README's structure);
- ``_structures``, ``_family``: the family of test structures (:func:`family`,
  :func:`structure`): the truss over two bands, a free-free ladder frame on a soft suspension,
  a cantilevered grid with modes just outside both band edges, a hub with a dense cluster of
  blade modes and a local resonator -- each with its FE model, a deliberately wrong FE model,
  the parameters that correct it and a simulated test (:meth:`TestStructure.frf`);
- ``_roving``: simulated roving-hammer surveys of those structures (:func:`survey`: fixed
  accelerometers, many hit points, one driving point, hammer hits through
  :func:`sdctrl.impact_frf`), with the exact modes they were made from;
- ``_scalable``: the scalable member, :func:`lattice` -- a cantilevered lattice plate of bars
  of 10^3 to 10^5+ DOFs, for the whole chain at industrial sizes.
"""

from sdctrl.testbeds._family import TestStructure, family, structure
from sdctrl.testbeds._roving import Survey, survey
from sdctrl.testbeds._scalable import lattice
from sdctrl.testbeds._truss import SENSORS, SHAKERS, TESTBED_BAND, testbed, testbed_frf

__all__ = ["SENSORS", "SHAKERS", "TESTBED_BAND", "Survey", "TestStructure", "family",
           "lattice", "structure", "survey", "testbed", "testbed_frf"]
