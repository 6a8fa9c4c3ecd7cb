"""The test's sensors and inputs placed on the FE DOFs of a hybrid model (checked).

:func:`sdctrl.hybrid` (5.1) takes the test's sensor shapes ``sensor_c`` and, optionally, its
input shapes ``actuator_b`` on the FE DOFs (arrays or DOF labels); :func:`placed_io` gives them
as arrays, with one row (column) per sensor (input) of the identified model and entries of a
usable scale.
"""

from __future__ import annotations

import numpy as np

from sdctrl.fe._fe_checks import shapes_on_dofs

__all__ = ["placed_io"]


def placed_io(fe, nm, sensor_c, actuator_b):
    """Test sensors ``c`` (ns, N) and, when given, actuators ``b`` (N, na) on the FE DOFs."""
    N = fe.N
    c, _ = shapes_on_dofs(sensor_c, N, fe.dofs, "sensor_c", output=True)
    if c.shape[0] != nm.ns:
        raise ValueError(f"sensor_c must have one row per sensor of nm (ns={nm.ns}), got "
                         f"{c.shape[0]}")
    _check_io_scale(c, "sensor_c")
    b = None
    if actuator_b is not None:
        b, _ = shapes_on_dofs(actuator_b, N, fe.dofs, "actuator_b")
        if b.shape[1] != nm.na:
            raise ValueError(f"actuator_b must have one column per input of nm (na={nm.na}), "
                             f"got {b.shape[1]}")
        _check_io_scale(b.T, "actuator_b")
    return c, b


def _check_io_scale(x, name):
    """Each sensor (row) or input (column) shape must be non-zero and of a usable scale:
    the expansion fits ``c phi`` in a scale-free way, but zero, overflowing or subnormal
    shapes make it meaningless."""
    if not np.all(np.isfinite(x)):
        raise ValueError(f"{name} must contain only finite values (no NaN or inf)")
    nrm = np.linalg.norm(x, axis=1)
    big = np.abs(x).max() if x.size else 0.0
    if np.any(nrm == 0) or big > 1e100 or np.any(nrm < 1e-100):
        raise ValueError(f"{name}: every shape must be non-zero with entries of a usable "
                         f"scale (norms between 1e-100 and 1e100), got norms in "
                         f"[{nrm.min() if nrm.size else 0:.3g}, {big:.3g}]")
