"""Real state-space realisation of a complex-mode model (thesis 3.26)-(3.33), (2.20).

Each residue is split into dyads and each dyad becomes a 2-state block; the improper terms of
velocity/acceleration outputs are realised through a critically damped filter (2.20).  Kept
apart from :mod:`.complex_modes` (the model itself) along the thesis's seam between the
parametrisation (3.7) and its state-space form (3.26).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from sdctrl._lib.statespace import correction_filter
from sdctrl._lib.validate import QUANTITY_POWER, check_finite_result, check_quantity, check_scalar
from sdctrl._lib.signals import signal_names

if TYPE_CHECKING:  # pragma: no cover
    from sdctrl.identification._complex_modes import ComplexModeModel

__all__ = ["to_statespace"]


def to_statespace(cm: ComplexModeModel, quantity: str = "displacement",
                  omega_c: float | None = None):
    """Real 2x2-block state-space form (3.26)-(3.33) of a complex-mode model.

    See :meth:`ComplexModeModel.to_statespace` (notes).

    Parameters
    ----------
    cm : ComplexModeModel
        The model.
    quantity : {"displacement", "velocity", "acceleration"}
        Output quantity.
    omega_c : float, optional
        Cut-off (rad/s) of the correction filter of the improper terms.

    Returns
    -------
    control.StateSpace
        Outputs named after the sensors, inputs after the actuators followed by ``_u``.
    """
    q = check_quantity(quantity, "quantity")
    omega_c = check_scalar(omega_c, "omega_c", positive=True, optional=True)
    with np.errstate(all="ignore"):
        A, B, C, D, states = _realisation(cm, QUANTITY_POWER[q], omega_c)
    check_finite_result([np.abs(X).max(initial=0.0) for X in (A, B, C, D)], "the realisation",
                        "omega_c or the model's poles, residues, E, F")
    import control

    inputs, outputs = signal_names(cm.sensors, cm.actuators)
    return control.ss(A, B, C, D, inputs=inputs, outputs=outputs, states=states)


def _modal_blocks(cm: ComplexModeModel):
    """2-state blocks of every non-negligible dyad of every residue, (3.32)-(3.33), ``a = 1``."""
    ns, na = cm.ns, cm.na
    blocks_A, Cs, Bs, states = [], [], [], []
    U, sv, Vh = np.linalg.svd(cm.residues, full_matrices=False)
    for j in range(cm.n):
        lam = cm.poles[j]
        w, zw, wd = abs(lam), -lam.real, lam.imag
        Aj = np.array([[0.0, 1.0], [-w**2, -2 * zw]])
        smax = sv[j, 0] if sv.shape[1] else 0.0
        for k in range(sv.shape[1]):
            if sv[j, k] <= 1e-13 * smax or smax == 0:
                continue
            cpsi = U[j, :, k]
            psib = sv[j, k] * Vh[j, k, :]
            C1 = cpsi.real + (zw / wd) * cpsi.imag            # (3.33), a = 1
            C2 = cpsi.imag / wd
            B1 = 2 * psib.real
            B2 = -2 * (zw * psib.real + wd * psib.imag)
            blocks_A.append(Aj)
            Cs.append(np.column_stack([C1, C2]))
            Bs.append(np.vstack([B1, B2]))
            states += [f"x{j}_{k}", f"dx{j}_{k}"]
    A = _block_diag(*blocks_A)
    B = np.vstack(Bs) if Bs else np.zeros((0, na))
    C = np.hstack(Cs) if Cs else np.zeros((ns, 0))
    return A, B, C, states


def _derivative(A, B, C, E, F, kq: int):
    """``C, D`` of the ``kq``-th output derivative and the improper terms ``P1 s + P2 s^2``."""
    hasE = bool(np.any(E))
    P1 = P2 = None
    if kq == 0:
        D = E.copy()
    elif kq == 1:
        C, D = C @ A, C @ B
        P1 = E if hasE else None
    else:
        D = C @ A @ B + F
        P1 = C @ B
        C = C @ A @ A
        P2 = E if hasE else None
        if np.abs(P1).max(initial=0) <= 1e-12 * max(np.abs(D).max(initial=0), 1e-300):
            P1 = None
    return C, D, P1, P2


def _residual_mass(F, kq: int, ns: int, na: int):
    """``F/s^2`` (displacement) by double integrators, ``F/s`` (velocity) by integrators; one
    per rank component of ``F = U S V^T`` (at most ``min(ns, na)``)."""
    Uf, Sf, Vft = np.linalg.svd(F, full_matrices=False)
    rf = int(np.sum(Sf > 1e-14 * Sf[0]))
    Cf, Bf = Uf[:, :rf] * Sf[:rf], Vft[:rf]
    Ii, Zi = np.eye(rf), np.zeros((rf, rf))
    if kq == 0:
        return (np.block([[Zi, Ii], [Zi, Zi]]), np.vstack([np.zeros((rf, na)), Bf]),
                np.hstack([Cf, np.zeros((ns, rf))]), np.zeros((ns, na)),
                [f"r{a}" for a in range(rf)] + [f"dr{a}" for a in range(rf)])
    return Zi, Bf, Cf, np.zeros((ns, na)), [f"r{a}" for a in range(rf)]


def _correction_filter(cm: ComplexModeModel, P1, P2, omega_c):
    """``P1 s + P2 s^2`` through ``w_c^2 / (s + w_c)^2`` (2.20), one filter per actuator."""
    ns, na = cm.ns, cm.na
    wc = np.float64(omega_c if omega_c is not None else 10.0 * (
        np.abs(cm.poles).max() if cm.n else 2 * np.pi * (cm.band or (1, 1))[1]))
    P1 = np.zeros((ns, na)) if P1 is None else P1
    P2 = np.zeros((ns, na)) if P2 is None else P2
    return (*correction_filter(P1, P2, wc),
            [f"zc{a}" for a in range(na)] + [f"dzc{a}" for a in range(na)])


def _block_diag(*blocks):
    """Block-diagonal matrix of 2-D real ``blocks`` (``(0, 0)`` for none)."""
    rows, cols = sum(b.shape[0] for b in blocks), sum(b.shape[1] for b in blocks)
    out = np.zeros((rows, cols))
    i = j = 0
    for b in blocks:
        out[i:i + b.shape[0], j:j + b.shape[1]] = b
        i, j = i + b.shape[0], j + b.shape[1]
    return out


def _realisation(cm: ComplexModeModel, kq: int, omega_c: float | None):
    """``A, B, C, D, state names`` of :func:`to_statespace` for output derivative ``kq``."""
    A, B, C, states = _modal_blocks(cm)
    E, F = np.asarray(cm.E, float), np.asarray(cm.F, float)
    C, D, P1, P2 = _derivative(A, B, C, E, F, kq)
    extra = []
    if bool(np.any(F)) and kq < 2:
        extra.append(_residual_mass(F, kq, cm.ns, cm.na))
    if P1 is not None or P2 is not None:
        extra.append(_correction_filter(cm, P1, P2, omega_c))
    for Ae, Be, Ce, De, st in extra:
        A = _block_diag(A, Ae)
        B = np.vstack([B, Be])
        C = np.hstack([C, Ce])
        D = D + De
        states = states + st
    return A, B, C, D, states
