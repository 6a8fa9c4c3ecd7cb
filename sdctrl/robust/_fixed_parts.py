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

import functools

import numpy as np

from sdctrl._lib.validate import readonly

__all__ = ["append_block", "mass_block"]


def append_block(A, B, C, block):
    """``(A, B, C)`` with the states of ``block = (Ae, Be, Ce)`` appended (block diagonal)."""
    Ae, Be, Ce = block[:3]
    A = np.block([[A, np.zeros((A.shape[0], Ae.shape[1]))],
                  [np.zeros((Ae.shape[0], A.shape[1])), Ae]])
    return A, np.vstack([B, Be]), np.hstack([C, Ce])


@functools.lru_cache(maxsize=16)
def mass_block(model):
    """The correction modes of the residual mass ``F`` (2.23) of ``model``, certain.

    Taken from the model's own realisation once per model (models are immutable; the cache
    holds a few, by identity), so that every perturbed model of an uncertain model appends
    the same block without realising the model again.

    Parameters
    ----------
    model : NormalModeModel
        Any normal-mode model (identified, FE-derived, hybrid).

    Returns
    -------
    tuple or None
        ``(A, B, C, state names)`` of the states ``model.to_statespace()`` (displacement)
        appends for ``F`` after its modes and residual dynamics (``3 na`` states ``zr``,
        ``dzr``, ``ddzr``: critically damped a decade below the band), read-only, or None
        when the model has no ``F``.
    """
    if getattr(model, "F", None) is None:
        return None
    own = model.to_statespace()
    res = getattr(model, "residual", None)
    k = 2 * model.n + (len(res.realisation(model.sensors, model.actuators)[3])
                       if res is not None and res.m else 0)
    A, B, C = (np.asarray(X, float) for X in (own.A, own.B, own.C))
    if np.any(A[:k, k:]) or np.any(A[k:, :k]):
        raise RuntimeError("mass_block: the model's realisation does not end with a "
                           "decoupled block of F's correction modes")
    return (readonly(A[k:, k:].copy()), readonly(B[k:].copy()), readonly(C[:, k:].copy()),
            tuple(own.state_labels[k:]))
