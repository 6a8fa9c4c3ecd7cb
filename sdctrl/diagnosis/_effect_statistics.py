"""Standard deviations of the fitted sizes of a diagnosis effect: the noise's (Cramer-Rao,
3.12) or the sensors' scatter (model error), whichever is larger.

An effect's sizes ``x`` (a dashpot ``c``, a mass ``dm``, a delay ``tau``, a missing mode's
frequency, damping and modal vectors, ...) are fitted by least squares on the complex logLS
residual ``r(x) = Log(H(x) / H_d)`` of every line and data channel.  To first order their
covariance is ``(sigma^2 / 2) (J^T J)^-1`` with ``J`` the real stacked Jacobian
``[Re; Im] dr/dx`` and ``sigma^2`` the noise level of the diagnosis (the expected ``|r|^2``
of the measurement noise alone, half on each of the real and imaginary parts).  ``J`` is
evaluated by central differences of the corrected model itself (:func:`apply_effect`), so
every kind of effect gets the same mechanism -- but a free extra mode's coordinates, whose
term ``phi c b^T`` (``phi = 1 / (s^2 + 2 zeta w s + w^2)``, 2.15) adds to the response of
everything else, are differentiated in closed form (:func:`stacked_jacobian`): ``d Log H =
dH / H`` with ``dphi / dw = -phi^2 (2 zeta s + 2 w)``, ``dphi / dzeta = -phi^2 2 w s`` (a
delay multiplies the term and ``H`` alike; unless coupling terms follow); so are the
coupling terms ``Gamma_ij`` of a
non-proportional damping effect applied last, ``dH / dGamma_ij = -s (X_y,i X_u,j + X_y,j
X_u,i)`` (:mod:`._global_effects`).  Nuisance coordinates (the modal vectors of a
missing mode) are fitted together with the reported sizes; sizes that are functions of the
coordinates (a resonator's stiffness ``m w^2``, a relative stiffness change) get the
first-order propagation of the coordinates' covariance.  Several effects accepted in one
diagnosis share one Jacobian (:func:`joint_std`): the covariance then accounts for their
correlation.  The difference quotients are taken as ``Log(H(x+h) / H(x-h)) / 2h`` so that a
phase crossing the branch cut of the logarithm (near an antiresonance) does not appear as a
``2 pi / 2h`` slope.

That covariance is the noise's alone: it assumes the model right but for the effects.  A
slightly wrong nominal model (a reduction's truncation) biases the sizes by what it cannot
see -- a dashpot sharing its node with a mass by 17-28 of those standard deviations.  The
same Jacobian and the residual at the fit give the covariance the data themselves show,
the leverage-corrected leave-one-sensor-out scatter of the fit
(:mod:`sdctrl._lib.sensor_scatter`), which contains the noise's and any model error not common to
every sensor.  Each reported standard deviation is the larger of the two, ``max(s_noise,
s_data) = sqrt(s_noise^2 + max(0, s_data^2 - s_noise^2))``: under pure noise the scatter
estimates the noise's own (0.91-1.04 of it on the family) with only ``G - 1`` degrees of
freedom, and the Cramer-Rao bound is then the sharper of the two (the larger of them is
4-19% above it, rms over 20-40 draws on six cases of the family, where a sum would count the
noise twice, +41%); when the scatter exceeds it, the excess is model error that the noise's
bound would hide.  A size that only one sensor determines (a free mode's modal
observability there) keeps the noise's.
"""

from __future__ import annotations

import copy

import numpy as np

from sdctrl.diagnosis._residual_map import complex_residual
from sdctrl._lib.sensor_scatter import channel_groups, scatter_covariance

__all__ = ["coordinates", "effect_std", "joint_std", "mode_keys", "stacked_jacobian"]

#: relative difference step on each coordinate (the corrected model's response is accurate
#: to about 1e-9 relative: a forward difference's round-off error is then 1e-4 of the
#: derivative, its truncation error about the step itself)
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
    the correlation between effects; each effect's sizes come from its own block.  Each
    standard deviation is the larger of the noise's (Cramer-Rao) and the sensors' scatter
    (:func:`sdctrl._lib.sensor_scatter.scatter_covariance`, from the same Jacobian and the
    residual at ``props``' coordinates, which should be the fit's optimum).

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
    coords = [coordinates(p) for p in props]
    owner = np.concatenate([[i] * len(c) for i, c in enumerate(coords)] + [[]]).astype(int)
    x0 = np.array([c[1] for cs in coords for c in cs], float)
    if x0.size == 0:
        return [{} for _ in props]
    evaluate = Evaluator(model, props, coords, placed, placed0)
    J = stacked_jacobian(evaluate, x0)
    cov = _covariance(J, sigma2 / 2.0)
    H = evaluate(x0)[0]
    r = complex_residual(H, placed0.Hd).ravel()
    groups = channel_groups(H.shape)
    cov_data = None if groups is None else scatter_covariance(J, np.r_[r.real, r.imag],
                                                               groups)
    out = []
    for i, p in enumerate(props):
        sel = np.flatnonzero(owner == i)
        if not sel.size:
            out.append({})
            continue
        std = _sizes(p, coords[i], x0[sel], cov[np.ix_(sel, sel)])
        if cov_data is not None:
            std = _larger(std, _sizes(p, coords[i], x0[sel], cov_data[np.ix_(sel, sel)]))
        out.append(std)
    return out


