"""Shapes of the static-correction states of a plain normal-mode model placed on its FE model
(issue 23: "given a plain normal-mode model with an FE model: the same results as with a
hybrid").

A model without shapes is given shapes on the FE model by the expansion of a hybrid model
(4.7): each state's measured ``cphi`` is fitted by FE modes.  That is exact for the states
that are FE modes, and wrong for the static-correction states an FE reduction appends
(2.21)-(2.22), (4.23)-(4.24): their shapes are combinations of the static response to the
model's inputs (and, for a reduction with ``damping_paths``, to the dashpots' load paths
:func:`~sdctrl.fe._reduction.damping_loads`) less the retained modes' part,
``Psi = K^-1 B - sum phi phi^T B / omega^2``, which no set of low FE modes spans.  With those wrong
shapes a physical candidate at a loaded node sees the wrong static flexibility (on a held-out
aircraft model: a dashpot biased by 0.8-1.2%, a mass by -1.5%, noise-free).

Rule: the states paired with an FE mode (same frequency within :data:`MATCH`, MAC above
0.999) are modes; every other state whose ``(cphi, phib)`` lies in the span of ``Psi``
(``C Psi a = cphi_j``, ``(Psi a)^T B = phib_j`` within :data:`FIT`, relative) is a static
state and takes the shape ``Psi a``.  The inputs ``B`` are the model's actuator labels as
point loads on the FE DOFs.  States that meet neither keep their expanded shape.
"""

from __future__ import annotations

import numpy as np

from sdctrl.fe._reduction import damping_loads

__all__ = ["FIT", "MATCH", "static_shapes"]

#: relative frequency match of a state that is an FE mode
MATCH = 1e-4
#: relative residual of a state's ``(cphi, phib)`` in the span of the static correction
FIT = 1e-3


def static_shapes(fe, model, pairing):
    """``(model, k)``: ``model`` with its ``k`` static-correction states given their shapes
    (module notes).

    Parameters
    ----------
    fe : FEModel
        The FE model (DOF labels of the model's sensors and actuators).
    model : NormalModeModel
        The model with expanded shapes on the FE DOFs.
    pairing : ModePairing
        The FE/test pairing of the hybrid that expanded them (test modes = model states).

    Returns
    -------
    model : NormalModeModel
    k : int
    """
    n = model.n
    real = np.zeros(n, bool)
    if pairing is not None and pairing.test_mode is not None and pairing.test_mode.size:
        same = (np.abs(pairing.test_hz / pairing.fe_hz - 1) < MATCH) & (pairing.mac > 0.999)
        real[pairing.test_mode[same]] = True
    cand = np.flatnonzero(~real)
    if not cand.size or not real.any():
        return model, 0
    S = np.asarray(model.shapes, float)
    B = fe.point(list(model.actuators))
    C = fe.point(list(model.sensors)).T
    # the loads an FE reduction corrects: the inputs, and the dashpots' load paths
    # (FEModel.normal_mode_model(..., damping_paths=True))
    loads = np.hstack([B, damping_loads(fe, S[:, real])])
    Psi = fe.static_correction(loads, S[:, real])
    G = np.vstack([C @ Psi, B.T @ Psi])
    Y = np.vstack([np.asarray(model.cphi)[:, cand], np.asarray(model.phib)[cand].T])
    A, *_ = np.linalg.lstsq(G, Y, rcond=None)
    res = np.linalg.norm(G @ A - Y, axis=0) / np.maximum(np.linalg.norm(Y, axis=0), 1e-300)
    good = res < FIT
    if not good.any():
        return model, 0
    S = S.copy()
    S[:, cand[good]] = Psi @ A[:, good]
    return model.replace(shapes=S), int(good.sum())
