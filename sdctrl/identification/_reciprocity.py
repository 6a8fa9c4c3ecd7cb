"""Reciprocity for :func:`~sdctrl.normal_modes`: a roving-hammer survey as its transposed test.

The reduced coordinates (3.46)-(3.47) need at least as many sensors as modes.  A roving-hammer
survey has few sensors (fixed accelerometers) and many actuators (hit points); for a
structure with symmetric mass, damping and stiffness the transfer is reciprocal,
``H(s) = H(s)^T`` for dual sensors and actuators, so the survey's transpose is a test with
many sensors.  The normal-mode model of the transposed test,
``H^T = cphi' (s^2 I + s Gamma' + Omega)^-1 phib' + E'``, is turned back exactly:
``H = phib'^T (s^2 I + s Gamma'^T + Omega)^-1 cphi'^T + E'^T``.

Internal module: the functions trust their inputs (validated by ``normal_modes``).
"""

from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np

__all__ = ["needs_transpose", "via_transpose"]


def needs_transpose(cm, n_modes: int) -> bool:
    """True when ``cm`` has fewer sensors than the ``n_modes`` to transform and more
    actuators than sensors (a roving-hammer survey).

    Parameters
    ----------
    cm : ComplexModeModel
        The identified model.
    n_modes : int
        Number of modes to transform.

    Returns
    -------
    bool
    """
    return cm.ns < n_modes and cm.na > cm.ns


def via_transpose(transform, cm, pairs, **options):
    """Normal modes of ``cm`` computed on its transposed test and turned back, with a warning.

    Parameters
    ----------
    transform : callable
        ``transform(cm_t, pairs_t, **options) -> NormalModeModel`` (:func:`normal_modes`).
    cm : ComplexModeModel
        The identified model (few sensors, many actuators).
    pairs : tuple of (int, int)
        Its collocated (sensor, actuator) index pairs.
    **options
        Passed to ``transform``.

    Returns
    -------
    NormalModeModel
        In the caller's orientation: ``cm``'s sensors and actuators.
    """
    warnings.warn(f"normal_modes: {cm.ns} sensor(s) for {cm.n} modes and {cm.na} actuators (a "
                  "roving-hammer survey): the normal modes are computed on the transposed "
                  "test (reciprocity, FRF.transpose) and returned in the test's orientation",
                  RuntimeWarning, stacklevel=3)
    pairs_t = tuple((a, s) for s, a in pairs)
    cm_t = replace(cm, residues=np.swapaxes(cm.residues, 1, 2), E=np.asarray(cm.E).T,
                   F=np.asarray(cm.F).T, sensors=cm.actuators, actuators=cm.sensors,
                   collocated=pairs_t)
    nm = transform(cm_t, pairs_t, **options)
    return replace(nm, Gamma=np.asarray(nm.Gamma).T, cphi=np.asarray(nm.phib).T,
                   phib=np.asarray(nm.cphi).T, E=None if nm.E is None else np.asarray(nm.E).T,
                   F=None if nm.F is None else np.asarray(nm.F).T,
                   sensors=nm.actuators, actuators=nm.sensors)