def _larger(noise, leave_out) -> dict:
    """Size by size, the larger of the noise's and the leave-outs' standard deviations
    (module notes); NaN where the noise's is (the data do not determine the size)."""
    return {k: np.maximum(v, leave_out[k]) if k in leave_out else v
            for k, v in noise.items()}


class Evaluator:
    """The response of ``model`` with the effects ``props`` applied in turn at coordinates
    ``x`` (those of :func:`coordinates`, effect after effect): ``evaluate(x) -> (H, built,
    lag)``, ``H`` on ``placed0``'s lines and channels, ``built`` the proposals at ``x``,
    ``lag`` the delay factor ``exp(-j w tau)`` per line (None without a delay).  The last
    evaluation is kept (a least-squares solver asks for the residual and the Jacobian at
    the same point)."""

    def __init__(self, model, props, coords, placed, placed0):
        self.model, self.props, self.coords = model, props, coords
        self.placed, self.placed0 = placed, placed0
        self.owner = np.concatenate([[i] * len(c) for i, c in enumerate(coords)]
                                    + [[]]).astype(int)
        self._last = (None, None)

    def built(self, x) -> list:
        """Copies of the proposals with their coordinates set to ``x``."""
        out = []
        for i, p in enumerate(self.props):
            q = copy.deepcopy(p)
            for (setter, _v, _g), xi in zip(self.coords[i], x[self.owner == i]):
                setter(q["payload"], xi)
            out.append(q)
        return out

    def __call__(self, x):
        x = np.asarray(x, float)
        if self._last[0] is not None and np.array_equal(self._last[0], x):
            return self._last[1]
        from sdctrl.diagnosis._apply import DelayedModel, apply_effect

        built, m = self.built(x), self.model
        for q in built:
            m = apply_effect(m, q, self.placed)
        H = self.placed0.fast_response(m)
        lag = self.placed0.lag(m)
        self.corrected = m.model if isinstance(m, DelayedModel) else m
        self._last = (x.copy(), (H, built, lag))
        return H, built, lag


def mode_keys(prop) -> list:
    """What each coordinate of a free mode is, in :func:`coordinates`' order: ``("omega",)``,
    ``("zeta",)``, ``("c", i)`` per data sensor, ``("b", j)`` per data actuator but the
    largest (fixed: only ``c b^T`` is determined)."""
    c, b = np.asarray(prop["payload"]["c"]), np.asarray(prop["payload"]["b"], float)
    keep = np.flatnonzero(np.arange(b.size) != int(np.argmax(np.abs(b))))
    return [("omega",), ("zeta",)] + [("c", i) for i in range(c.size)] + \
        [("b", int(j)) for j in keep]


def _mode_columns(payload, keys, s, H, lag):
    """``[Re; Im] d Log H / d coordinate`` of a free mode's coordinates (module notes)."""
    w, z = float(payload["omega"]), float(payload["zeta"])
    c, b = np.asarray(payload["c"], float), np.asarray(payload["b"], float)
    phi = 1.0 / (s**2 + 2 * z * w * s + w * w)
    Q = (phi if lag is None else phi * lag)[:, None, None] / H        # dH / H per unit term
    cb = np.outer(c, b)
    n = H.size
    out = np.zeros((2 * n, len(keys)), order="F")
    for k, key in enumerate(keys):
        re, im = out[:n, k].reshape(H.shape), out[n:, k].reshape(H.shape)     # views
        if key[0] in ("omega", "zeta"):
            dD = 2 * z * s + 2 * w if key[0] == "omega" else 2 * w * s
            d = Q * (-phi * dD)[:, None, None] * cb
            re[...], im[...] = d.real, d.imag
        elif key[0] == "c":
            d = Q[:, key[1], :] * b
            re[:, key[1], :], im[:, key[1], :] = d.real, d.imag
        else:
            d = Q[:, :, key[1]] * c
            re[:, :, key[1]], im[:, :, key[1]] = d.real, d.imag
    return out


