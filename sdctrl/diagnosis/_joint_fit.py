"""Joint refit of the effects a diagnosis has accepted (several effects in one call).

Each step of :func:`sdctrl.diagnose` fits its candidates to the residual left by the effects
already accepted, their sizes held.  Two effects whose responses overlap (a mass near a
dashpot, both shifting and damping the same modes) then share the error between them in the
order they were found: the first absorbs part of the second.  After each accepted effect the
sizes of all accepted effects are therefore fitted again together (from the second on: a
lone effect keeps its own fit -- a free mode's, on the lines around it, is not pulled by the
rest of the band) on the complex logLS residual (3.12) ``r(x) = Log(H(x) / H_d)`` of every
line and channel, ``H(x)`` the model with every effect applied in turn at the coordinates
``x`` (their sizes, and for an extra mode its frequency, damping and modal vectors).  Residual
terms, linear and many, are not coordinates: each is refitted per channel given the others
before and after (:func:`_residual_terms_refitted`).

The fit is Levenberg-Marquardt on the normal equations: ``J^T J`` is as small as the number
of coordinates while ``J`` has a row per line, channel and real/imaginary part; each
coordinate is scaled by its starting value, and a step leaving the bounds is projected on
them.  The Jacobian is that of the effects' statistics
(:func:`._effect_statistics.stacked_jacobian`: a free mode's coordinates in closed form, the
others by forward differences).  The fit stops when a step lowers the cost by less than 1%
of one noise unit ``sigma^2 / 2`` (per real residual entry): near the minimum ``|r(x)|^2 -
|r(x*)|^2 = (sigma^2 / 2) d^2`` with ``d`` the Mahalanobis distance of ``x`` from ``x*`` in
the coordinates' covariance (:mod:`._effect_statistics`), so the coordinates are then within
about a tenth of a standard deviation of the optimum.  A free mode stays in its region
(:func:`._global_effects.free_mode_region`: frequency near the band, damping ratio below
0.5): the refit is bounded there, and a mode it drives onto the region's edge is a
broadband trend, not a mode (:func:`._global_effects.leaves_region`): the refit stops
there, and the diagnosis tries its next candidate.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sdctrl.diagnosis._apply import apply_effect
from sdctrl.diagnosis._effect_statistics import Evaluator, coordinates, stacked_jacobian
from sdctrl.diagnosis._global_effects import free_mode_region, leaves_region
from sdctrl.diagnosis._residual_map import ALPHA, complex_residual, cost, false_alarm, log_ratio

__all__ = ["Corrected", "applied", "corrected", "pruned", "refit", "shed_trends"]

#: function evaluations of the joint refit (the Jacobian's not counted)
MAX_NFEV = 30
#: the refit stops when a step lowers the cost by less than this share of it ...
RTOL = 1e-8
#: ... or by less than this share of one noise unit ``noise / 2`` (module notes)
NOISE_SHARE = 0.01


@dataclass(frozen=True, eq=False)
class Corrected:
    """Effects, the model with them applied, and its exact response and cost on the data
    (computed once, read by the refit, the pruning and the diagnosis's loop).

    Parameters
    ----------
    props : list of dict
        The effects (proposals).
    model : model
        The diagnosis's input model with them applied.
    H : ndarray, shape (nf, ns, na)
        Its response on the data lines and channels (:meth:`Placed.response`).
    J : float
        Its complex logLS cost (3.12).
    """

    props: list
    model: object
    H: np.ndarray
    J: float


def corrected(model, props, placed) -> Corrected:
    """``model`` with the effects ``props`` applied (:func:`applied`), with its response and
    cost on ``placed``.

    Parameters
    ----------
    model : model
        The diagnosis's input model.
    props : list of dict
        Effects.
    placed : Placed
        The data.

    Returns
    -------
    Corrected
    """
    m = applied(model, props, placed)
    H = placed.response(m)
    return Corrected(props, m, H, cost(H, placed.Hd))


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
    elif act == "residual":
        X = np.asarray(p["X"], float)
        if "scale" in par and par["scale"]:
            par["scale"] = float(par["scale"] * np.sum(X * par[p["field"]])
                                 / np.sum(par[p["field"]] ** 2))
        par[p["field"]] = X.copy()
    elif act == "gamma":
        for name in par:
            i, j = (int(t) - 1 for t in name.split("_")[1:3])
            par[name] = float(p["dGamma"][i, j])
    return par


def refit(model, props, placed, noise: float = 0.0):
    """Fit the coordinates of all accepted effects together (module notes).

    Parameters
    ----------
    model : model
        The diagnosis's input model.
    props : list of dict
        Accepted proposals, in the order they were found.
    placed : Placed
        The data.
    noise : float
        Noise level of the diagnosis (expected ``|r|^2`` per line and channel): the fit stops
        when a step lowers the cost by less than ``NOISE_SHARE`` of ``noise / 2``.

    Returns
    -------
    Corrected
        New proposals (copies) with refitted payloads, parameters and cost -- the input ones
        when the refit does not lower the cost -- and ``model`` with them applied.
    """
    base = corrected(model, props, placed)
    first = _residual_terms_refitted(model, props, placed)
    coords = [[] if p["action"] == "residual" else coordinates(p) for p in first]
    x0 = np.array([c[1] for cs in coords for c in cs], float)
    if x0.size == 0:
        return _kept(model, base, first, placed)
    evaluate = Evaluator(model, first, coords, placed, placed)
    lb, ub = _bounds(props, coords, placed.omega)
    x0 = np.clip(x0, lb, ub)

    def resid(x):
        r = complex_residual(evaluate(x)[0], placed.Hd)
        return np.r_[r.real.ravel(), r.imag.ravel()]

    try:
        x = _levenberg_marquardt(
            resid, lambda x: stacked_jacobian(evaluate, x, central=False), x0, (lb, ub),
            NOISE_SHARE * noise / 2,
            stop=lambda x: any(leaves_region(q, placed.omega) for q in evaluate.built(x)))
    except np.linalg.LinAlgError:
        return base
    new = _residual_terms_refitted(model, evaluate.built(x), placed)
    return _kept(model, base, new, placed)


def pruned(model, fit, placed, noise):
    """Generic effects that the later ones made redundant, taken out.

    A free extra mode or a residual term (the effects that can stand for anything) accepted
    at an earlier step is tested again given the others: the effects without it are refitted
    together (:func:`refit`) and it is dropped when the error it then removes is not
    significant (the false-alarm test of its acceptance, its own ``k`` parameters and ``m``
    hypotheses, :func:`._residual_map.false_alarm` above ``ALPHA``).  Located physical
    effects (a dashpot, a mass, ...), the newest effect and a free mode that a later
    non-proportional damping couples (its ``dGamma`` has the mode's row and column) are kept
    as they are.

    Parameters
    ----------
    model : model
        The diagnosis's input model.
    fit : Corrected
        Accepted proposals, jointly refitted, and ``model`` with them (:func:`refit`).
    placed : Placed
        The data.
    noise : float
        Noise level of the diagnosis.

    Returns
    -------
    fit : Corrected
    dropped : list of int
        Indices (in ``fit.props``) of the effects taken out.
    """
    dropped, index = [], list(range(len(fit.props)))
    k = 0
    while k < len(fit.props) - 1:
        p = fit.props[k]
        if p["action"] not in ("mode", "residual") or (p["action"] == "mode"
                                                        and _coupled_later(fit.props, k)):
            k += 1
            continue
        without = refit(model, fit.props[:k] + fit.props[k + 1:], placed, noise)
        if false_alarm(without.J, fit.J, noise, placed.n_entries, p["k"], p["m"]) < ALPHA:
            k += 1
            continue
        dropped.append(index.pop(k))
        fit = without
    return fit, dropped


def shed_trends(model, props, fit, placed, noise):
    """Earlier free modes that the joint refit with a new effect moved onto their region's
    edge, taken out: the new effect explains what they stood for (a broadband trend, never
    a mode), so the effects are refitted without them.

    Parameters
    ----------
    model : model
        The diagnosis's input model.
    props : list of dict
        The accepted proposals and the new one (last), as proposed.
    fit : Corrected
        Their joint refit (:func:`refit`).
    placed : Placed
        The data.
    noise : float
        Noise level of the diagnosis.

    Returns
    -------
    fit : Corrected
        ``fit`` itself when no earlier mode left its region, when the new effect is itself
        a mode that left it, or when a later non-proportional damping couples one of them;
        else the refit without those modes (from the others' joint refit).
    shed : list of int
        Indices (in ``props``) of the modes taken out.
    """
    last = len(props) - 1
    shed = [i for i in range(last) if leaves_region(fit.props[i], placed.omega)]
    if not shed or leaves_region(fit.props[last], placed.omega) or any(
            _coupled_later(props, i) for i in shed):
        return fit, []
    return refit(model, [p for i, p in enumerate(fit.props) if i not in shed], placed,
                 noise), shed


def _coupled_later(props, i) -> bool:
    """Whether a non-proportional damping accepted after effect ``i`` couples it (its
    ``dGamma`` has the free mode's row and column: the mode cannot be taken out alone)."""
    return any(q["action"] == "gamma" for q in props[i + 1:])


def _kept(model, base, new, placed) -> Corrected:
    """The effects ``new`` with ``model`` corrected by them when they lower the cost below
    ``base``'s (the input effects, :class:`Corrected`), else ``base``."""
    fit = corrected(model, new, placed)
    if not fit.J < base.J:
        return base
    for q in new:
        q["parameters"] = _parameters(q)
        if q["action"] == "mode":                 # a free mode is located by its frequency
            q["location"] = q["parameters"]["frequency"]
    return fit


def _residual_terms_refitted(model, props, placed) -> list:
    """Copies of ``props`` whose residual terms (``+E``, ``+F / s^2``) are fitted again, one
    after the other, given all the other effects: Gauss-Newton on the complex logLS of each
    channel, whose entry of the term is its own coordinate (the entries the term has: its
    actuator's column, or all), or on the term's one factor along the FE's residual
    flexibility; a step is halved until it lowers the cost (:func:`_term_steps`)."""
    out = [dict(p) for p in props]
    for i, p in enumerate(props):
        if p["action"] != "residual":
            continue
        m = applied(model, out, placed)
        H = placed.fast_response(m)
        lag = placed.lag(m)
        lag = np.ones(placed.omega.size) if lag is None else lag
        phi = (lag * (1.0 if p["payload"]["field"] == "E" else 1.0 / placed.s**2))
        X = np.asarray(p["payload"]["X"], float)
        scale = p["parameters"].get("scale")
        g = X / scale if scale else (X != 0).astype(float)
        x0 = scale if scale else X
        x = _term_steps(H - phi[:, None, None] * X, phi[:, None, None] * g, placed.Hd, x0,
                        scalar=bool(scale))
        out[i] = dict(p, payload=dict(p["payload"], X=x * g))
    return out


def _term_steps(H0, G, Hd, x, scalar, steps=8):
    """Minimise the logLS of ``H0 + G x`` per channel (``x`` (ns, na)), or over all
    channels for one ``x`` (``scalar``), by Gauss-Newton steps halved until they help."""
    axes = (0, 1, 2) if scalar else 0

    def costs(x):
        return np.sum(np.abs(log_ratio((H0 + G * x) / Hd)) ** 2, axis=axes)

    c = costs(x)
    for _ in range(steps):
        H = H0 + G * x
        a = G / H
        num = np.sum((np.conj(a) * log_ratio(H / Hd)).real, axis=axes)
        den = np.sum(np.abs(a) ** 2, axis=axes)
        dx = np.where(den > 0, -num / np.maximum(den, 1e-300), 0.0)
        for _half in range(6):
            ct = costs(x + dx)
            better = ct < c
            if np.all(better | (dx == 0)):
                break
            dx = np.where(better, dx, 0.5 * dx)
        x, c = np.where(better, x + dx, x), np.where(better, ct, c)
        if not np.any(better):
            break
    return x


def _bounds(props, coords, omega):
    """Lower and upper bounds of the coordinates: a free mode's frequency and damping ratio
    in its region, every other coordinate free."""
    lo, hi, zlo, zhi = free_mode_region(omega)
    lb, ub = [], []
    for p, cs in zip(props, coords):
        k = len(lb)
        lb += [-np.inf] * len(cs)
        ub += [np.inf] * len(cs)
        if p["action"] == "mode":                 # (omega, zeta, c..., b...): coordinates()
            lb[k:k + 2], ub[k:k + 2] = [lo, zlo], [hi, zhi]
    return np.array(lb, float), np.array(ub, float)


def _levenberg_marquardt(resid, jac, x0, bounds, enough=0.0, stop=None):
    """Minimise ``|resid(x)|^2`` within ``bounds`` from ``x0`` (module notes); stop when a
    step lowers it by less than ``enough`` (or the share ``RTOL``), or at a point where
    ``stop(x)`` is true."""
    lb, ub = bounds
    scale = np.where(x0 != 0, np.abs(x0), 1.0)
    x, r = x0, resid(x0)
    f, mu, nfev = float(r @ r), 1e-3, 1
    while nfev < MAX_NFEV:
        Js = jac(x) * scale                        # columns in units of the starting values
        A, g = Js.T @ Js, Js.T @ r
        d = np.diag(A) + 1e-12 * max(np.trace(A), 1e-300)
        while nfev < MAX_NFEV:
            xt = np.clip(x - np.linalg.solve(A + mu * np.diag(d), g) * scale, lb, ub)
            rt = resid(xt)
            nfev += 1
            ft = float(rt @ rt)
            if ft < f:
                break
            mu *= 10.0
        else:
            break
        done = f - ft < max(RTOL * f, enough) or (stop is not None and stop(xt))
        x, r, f, mu = xt, rt, ft, max(mu / 10.0, 1e-12)
        if done:
            break
    return x
