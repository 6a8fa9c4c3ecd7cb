"""Standard deviations of the fitted sizes of a diagnosis effect (Cramer-Rao, 3.12).

An effect's sizes ``x`` (a dashpot ``c``, a mass ``dm``, a delay ``tau``, a missing mode's
frequency, damping and modal vectors, ...) are fitted by least squares on the complex logLS
residual ``r(x) = Log(H(x) / H_d)`` of every line and data channel.  To first order their
covariance is ``(sigma^2 / 2) (J^T J)^-1`` with ``J`` the real stacked Jacobian
``[Re; Im] dr/dx`` and ``sigma^2`` the noise level of the diagnosis (the expected ``|r|^2``
of the measurement noise alone, half on each of the real and imaginary parts).  ``J`` is
evaluated by central differences of the corrected model itself (:func:`apply_effect`), so
every kind of effect gets the same mechanism.  Nuisance coordinates (the modal vectors of a
missing mode) are fitted together with the reported sizes; sizes that are functions of the
coordinates (a resonator's stiffness ``m w^2``, a relative stiffness change) get the
first-order propagation of the coordinates' covariance.  Several effects accepted in one
diagnosis share one Jacobian (:func:`joint_std`): the covariance then accounts for their
correlation.  The difference quotients are taken as ``Log(H(x+h) / H(x-h)) / 2h`` so that a
phase crossing the branch cut of the logarithm (near an antiresonance) does not appear as a
``2 pi / 2h`` slope.
"""

from __future__ import annotations

import copy

import numpy as np

__all__ = ["coordinates", "effect_std", "joint_std"]

#: relative difference step on each coordinate
STEP = 1e-5


def effect_std(prop, model, placed, placed0, sigma2) -> dict:
    """One standard deviation of each fitted size of the effect ``prop`` (module notes).

    Parameters
    ----------
    prop : dict
        The accepted proposal (kind, parameters, action, payload).
    model : model
        The model the effect is added to.
    placed : Placed
        The data as the effect is applied (undelayed).
    placed0 : Placed
        The data the cost is measured on.
    sigma2 : float
        Noise level: expected ``|Log(H / H_d)|^2`` of the noise per line and channel.

    Returns
    -------
    dict
        Like ``prop["parameters"]``: a float per scalar size, an array per matrix; NaN where
        the data do not determine it.
    """
    return joint_std([prop], model, placed, placed0, sigma2)[0]


def joint_std(props, model, placed, placed0, sigma2) -> list:
    """Standard deviations of the sizes of several effects fitted together.

    The Jacobian is taken with respect to the coordinates of every effect at once (the
    effects applied in turn to ``model``), so that the covariance (module notes) accounts for
    the correlation between effects; each effect's sizes come from its own block.

    Parameters
    ----------
    props : list of dict
        The accepted proposals, in the order they are applied.
    model : model
        The model they are added to.
    placed : Placed
        The data as the effects are applied (undelayed).
    placed0 : Placed
        The data the cost is measured on.
    sigma2 : float
        Noise level (expected ``|Log(H / H_d)|^2`` of the noise per line and channel).

    Returns
    -------
    list of dict
        One per effect, like its ``parameters``.
    """
    from sdctrl.diagnosis._apply import apply_effect

    coords = [coordinates(p) for p in props]
    owner = np.concatenate([[i] * len(c) for i, c in enumerate(coords)] + [[]]).astype(int)
    flat = [c for cs in coords for c in cs]
    x0 = np.array([c[1] for c in flat], float)
    if x0.size == 0:
        return [{} for _ in props]

    def response(x):
        m = model
        for i, p in enumerate(props):
            q = copy.deepcopy(p)
            for (setter, _v, _g), xi in zip(coords[i], x[owner == i]):
                setter(q["payload"], xi)
            m = apply_effect(m, q, placed)
        return placed0.fast_response(m)

    cols = []
    for i in range(x0.size):
        h = STEP * max(abs(x0[i]), 1e-12)
        xp, xm = x0.copy(), x0.copy()
        xp[i] += h
        xm[i] -= h
        # Log(H+ / H-), not Log H+ - Log H-: no 2 pi jump where the phase crosses the cut
        d = np.log(response(xp) / response(xm)).ravel() / (2 * h)
        cols.append(np.r_[d.real, d.imag])
    cov = _covariance(np.array(cols).T, sigma2 / 2.0)
    out = []
    for i, p in enumerate(props):
        sel = np.flatnonzero(owner == i)
        out.append(_sizes(p, coords[i], x0[sel], cov[np.ix_(sel, sel)]) if sel.size else {})
    return out