def stacked_jacobian(evaluate, x, central: bool = True) -> np.ndarray:
    """``[Re; Im] d Log H / dx`` at ``x`` (module notes): differences of the corrected model
    for every coordinate but a free mode's and the coupling terms of the last effect, which
    are in closed form.

    Parameters
    ----------
    evaluate : Evaluator
        The corrected model's response at given coordinates.
    x : ndarray
        The coordinates.
    central : bool
        Central differences; else forward ones (half the evaluations: for a fit's search
        direction).

    Returns
    -------
    ndarray, shape (2 nf ns na, x.size)
    """
    x = np.asarray(x, float)
    H, built, lag = evaluate(x)
    corrected = evaluate.corrected
    props, owner = evaluate.props, evaluate.owner
    n = H.size
    out = np.empty((2 * n, x.size), order="F")
    for k in range(x.size):
        if _closed_form(props, k, owner):
            continue
        h = STEP * max(abs(x[k]), 1e-12)
        xp, xm = x.copy(), x.copy()
        xp[k] += h
        xm[k] -= h if central else 0.0
        # Log(H+ / H-), not Log H+ - Log H-: no 2 pi jump where the phase crosses the cut
        Hm = evaluate(xm)[0] if central else H
        d = np.log(evaluate(xp)[0] / Hm).ravel() / ((1 + central) * h)
        out[:n, k], out[n:, k] = d.real, d.imag
    for i, p in enumerate(props):
        sel = np.flatnonzero(owner == i)
        if sel.size == 0 or not _closed_form(props, sel[0], owner):
            continue
        if p["action"] == "mode":
            out[:, owner == i] = _mode_columns(built[i]["payload"], mode_keys(p),
                                               evaluate.placed0.s, H, lag)
        else:
            out[:, owner == i] = _gamma_columns(corrected, p, evaluate.placed0, H, lag)
    return out


def _closed_form(props, k, owner) -> bool:
    """Whether coordinate ``k`` has a closed-form column: a free mode's when no coupling
    effect follows (coupling terms may tie it to the other modes: its term is then no longer
    additive), or a coupling term of the last effect (the corrected model's ``Gamma`` is
    then that effect's)."""
    i = owner[k]
    act = props[i]["action"]
    if act == "mode":
        return not any(p["action"] == "gamma" for p in props[i + 1:])
    return act == "gamma" and i == len(props) - 1


def _gamma_columns(model, prop, placed0, H, lag):
    """``[Re; Im] d Log H / dGamma_ij`` of the coupling terms of ``prop`` applied last to
    the corrected ``model``: ``dH / dGamma_ij = -s (X_y,i X_u,j + X_y,j X_u,i)`` with
    ``X_y = C Z^-1``, ``X_u = Z^-1 B`` (2.15, :mod:`._global_effects`)."""
    from sdctrl.diagnosis._lowrank import Resolvent

    s, n = placed0.s, H.size
    C = np.asarray(model.cphi)[placed0.rows]
    B = np.asarray(model.phib)[:, placed0.cols]
    R = Resolvent.of(np.asarray(model.Omega, float), np.asarray(model.Gamma, float))
    eye = np.eye(model.n)
    Xy, Xu = R.transfer(s, C.T, eye), R.transfer(s, eye, B)
    Q = (-s if lag is None else -s * lag)[:, None, None] / H
    out = np.empty((2 * n, len(prop["parameters"])), order="F")
    for k, name in enumerate(prop["parameters"]):
        i, j = (int(t) - 1 for t in name.split("_")[1:3])
        d = (Xy[:, :, i, None] * Xu[:, None, j, :] + Xy[:, :, j, None] * Xu[:, None, i, :]) * Q
        out[:n, k], out[n:, k] = d.real.ravel(), d.imag.ravel()
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


#: the parameter that sets the size of each kind of effect whose size must be determined
#: (a missing mode: its damping, which tells a resonance from a broadband trend)
SIZES = {"added_damper": "c", "mass_change": "dm", "stiffness_change": "dk", "delay": "tau",
         "missing_mode": "damping"}
#: a size must lie this many of its standard deviations from zero (as the acceptance's 3 std)
DETERMINED = 3.0


def undetermined(props, model, placed0, sigma2) -> str | None:
    """Why the last effect of ``props`` (fitted jointly with the others on ``model``) is not
    determined by the data, or None.

    A cost that falls significantly (the chi-square test of :func:`diagnose`) says that
    *something* explains the data better; the size must also be known.  A dashpot driven to
    a rigid link (its cost flat in ``c``), a "mode" whose damping is as uncertain as it is
    large (a broadband trend), absorb model error without telling its size: their size
    lies within ``DETERMINED`` standard deviations (:func:`joint_std`, the larger of the
    noise's and the sensors' scatter) of zero.
    """
    p = props[-1]
    key = SIZES.get(p["kind"])
    v = p["parameters"].get(key) if key else None
    if v is None or not np.isscalar(v):
        return None
    s = joint_std(props, model, placed0, placed0, sigma2)[-1].get(key)
    if s is None or not np.isfinite(s) or abs(v) >= DETERMINED * s:
        return None
    return (f"its size is not determined by the data ({key} = {v:.4g} +- {s:.2g}: within "
            f"{DETERMINED:g} standard deviations of zero)")
