"""State-space realisation of normal-mode models (thesis 2.15, 2.19-2.24, 3.26-3.33).

States, in order: the modes ``[p; p']`` (2.15, :func:`sdctrl._lib.statespace.second_order`),
the residual dynamics (complex modes kept as they are, 2x2 blocks 3.26-3.33), the correction
modes of ``E`` for velocity/acceleration outputs (2.19)-(2.20) and the low-frequency
correction modes of the residual mass ``F`` (critically damped a decade below the band by
default, the rigid-body form 2.24 on request).  Every kernel is in
:mod:`sdctrl._lib.statespace`; this module only assembles them.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import block_diag

from sdctrl._lib.signals import signal_names
from sdctrl._lib.statespace import (
    correction_filter,
    default_omega_f,
    mass_correction,
    modal_states,
    pole_moduli,
    second_order,
)
from sdctrl._lib.validate import (
    QUANTITY_POWER,
    check_bool,
    check_finite_result,
    check_quantity,
    check_scalar,
)

__all__ = ["default_omega_c", "default_omega_f", "to_statespace"]


def default_omega_c(model) -> float:
    """Default correction-mode cut-off (2.20): ten times the highest modal frequency (rad/s).

    ``model.omega_c`` when set; the poles of the residual dynamics count as modes.
    """
    if model.omega_c is not None:
        return model.omega_c
    w = pole_moduli(model)
    return 10.0 * (max(float(w.max()), 1e-6) if w.size else 1.0)


def to_statespace(model, quantity: str = "displacement", omega_c: float | None = None, *,
                  rigid_body: bool = False):
    """Real state-space realisation with named signals, states ``[p; p']`` first.

    Parameters
    ----------
    model : NormalModeModel
    quantity : {"displacement", "velocity", "acceleration"}
        Output quantity.
    omega_c : float, optional
        Cut-off (rad/s) of the critically damped correction mode realising ``E``
        for velocity/acceleration outputs (2.19)-(2.20); default
        :func:`default_omega_c`.  Displacement realises ``E`` exactly as a feedthrough.
    rigid_body : bool
        Realise the residual mass ``F`` exactly by rigid-body correction modes (2.24),
        double integrators with poles at 0.  Default False: stable critically damped
        correction modes ``F (s + 3 w_f) / (s + w_f)^3`` (a triple real pole per input) with
        ``w_f`` = :func:`default_omega_f` (a decade below the band), equal to ``F / s^2`` in
        the band to a relative error of ``3 (w_f / w)^2`` (3% at the lower band edge, phase
        included; :func:`sdctrl._lib.statespace.mass_correction`).

    Returns
    -------
    control.StateSpace
        Outputs named after ``model.sensors``, inputs after ``model.actuators`` followed
        by ``_u`` (``.`` replaced by ``_``): sensor ``"N3.z"`` is output ``N3_z``, actuator
        ``"N3.z"`` input ``N3_z_u``, so a collocated pair never shares a name.

    Raises
    ------
    ValueError
        Two labels of one side with the same signal name (``"a.b"`` and ``"a_b"``), or an
        input name equal to an output name.

    Notes
    -----
    State count: ``2 n`` for the ``n`` modes (``p``, ``dp``), plus ``2`` per non-negligible
    dyad of each pole of the residual dynamics (``r``, ``dr``; at most ``2 m min(ns, na)``,
    ``2 m`` for dyadic residues), plus ``2 na`` when a correction filter is needed (``zc``,
    ``dzc``: ``E`` for velocity/acceleration, and for acceleration the ``s`` term of the
    residual dynamics), plus ``3 na`` for ``F`` (``zr``, ``dzr``, ``ddzr``; ``2 na`` with
    ``rigid_body=True``).

    For velocity/acceleration a term ``E`` cannot be a proper feedthrough.  Each
    actuator gets a critically damped correction mode ``w_c^2/(s + w_c)^2`` (2.20):
    ``E (j w)^k w_c^2/(j w + w_c)^2`` equals the E term up to a relative error of
    about ``2 w / w_c`` in the band.  Static correction modes (2.21)-(2.22) carried as modes
    of the model are realised like the other modes.  The residual dynamics are added where
    the model's labels match the block's (its tested I/O).
    """
    q = check_quantity(quantity, "quantity")
    omega_c = check_scalar(omega_c, "omega_c", positive=True, optional=True)
    check_bool(rigid_body, "rigid_body")
    with np.errstate(all="ignore"):
        A, B, C, D, states = realisation_matrices(model, QUANTITY_POWER[q], omega_c,
                                                  bool(rigid_body))
    check_finite_result([np.abs(X).max(initial=0.0) for X in (A, B, C, D)], "the realisation",
                        "omega_c or the model's Omega, Gamma, cphi, phib, E, F")
    import control

    inputs, outputs = signal_names(model.sensors, model.actuators)
    return control.ss(A, B, C, D, inputs=inputs, outputs=outputs, states=states)


def _append(parts, A, B, C, D, states):
    """Block-diagonal append of ``(Ae, Be, Ce, De, names)`` blocks."""
    for Ae, Be, Ce, De, st in parts:
        A = block_diag(A, Ae)
        B = np.vstack([B, Be])
        C = np.hstack([C, Ce])
        D = D + De
        states = states + list(st)
    return A, B, C, D, states


def realisation_matrices(model, k: int, omega_c: float | None, rigid_body: bool):
    """``A, B, C, D, state names`` of :func:`to_statespace` for output derivative ``k``."""
    ns, na = model.ns, model.na
    A, B, C, D = second_order(model.Omega, model.Gamma, model.phib, model.cphi, k)
    states = modal_states(model.n)
    Z0 = np.zeros((ns, na))
    P1, P2 = Z0, Z0
    parts = []
    if model.residual is not None and model.residual.m:
        Ar, Br, Cr, st = model.residual.realisation(model.sensors, model.actuators)
        if k == 0:
            parts.append((Ar, Br, Cr, Z0, st))
        elif k == 1:
            parts.append((Ar, Br, Cr @ Ar, Cr @ Br, st))
        else:                       # y'' = C A^2 x + C A B u + C B u' (improper C B s term)
            parts.append((Ar, Br, Cr @ Ar @ Ar, Cr @ Ar @ Br, st))
            P1 = Cr @ Br
    if model.E is not None:
        if k == 0:
            D = D + model.E
        else:
            P1, P2 = (P1 + model.E, P2) if k == 1 else (P1, P2 + model.E)
    if np.any(P1) or np.any(P2):
        wc = np.float64(omega_c if omega_c is not None else default_omega_c(model))
        # P1 s + P2 s^2 through one critically damped correction state pair per actuator (2.20)
        parts.append((*correction_filter(P1, P2, wc),
                      [f"zc{j}" for j in range(na)] + [f"dzc{j}" for j in range(na)]))
    if model.F is not None:
        wf = 0.0 if rigid_body else default_omega_f(model)
        names = ["zr", "dzr"] + ([] if rigid_body else ["ddzr"])
        parts.append((*mass_correction(model.F, wf, k),
                      [f"{x}{j}" for x in names for j in range(na)]))
    return _append(parts, A, B, C, D, states)
