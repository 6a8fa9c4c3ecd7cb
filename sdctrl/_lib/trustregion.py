"""Bounded nonlinear least squares in numpy: an interior, reflective trust-region method.

``minimise 0.5 ||f(x)||^2 subject to lo < x < hi`` for small problems (a few dozen
parameters).  Written from the textbook method (Coleman and Li, "An interior trust region
approach for nonlinear minimization subject to bounds", SIAM J. Optim. 6, 1996; trust-region
subproblem and radius update as in Nocedal and Wright, *Numerical Optimization*, ch. 4):

- the first-order condition with bounds is ``v(x) * g = 0``, ``g = J^T f`` and ``v_i`` the
  distance to the bound that the descent direction ``-g_i`` points to (1 where it points
  to an infinite bound); Newton's method on it, in the variables ``x = x_k + D p`` with
  ``D = diag(v^1/2 / c)`` (``c`` the column norms of ``J``, the largest met so far:
  scale-free steps), gives the Gauss-Newton model ``g_h^T p + p^T B_h p / 2`` with
  ``g_h = D g`` and ``B_h = D J^T J D + diag(g dv / c^2)`` (``dv = dv/dx``, +-1 or 0: the
  term, never negative, slows the approach to an active bound);
- the model is minimised in the ball ``||p|| <= Delta`` exactly (eigen-decomposition and
  Newton on ``1/||p(alpha)|| - 1/Delta``, More and Sorensen);
- iterates stay strictly inside the bounds: a step that would cross a bound is cut back
  to ``theta`` (``>= 0.995``) of the way there, or reflected at the bound, or replaced by
  the scaled gradient step, whichever the model prefers;
- the radius follows the ratio of actual to predicted reduction (< 1/4: shrink to a
  quarter of the step; > 3/4 at the boundary of the ball: double).

Stopping tests (the meanings of ``scipy.optimize.least_squares``): ``gtol`` on
``max |v g|``, ``ftol`` on an accepted cost decrease relative to the cost (with a ratio
above 1/4), ``xtol`` on ``||dx|| < xtol (xtol + ||x||)``, and ``max_nfev`` evaluations.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

__all__ = ["BoundedFit", "bounded_least_squares"]

MESSAGES = {0: "the maximum number of function evaluations is exceeded",
            1: "gtol termination condition is satisfied",
            2: "ftol termination condition is satisfied",
            3: "xtol termination condition is satisfied",
            4: "both ftol and xtol termination conditions are satisfied"}


@dataclass(frozen=True, eq=False)
class BoundedFit:
    """Result of :func:`bounded_least_squares`.

    Attributes
    ----------
    x : ndarray
        Solution (strictly inside the bounds).
    cost : float
        ``0.5 ||f(x)||^2``.
    nfev : int
        Evaluations of ``fun``.
    status : int
        0 evaluations exhausted, 1 gtol, 2 ftol, 3 xtol, 4 ftol and xtol.
    """

    x: np.ndarray
    cost: float
    nfev: int
    status: int

    @property
    def message(self) -> str:
        """The stopping test that ended the search, in words."""
        return MESSAGES[self.status]


def _descent_distance(x, g, lo, hi):
    """``v``: distance to the bound the descent direction points to (1 where that bound
    is infinite), and ``dv/dx`` (+-1 or 0)."""
    v, dv = np.ones_like(x), np.zeros_like(x)
    up = (g < 0) & np.isfinite(hi)
    down = (g > 0) & np.isfinite(lo)
    v[up], dv[up] = hi[up] - x[up], -1.0
    v[down], dv[down] = x[down] - lo[down], 1.0
    return v, dv


def _scaled(v, dv, cinv):
    """``v`` in the scaled variables ``x * cinv`` (where a bound applies)."""
    return np.where(dv != 0, v * cinv, v)


def _ball_minimiser(B, g, delta):
    """Minimiser of ``g.p + p.B.p / 2`` in ``||p|| <= delta`` (B symmetric)."""
    lam, V = np.linalg.eigh(B)
    a = V.T @ g
    if lam[0] > 0:
        p = -(a / lam)
        if np.linalg.norm(p) <= delta:
            return V @ p
        alpha = 0.0
    else:
        alpha = -lam[0] + 1e-12 * max(1.0, abs(lam[0]))
    for _ in range(50):               # Newton on 1/||p|| - 1/delta: monotone from the left
        den = lam + alpha
        pn = np.sqrt(np.sum((a / den) ** 2))
        if pn <= delta * (1 + 1e-3):
            break
        d1 = np.sum(a * a / den**3) / pn**3
        alpha -= (1.0 / pn - 1.0 / delta) / d1
    p = -(a / (lam + alpha))
    pn = np.linalg.norm(p)
    if pn < delta * (1 - 1e-3) and lam[0] <= 0:    # hard case: fill up with the lowest mode
        p[0] += np.sqrt(delta**2 - pn**2)
    return V @ p


def _strictly_inside(x, lo, hi):
    """``x`` with components on (or, by round-off, beyond) a bound moved to the nearest
    floating-point number inside."""
    return np.where(x <= lo, np.nextafter(lo, hi), np.where(x >= hi, np.nextafter(hi, lo), x))


def _model(B, g, p):
    """Value of the quadratic model ``g.p + p.B.p / 2``."""
    return float(g @ p + 0.5 * p @ (B @ p))


def _to_bound(x, s, lo, hi):
    """Largest t with x + t s inside [lo, hi] and whether each component binds there."""
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(s > 0, (hi - x) / s, np.where(s < 0, (lo - x) / s, np.inf))
    tmin = float(np.min(t)) if t.size else np.inf
    return tmin, t <= tmin * (1 + 1e-12)


def _segment_minimum(B, g, p0, r, tlo, thi):
    """Minimiser over t in [tlo, thi] of the model at p0 + t r."""
    b = float((g + B @ p0) @ r)
    c = float(r @ (B @ r))
    t = -b / c if c > 0 else (thi if b < 0 else tlo)
    return float(np.clip(t, tlo, thi))


def _inside_step(x, ph, d, lo, hi, B, gh, delta, theta):
    """Strictly feasible step (hat variables) from the ball minimiser ``ph``: itself,
    cut back at the first bound, reflected there, or the scaled gradient step."""
    t, binds = _to_bound(x, d * ph, lo, hi)
    if t > 1:
        return ph
    cands = [theta * t * ph]
    # reflection: from the bound, the binding components turn back
    p0 = t * ph
    rh = ph.copy()
    rh[binds] *= -1
    tb, _ = _to_bound(x + d * p0, d * rh, lo, hi)
    aa, bb, cc = rh @ rh, 2 * p0 @ rh, p0 @ p0 - delta**2      # ||p0 + s rh|| = delta
    disc = bb * bb - 4 * aa * cc
    ts = (-bb + np.sqrt(max(disc, 0.0))) / (2 * aa) if aa > 0 else 0.0
    hi_s = theta * tb if tb <= ts else ts
    if hi_s > 0:
        s = _segment_minimum(B, gh, p0, rh, (1 - theta) * hi_s, hi_s)
        cands.append(p0 + s * rh)
    # scaled gradient (Cauchy) step, inside the ball and the bounds
    gn = np.linalg.norm(gh)
    if gn > 0:
        tg, _ = _to_bound(x, -d * gh, lo, hi)
        hi_g = min(theta * tg, delta / gn)
        cands.append(-_segment_minimum(B, gh, 0 * gh, -gh, 0.0, hi_g) * gh)
    vals = [_model(B, gh, c) for c in cands]
    return cands[int(np.argmin(vals))]


def bounded_least_squares(fun: Callable, x0, lo, hi, ftol: float = 1e-8,
                          xtol: float = 1e-8, gtol: float = 1e-8,
                          max_nfev: int = 100) -> BoundedFit:
    """Minimise ``0.5 ||f(x)||^2`` with ``lo < x < hi`` (module notes for the method).

    Parameters
    ----------
    fun : callable
        ``fun(x) -> (f, J)``: residual (m,) and its Jacobian (m, n).
    x0 : array_like, shape (n,)
        Start, strictly inside the bounds.
    lo, hi : array_like, shape (n,)
        Bounds (``-inf``/``inf`` allowed).
    ftol, xtol, gtol : float
        Tolerances (module notes).
    max_nfev : int
        Evaluations of ``fun`` allowed.

    Returns
    -------
    BoundedFit
    """
    x = np.array(x0, float)
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    f, J = fun(x)
    nfev = 1
    cost = 0.5 * float(f @ f)
    g = J.T @ f
    cinv = np.linalg.norm(J, axis=0)
    cinv[cinv == 0] = 1.0
    v, dv = _descent_distance(x, g, lo, hi)
    delta = float(np.linalg.norm(x * cinv / np.sqrt(_scaled(v, dv, cinv)))) or 1.0
    status = None
    while True:
        v, dv = _descent_distance(x, g, lo, hi)
        gnorm = float(np.max(np.abs(g * v), initial=0.0))
        if gnorm < gtol:
            status = 1
        if status is not None or nfev >= max_nfev:
            break
        d = np.sqrt(_scaled(v, dv, cinv)) / cinv
        gh = d * g
        Jh = J * d
        B = Jh.T @ Jh + np.diag(g * dv / cinv)
        theta = max(0.995, 1 - gnorm)
        reduced = 0.0
        while reduced <= 0 and nfev < max_nfev:
            ph = _inside_step(x, _ball_minimiser(B, gh, delta), d, lo, hi, B, gh, delta,
                              theta)
            xn = _strictly_inside(x + d * ph, lo, hi)
            step = xn - x
            pred = -_model(B, gh, ph)
            fn, Jn = fun(xn)
            nfev += 1
            cost_n = 0.5 * float(fn @ fn)
            if not np.isfinite(cost_n):
                delta = 0.25 * float(np.linalg.norm(ph))
                continue
            reduced = cost - cost_n
            ratio = reduced / pred if pred > 0 else 0.0
            pnorm = float(np.linalg.norm(ph))
            if ratio < 0.25:
                delta = 0.25 * pnorm
            elif ratio > 0.75 and pnorm > 0.95 * delta:
                delta = 2.0 * delta
            ftol_met = reduced < ftol * cost and ratio > 0.25
            xtol_met = np.linalg.norm(step) < xtol * (xtol + np.linalg.norm(x))
            if ftol_met or xtol_met:
                status = 4 if ftol_met and xtol_met else (2 if ftol_met else 3)
                break
        if reduced > 0:
            x, f, J, cost = xn, fn, Jn, cost_n
            g = J.T @ f
            cinv = np.maximum(cinv, np.linalg.norm(J, axis=0))
    if status is None:
        status = 0
    return BoundedFit(x=x, cost=cost, nfev=nfev, status=status)
