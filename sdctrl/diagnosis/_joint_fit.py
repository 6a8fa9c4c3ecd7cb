"""Joint refit of the effects a diagnosis has accepted (several effects in one call).

Each step of :func:`sdctrl.diagnose` fits its candidates to the residual left by the effects
already accepted, their sizes held.  Two effects whose responses overlap (a mass near a
dashpot, both shifting and damping the same modes) then share the error between them in the
order they were found: the first absorbs part of the second.  After each accepted effect the
sizes of all accepted effects are therefore fitted again together (from the second on: a
lone effect keeps its own fit -- a free mode's, on the lines around it, is not pulled by the
rest of the band), by nonlinear least squares
(trust-region reflective, finite-difference Jacobian) on the complex logLS residual (3.12)
``r(x) = Log(H(x) / H_d)`` of every line and channel, ``H(x)`` the model with every effect
applied in turn at the coordinates ``x`` (their sizes, and for an extra mode its frequency,
damping and modal vectors; residual terms, linear and many, keep their values).
"""

from __future__ import annotations

import copy

import numpy as np
from scipy.optimize import least_squares

from sdctrl.diagnosis._apply import apply_effect
from sdctrl.diagnosis._effect_statistics import coordinates
from sdctrl.diagnosis._residual_map import complex_residual, cost

__all__ = ["applied", "refit"]

#: function evaluations of the joint refit (the Jacobian's not counted)
MAX_NFEV = 30


def applied(model, props, placed):
    """``model`` with every effect of ``props`` applied in turn.

    Parameters
    ----------
    model : model
        The diagnosis's input model.
    props : list of dict
        Accepted proposals.
    placed : Placed
        The data (channels of the fitted terms).

    Returns
    -------
    model
    """
    for p in props:
        model = apply_effect(model, p, placed)
    return model


def _parameters(prop) -> dict:
    """The reported sizes of a proposal from its payload (after its coordinates changed)."""
    p, act, par = prop["payload"], prop["action"], dict(prop["parameters"])
    if act == "delay":
        par["tau"] = float(p["tau"])
    elif act == "lowrank" and p["kind"] != "resonator":
        key = next(k for k in ("c", "dk", "dm") if k in par)
        if "relative" in par and par[key]:
            par["relative"] = float(par["relative"] / par[key] * p["size"])
        par[key] = float(p["size"])
    elif act == "lowrank":
        m, w = float(p["size"]), float(p["omega"])
        par.update(frequency=w / (2 * np.pi), damping=float(p["zeta"]), mass=m,
                   stiffness=m * w * w)
    elif act == "mode":
        par.update(frequency=float(p["omega"]) / (2 * np.pi), damping=float(p["zeta"]))
        if "cphi" in par:
            par.update(cphi=np.asarray(p["c"], float).copy(),
                       phib=np.asarray(p["b"], float).copy())
    elif act == "gamma":
        for name in par:
            i, j = (int(t) - 1 for t in name.split("_")[1:3])
            par[name] = float(p["dGamma"][i, j])
    return par


def refit(model, props, placed):
    """Fit the coordinates of all accepted effects together (module notes).

    Parameters
    ----------
    model : model
        The diagnosis's input model.
    props : list of dict
        Accepted proposals, in the order they were found.
    placed : Placed
        The data.

    Returns
    -------
    props : list of dict
        New proposals (copies) with refitted payloads, parameters and cost; the input ones
        when the refit does not lower the cost.
    corrected : model
        ``model`` with them applied.
    """
    coords = [[] if p["action"] == "residual" else coordinates(p) for p in props]
    owner = np.concatenate([[i] * len(c) for i, c in enumerate(coords)] + [[]]).astype(int)
    x0 = np.array([c[1] for cs in coords for c in cs], float)
    base = applied(model, props, placed)
    J0 = cost(placed.response(base), placed.Hd)
    if x0.size == 0:
        return props, base

    def build(x):
        out = []
        for i, p in enumerate(props):
            q = copy.deepcopy(p)
            for (setter, _v, _g), xi in zip(coords[i], x[owner == i]):
                setter(q["payload"], xi)
            out.append(q)
        return out

    def resid(x):
        r = complex_residual(placed.fast_response(applied(model, build(x), placed)),
                             placed.Hd)
        return np.r_[r.real.ravel(), r.imag.ravel()]

    scale = np.where(x0 != 0, np.abs(x0), 1.0)
    try:
        sol = least_squares(resid, x0, x_scale=scale, diff_step=1e-6, method="trf",
                            max_nfev=MAX_NFEV)
    except (ValueError, np.linalg.LinAlgError):
        return props, base
    new = build(sol.x)
    corrected = applied(model, new, placed)
    J = cost(placed.response(corrected), placed.Hd)
    if not J < J0:
        return props, base
    for q in new:
        q["parameters"] = _parameters(q)
        if q["action"] == "mode":                 # a free mode is located by its frequency
            q["location"] = q["parameters"]["frequency"]
    return new, corrected
