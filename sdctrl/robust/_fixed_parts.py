"""The certain parts of an uncertain model's plant (5.5): what the uncertainty does not touch.

Uncertainty acts on ``Omega``, ``Gamma``, ``cphi``, ``phib`` (and, when bounded, on the
residual dynamics, :mod:`._residual_uncertainty`).  The residual flexibility ``E`` (a
feedthrough), unbounded residual dynamics (3.26)-(3.33) and the correction modes of the
residual mass ``F`` -- critically damped a decade below the band, ``F (s + 3 w_f) /
(s + w_f)^3`` (2.19)-(2.20), :func:`sdctrl._lib.statespace.mass_correction` -- are realised
as the model's own :meth:`to_statespace` realises them, so that the uncertain model's nominal
StateSpace is the model's own.

Internal module: the functions trust their inputs.
"""

from __future__ import annotations

import numpy as np

from sdctrl._lib.statespace import default_omega_f, mass_correction
from sdctrl._lib.validate import readonly

__all__ = ["append_block", "mass_block"]


def append_block(A, B, C, block):
    """``(A, B, C)`` with the states of ``block = (Ae, Be, Ce)`` appended (block diagonal)."""
    Ae, Be, Ce = block[:3]
    A = np.block([[A, np.zeros((A.shape[0], Ae.shape[1]))],
                  [np.zeros((Ae.shape[0], A.shape[1])), Ae]])
    return A, np.vstack([B, Be]), np.hstack([C, Ce])


def mass_block(model):
    """The correction modes of the residual mass ``F`` (2.23) of ``model``, certain.

    The block ``model.to_statespace()`` (displacement) appends for ``F`` after its modes and
    residual dynamics: :func:`sdctrl._lib.statespace.mass_correction` at the model's corner
    :func:`sdctrl._lib.statespace.default_omega_f` (critically damped, a decade
    below the band), with the same state names.

    Parameters
    ----------
    model : NormalModeModel
        Any normal-mode model (identified, FE-derived, hybrid).

    Returns
    -------
    tuple or None
        ``(A, B, C, state names)`` of the ``3 na`` states ``zr``, ``dzr``, ``ddzr``, read-only,
        or None when the model has no ``F``.
    """
    if getattr(model, "F", None) is None:
        return None
    A, B, C, _ = mass_correction(np.asarray(model.F, float), default_omega_f(model))
    na = B.shape[1]
    names = tuple(f"{x}{j}" for x in ("zr", "dzr", "ddzr") for j in range(na))
    return readonly(A), readonly(B), readonly(C), names
