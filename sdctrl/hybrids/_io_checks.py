"""The test's sensors and inputs placed on the FE DOFs of a hybrid model (checked).

:func:`sdctrl.hybrid` (5.1) takes the test's sensor shapes ``sensor_c`` and, optionally, its
input shapes ``actuator_b`` on the FE DOFs (arrays or DOF labels); :func:`placed_io` gives them
as arrays, with one row (column) per sensor (input) of the identified model and entries of a
usable scale; :func:`measured_w2` checks the identified model and the pairing options,
:func:`placed_loads` places its inputs and :func:`warn_left_out` warns about the poles
left out of it.
"""

from __future__ import annotations

import warnings

import numpy as np

from sdctrl._lib.validate import check_scalar
from sdctrl.fe._fe_checks import shapes_on_dofs

__all__ = ["measured_w2", "placed_io", "placed_loads", "warn_left_out"]


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


def warn_left_out(nm) -> None:
    """Poles of the identified model left out of ``nm`` (``normal_modes(cm, modes=...)``)."""
    left = None if nm.properness is None else nm.properness.poles_left_out_hz
    hz = np.atleast_1d(np.asarray([] if left is None else left, float))
    if hz.size:
        warnings.warn(f"hybrid: nm was built from a subset of the identified poles (the pole(s) "
                      f"at {np.round(hz, 2).tolist()} Hz left out): their contribution near the "
                      "band edges is lost and only the FE model stands for them; build nm "
                      "with sd.normal_modes(cm) (its default keeps the poles outside the band "
                      "as residual dynamics) and let the FE modes stand for them",
                      stacklevel=3)


def placed_loads(fe, nm, b):
    """Physical test inputs: ``actuator_b``, point forces at ``nm.actuators`` labels, or
    None, and whether the appended modes stay unexcited."""
    if b is not None:
        return b, False
    if nm.na and set(nm.actuators) <= set(fe.dofs):
        return fe.point(list(nm.actuators)), False
    return None, bool(nm.na)


def measured_w2(nm, fmax, mac_min):
    """Measured ``omega^2`` (rad/s)^2 of ``nm`` (normal modes), ``fmax`` Hz and ``mac_min``."""
    Om = nm.Omega
    if np.abs(Om - np.diag(np.diag(Om))).max() > 1e-8 * max(np.abs(Om).max(), 1e-300):
        raise ValueError("nm.Omega must be diagonal (normal modes): re-diagonalise with "
                         "nm.modified() first")
    w2_id = np.clip(np.diag(Om), 0, None)
    if nm.n == 0:
        raise ValueError("nm must hold at least one measured mode")
    fmax = check_scalar(fmax, "fmax", positive=True, optional=True)
    if fmax is None:
        fmax = 5.0 * float((np.sqrt(w2_id) / (2 * np.pi)).max())
    mac_min = check_scalar(mac_min, "mac_min", lo=0.0, hi=1.0)
    return w2_id, fmax, mac_min