def _covariance(J, var):
    A = J.T @ J
    d = np.sqrt(np.maximum(np.diag(A), 0.0))
    n = A.shape[0]
    if np.any(d == 0) or not np.all(np.isfinite(A)):
        return np.full((n, n), np.nan)
    An = A / np.outer(d, d)
    if np.linalg.cond(An) > 1e14:
        return np.full((n, n), np.nan)
    return var * np.linalg.inv(An) / np.outer(d, d)


def _set(key):
    def setter(payload, v):
        payload[key] = v
    return setter


def _set_item(key, idx, pair=False):
    def setter(payload, v):
        a = np.array(payload[key], float)
        a[idx] = v
        if pair:
            a[idx[::-1]] = v
        payload[key] = a
    return setter


def coordinates(prop):
    """``(setter, value, gradients)`` of each fitted coordinate; ``gradients`` maps a
    reported size to its derivative with respect to the coordinate (scalar sizes)."""
    p, act, par = prop["payload"], prop["action"], prop["parameters"]
    if act == "delay":
        return [(_set("tau"), p["tau"], {"tau": 1.0})]
    if act == "lowrank" and p["kind"] != "resonator":
        key = next(k for k in ("c", "dk", "dm") if k in par)
        grads = {key: 1.0}
        if "relative" in par:
            grads["relative"] = par["relative"] / p["size"] if p["size"] else np.nan
        return [(_set("size"), p["size"], grads)]
    if act == "lowrank":
        m, w = p["size"], p["omega"]
        return [(_set("size"), m, {"mass": 1.0, "stiffness": w * w}),
                (_set("omega"), w, {"frequency": 1 / (2 * np.pi), "stiffness": 2 * m * w}),
                (_set("zeta"), p["zeta"], {"damping": 1.0})]
    if act == "mode":
        out = [(_set("omega"), p["omega"], {"frequency": 1 / (2 * np.pi)}),
               (_set("zeta"), p["zeta"], {"damping": 1.0})]
        c, b = np.asarray(p["c"], float), np.asarray(p["b"], float)
        out += [(_set_item("c", (i,)), c[i], {("cphi", (i,)): 1.0}) for i in range(c.size)]
        keep = np.arange(b.size) != int(np.argmax(np.abs(b)))    # c b^T: one scale fixed
        out += [(_set_item("b", (i,)), b[i], {("phib", (i,)): 1.0})
                for i in np.flatnonzero(keep)]
        return out
    if act == "gamma":
        out = []
        for name, v in par.items():
            i, j = (int(t) - 1 for t in name.split("_")[1:3])
            out.append((_set_item("dGamma", (i, j), pair=True), p["dGamma"][i, j], {name: 1.0}))
        return out
    if act == "residual":
        X = np.asarray(p["X"], float)
        if "scale" in par:
            g = X / par["scale"] if par["scale"] else np.zeros_like(X)

            def setter(payload, a, g=g):
                payload["X"] = a * g
            return [(setter, par["scale"], {"scale": 1.0, p["field"]: g})]
        return [(_set_item("X", idx), X[idx], {(p["field"], idx): 1.0})
                for idx in zip(*np.nonzero(X))]
    return []


def _sizes(prop, coords, x0, cov):
    """Standard deviations of the reported sizes from the coordinates' covariance."""
    par = prop["parameters"]
    grads = {}
    for k, (_s, _v, g) in enumerate(coords):
        for name, d in g.items():
            if isinstance(name, str) and np.ndim(d) == 0:
                grads.setdefault(name, np.zeros(x0.size))[k] = d
    out = {}
    for name, v in par.items():
        if isinstance(v, np.ndarray):
            out[name] = _matrix_std(prop, coords, cov, name, v.shape)
        elif name in grads:
            gv = grads[name]
            out[name] = float(np.sqrt(max(gv @ cov @ gv, 0.0))) if np.all(
                np.isfinite(cov)) else float("nan")
    return out


def _matrix_std(prop, coords, cov, name, shape):
    """Entry-wise standard deviation of a matrix size (residual terms)."""
    out = np.zeros(shape)
    diag = np.diag(cov)
    for k, (_s, _v, g) in enumerate(coords):
        for key, d in g.items():
            if key == name and np.ndim(d) == 2:                 # X = scale * g
                out = np.abs(d) * np.sqrt(max(diag[k], 0.0))
            elif isinstance(key, tuple) and key[0] == name:     # one entry
                out[key[1]] = np.sqrt(max(diag[k], 0.0))
    return out if np.all(np.isfinite(diag)) else np.full(shape, np.nan)
