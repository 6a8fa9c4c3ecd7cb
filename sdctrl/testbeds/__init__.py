"""The built-in test structures and their simulated vibration tests.

- ``_truss``: the suspended truss carrying three plates (246 DOFs), :func:`testbed` and its
  simulated test :func:`testbed_frf`.
"""

from sdctrl.testbeds._truss import SENSORS, SHAKERS, TESTBED_BAND, testbed, testbed_frf

__all__ = ["SENSORS", "SHAKERS", "TESTBED_BAND", "testbed", "testbed_frf"]
