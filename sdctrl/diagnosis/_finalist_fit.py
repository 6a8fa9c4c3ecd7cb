"""Full fit of one finalist of the candidate scan on all the data (complex logLS, 3.12).

A finalist is a rank-``k`` change of the model (4.22): on the lines ``s``,
``H = H_0 - G_yk D (I + G_kk D)^-1 G_ku`` (Woodbury, :func:`._lowrank.woodbury`).  Divided by
the data once, ``H / H_d = A - g(D) P`` with ``A = H_0 / H_d`` and, for rank 1,
``P = G_yk G_ku / H_d``, ``g = D / (1 + D G_kk)``: an evaluation of the residual
``Log(H / H_d)`` costs one scaled subtraction and the complex logarithm.  The resonator's
least-squares fit uses the exact Jacobian of that residual,
``d Log(q) / dx = -(dg/dD) (dD/dx) P / q`` with ``dg/dD = 1 / (1 + D G_kk)^2``.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares, minimize_scalar

from sdctrl._lib.threads import single_thread
from sdctrl.diagnosis._lowrank import dynamic_stiffness, woodbury
from sdctrl.diagnosis._residual_map import cost, log_ratio, ratio_cost

__all__ = ["fit_task"]

#: the resonator's fit starts on at most this many lines (every k-th) ...
PRE_FIT_LINES = 200
#: ... with at most this many evaluations (a true resonator's takes 7-19 on the truss), and
#: then at most this many on all the lines (4-9)
PRE_NFEV, FINAL_NFEV = 50, 20
#: a first fit whose log-mass ends this close to its lower bound has no resonator left
VANISHED = 1e-3


def _fit_size(t, cost_of):
    """Bounded 1-D minimisation of the cost ``cost_of(size)`` over ``u = log(base + size)``
    around the best grid point of the screen."""
    def c1(u):
        return cost_of(np.exp(u) - t["base"])

    u = np.sort(np.log(t["base"] + t["grid"]))
    j = int(np.searchsorted(u, np.log(t["base"] + t["grid"][t["best"]])))
    lo = np.log(t["base"] + t["bounds"][0])
    hi = np.log(t["base"] + t["bounds"][1])
    a = u[j - 1] if j > 0 else lo
    b = u[j + 1] if j + 1 < u.size else hi
    res = minimize_scalar(c1, bounds=(a, b), method="bounded", options={"xatol": 1e-6})
    return float(res.fun), float(np.exp(res.x) - t["base"]), np.nan, np.nan


def _resonator_D(s, x):
    """``D(s)`` of a resonator at ``x = log(m, w, z)`` and its derivatives along ``x``."""
    m, w, z = np.exp(x)
    s2 = s * s
    num = w * w + 2 * z * w * s
    den = s2 + num
    D = m * s2 * num / den
    dnum = m * s2 * s2 / (den * den)                     # dD / dnum
    return D, np.stack([D, dnum * w * (2 * w + 2 * z * s), dnum * 2 * z * w * s])


def _fit_resonator(t, A, P, Gkk):
    """Least squares on mass, frequency and damping (log coordinates), exact Jacobian: first
    on every k-th line (at most :data:`PRE_FIT_LINES`, :data:`PRE_NFEV` evaluations), then
    from there on all the lines (a few iterations, at most :data:`FINAL_NFEV`: the optimum of
    all the lines is sought from a point next to it).  A resonator whose first fit drives its mass
    onto the lower bound has no effect left (the data want none): its frequency and damping are then
    undetermined, and the fit on all the lines, which would wander along that valley, is not run."""
    x0 = np.log([t["grid"][t["best"]], t["omega"], t["zeta"]])
    lb = [np.log(t["bounds"][0]), x0[1] - 0.3, np.log(1e-5)]
    ub = [np.log(t["bounds"][1]), x0[1] + 0.3, np.log(0.5)]
    x = np.clip(x0, lb, ub)
    k = -(-t["s"].size // PRE_FIT_LINES)
    nfev = 100
    if k > 1:
        x = _least_squares(t["s"][::k], A[::k], P[::k], Gkk[::k], x, lb, ub, PRE_NFEV).x
        nfev = FINAL_NFEV
        if x[0] <= lb[0] + VANISHED:                 # vanished: the cost on all the lines
            D = _resonator_D(t["s"], x)[0]
            return (ratio_cost(A - (D / (1.0 + D * Gkk))[:, None, None] * P),
                    *(float(v) for v in np.exp(x)))
    res = _least_squares(t["s"], A, P, Gkk, x, lb, ub, nfev)
    m, w, z = np.exp(res.x)
    return float(np.mean(res.fun**2) * 2), float(m), float(w), float(z)


def _least_squares(s, A, P, Gkk, x0, lb, ub, max_nfev=100):
    """The resonator's least-squares fit on lines ``s`` from ``x0``."""
    def parts(x):
        D, dD = _resonator_D(s, x)
        den = 1.0 + D * Gkk
        q = A - (D / den)[:, None, None] * P
        return q, dD / (den * den)

    def rv(x):
        r = log_ratio(parts(x)[0]).reshape(-1)
        return np.r_[r.real, r.imag]

    def jac(x):
        q, dg = parts(x)
        Pq = P / q
        cols = [(-g[:, None, None] * Pq).reshape(-1) for g in dg]
        return np.stack([np.r_[c.real, c.imag] for c in cols], axis=1)

    return least_squares(rv, x0, jac=jac, bounds=(lb, ub), x_scale=[1, 0.01, 1],
                         xtol=1e-8, ftol=1e-9, max_nfev=max_nfev)


def fit_task(t) -> tuple:
    """Full fit of one finalist on all the data (complex logLS); runs on any executor.

    Parameters
    ----------
    t : dict
        ``H0``, ``Hd``, ``s`` (rad/s), ``Gyk``, ``Gkk``, ``Gku`` (on all lines), ``kind``,
        ``base``, ``bounds``, ``grid`` (screen sizes), ``best`` (index in it) and, for a
        resonator, ``omega`` (rad/s) and ``zeta`` (its screen tuning).

    Returns
    -------
    tuple
        ``(cost, size, omega, zeta)`` (NaN omega/zeta for non-resonators).
    """
    with single_thread():
        H0, Hd, s = t["H0"], t["Hd"], t["s"]
        Gyk, Gkk, Gku, kind = t["Gyk"], t["Gkk"], t["Gku"], t["kind"]
        A = H0 / Hd
        if Gkk.shape[1] == 1:
            P = Gyk[:, :, :1] * Gku[:, :1, :] / Hd
            g11 = Gkk[:, 0, 0]
            if kind == "resonator":
                return _fit_resonator(t, A, P, g11)

            def cost_of(size):                 # the ratio H / Hd formed directly
                D = dynamic_stiffness(kind, s, size)
                return ratio_cost(A - (D / (1.0 + D * g11))[:, None, None] * P)
        else:
            def cost_of(size):
                D = dynamic_stiffness(kind, s, size)
                return cost(woodbury(H0, Gyk, Gkk, Gku, D), Hd)
        return _fit_size(t, cost_of)
