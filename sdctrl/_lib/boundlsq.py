"""Bounded nonlinear least squares without importing ``scipy.optimize`` (internal).

``scipy.optimize``'s package import pulls shgo, linprog, scipy.spatial and scipy.constants:
0.4-0.6 s of a fresh process's first ``sd.identify`` call on a loaded 2-core machine, for
one function (``least_squares``).  :func:`trf_least_squares` is the same algorithm as
``scipy.optimize.least_squares(fun, x0, jac=jac, bounds=(lb, ub), method="trf",
x_scale="jac")`` with a dense Jacobian (``tr_solver="exact"``) and the linear loss: the
Trust Region Reflective method of Branch, Coleman & Li (1999) with Coleman-Li scaling,
an exact trust-region solve by one SVD per iteration (More 1977), reflected and
anti-gradient steps, step-back ratio ``theta`` from the bounds.  It performs the same
floating-point operations in the same order as scipy 1.17's ``_lsq/trf.py`` and
``_lsq/common.py``, so it returns the same iterates (checked against scipy in
``tests/test_boundlsq.py``).
"""

from __future__ import annotations

from dataclasses import dataclass
from math import copysign

import numpy as np
from numpy.linalg import norm

__all__ = ["TRFResult", "trf_least_squares"]

EPS = np.finfo(float).eps

#: scipy's messages of the termination statuses (``least_squares``)
MESSAGES = {
    0: "The maximum number of function evaluations is exceeded.",
    1: "`gtol` termination condition is satisfied.",
    2: "`ftol` termination condition is satisfied.",
    3: "`xtol` termination condition is satisfied.",
    4: "Both `ftol` and `xtol` termination conditions are satisfied.",
}


@dataclass(frozen=True, eq=False)
class TRFResult:
    """Outcome of :func:`trf_least_squares` (the fields of scipy's result used here)."""

    x: np.ndarray
    cost: float
    status: int
    nfev: int
    njev: int

    @property
    def message(self) -> str:
        """scipy's termination message of ``status``."""
        return MESSAGES[self.status]


def _step_size_to_bound(x, s, lb, ub):
    """Smallest positive t with x + t s on a bound; which components hit (-1, 0, +1)."""
    non_zero = np.nonzero(s)
    steps = np.full_like(x, np.inf)
    with np.errstate(over="ignore"):
        steps[non_zero] = np.maximum((lb - x)[non_zero] / s[non_zero],
                                     (ub - x)[non_zero] / s[non_zero])
    min_step = np.min(steps)
    return min_step, np.equal(steps, min_step) * np.sign(s).astype(int)


def _strictly_feasible(x, lb, ub, rstep):
    """Shift ``x`` inside the bounds by ``rstep`` relative (``nextafter`` when 0)."""
    x_new = x.copy()
    if rstep == 0:
        lower, upper = x <= lb, x >= ub
        x_new[lower] = np.nextafter(lb[lower], ub[lower])
        x_new[upper] = np.nextafter(ub[upper], lb[upper])
    else:
        lo_d, up_d = x - lb, ub - x
        lower = np.isfinite(lb) & (lo_d <= np.minimum(up_d, rstep * np.maximum(1, np.abs(lb))))
        upper = np.isfinite(ub) & (up_d <= np.minimum(lo_d, rstep * np.maximum(1, np.abs(ub))))
        lower &= ~upper
        x_new[lower] = lb[lower] + rstep * np.maximum(1, np.abs(lb[lower]))
        x_new[upper] = ub[upper] - rstep * np.maximum(1, np.abs(ub[upper]))
    tight = (x_new < lb) | (x_new > ub)
    x_new[tight] = 0.5 * (lb[tight] + ub[tight])
    return x_new


def _cl_scaling(x, g, lb, ub):
    """Coleman-Li scaling vector ``v`` and its derivative ``dv``."""
    v = np.ones_like(x)
    dv = np.zeros_like(x)
    mask = (g < 0) & np.isfinite(ub)
    v[mask] = ub[mask] - x[mask]
    dv[mask] = -1
    mask = (g > 0) & np.isfinite(lb)
    v[mask] = x[mask] - lb[mask]
    dv[mask] = 1
    return v, dv


def _quadratic(J, g, s, diag):
    """``0.5 s^T (J^T J + diag) s + g^T s``."""
    Js = J.dot(s)
    q = np.dot(Js, Js)
    q += np.dot(s * diag, s)
    return 0.5 * q + np.dot(s, g)


def _quadratic_1d(J, g, s, diag, s0=None):
    """Coefficients of the quadratic along ``s0 + t s`` (scipy's build_quadratic_1d)."""
    v = J.dot(s)
    a = np.dot(v, v)
    a += np.dot(s * diag, s)
    a *= 0.5
    b = np.dot(g, s)
    if s0 is None:
        return a, b, 0
    u = J.dot(s0)
    b += np.dot(u, v)
    c = 0.5 * np.dot(u, u) + np.dot(g, s0)
    b += np.dot(s0 * diag, s)
    c += 0.5 * np.dot(s0 * diag, s0)
    return a, b, c


def _minimize_1d(a, b, lb, ub, c=0):
    """Minimum (t, value) of ``a t^2 + b t + c`` on [lb, ub]."""
    t = [lb, ub]
    if a != 0:
        extremum = -0.5 * b / a
        if lb < extremum < ub:
            t.append(extremum)
    t = np.asarray(t)
    y = t * (a * t + b) + c
    k = np.argmin(y)
    return t[k], y[k]


def _tr_intersection(x, s, Delta):
    """Roots t of ||x + t s|| = Delta (negative, positive)."""
    a = np.dot(s, s)
    b = np.dot(x, s)
    c = np.dot(x, x) - Delta**2
    d = np.sqrt(b * b - a * c)
    q = -(b + copysign(d, b))
    t1, t2 = q / a, c / q
    return (t1, t2) if t1 < t2 else (t2, t1)


def _solve_trust_region(n, m, uf, s, V, Delta, alpha0):
    """More's trust-region solution from one SVD (scipy's solve_lsq_trust_region)."""
    def phi_and_derivative(alpha):
        denom = s**2 + alpha
        p_norm = norm(suf / denom)
        return p_norm - Delta, -np.sum(suf**2 / denom**3) / p_norm

    suf = s * uf
    full_rank = m >= n and s[-1] > EPS * m * s[0]
    if full_rank:
        p = -V.dot(uf / s)
        if norm(p) <= Delta:
            return p, 0.0
    alpha_upper = norm(suf) / Delta
    alpha_lower = 0.0
    if full_rank:
        phi, phi_prime = phi_and_derivative(0.0)
        alpha_lower = -phi / phi_prime
    if alpha0 is None or not full_rank and alpha0 == 0:
        alpha = max(0.001 * alpha_upper, (alpha_lower * alpha_upper)**0.5)
    else:
        alpha = alpha0
    for _ in range(10):
        if alpha < alpha_lower or alpha > alpha_upper:
            alpha = max(0.001 * alpha_upper, (alpha_lower * alpha_upper)**0.5)
        phi, phi_prime = phi_and_derivative(alpha)
        if phi < 0:
            alpha_upper = alpha
        ratio = phi / phi_prime
        alpha_lower = max(alpha_lower, alpha - ratio)
        alpha -= (phi + Delta) * ratio / Delta
        if np.abs(phi) < 0.01 * Delta:
            break
    p = -V.dot(suf / (s**2 + alpha))
    p *= Delta / norm(p)
    return p, alpha


@dataclass(frozen=True, eq=False)
class _Local:
    """The scaled ("hat") problem of one iteration."""

    x: np.ndarray
    J_h: np.ndarray
    diag_h: np.ndarray
    g_h: np.ndarray
    d: np.ndarray
    lb: np.ndarray
    ub: np.ndarray
    theta: float


def _reflected(L, p, p_h, Delta):
    """Bound-hitting part of the step and its reflection (value inf when unavailable)."""
    p_stride, hits = _step_size_to_bound(L.x, p, L.lb, L.ub)
    r_h = np.copy(p_h)
    r_h[hits.astype(bool)] *= -1
    r = L.d * r_h
    p *= p_stride
    p_h *= p_stride
    _, to_tr = _tr_intersection(p_h, r_h, Delta)
    to_bound, _ = _step_size_to_bound(L.x + p, r, L.lb, L.ub)
    r_stride = min(to_bound, to_tr)
    if r_stride > 0:
        r_lo = (1 - L.theta) * p_stride / r_stride
        r_up = L.theta * to_bound if r_stride == to_bound else to_tr
    else:
        r_lo, r_up = 0, -1
    if r_lo > r_up:
        return r, r_h, np.inf
    a, b, c = _quadratic_1d(L.J_h, L.g_h, r_h, L.diag_h, s0=p_h)
    r_stride, r_value = _minimize_1d(a, b, r_lo, r_up, c=c)
    r_h *= r_stride
    r_h += p_h
    return r_h * L.d, r_h, r_value


def _select_step(L, p, p_h, Delta):
    """Best of the trust-region, reflected and anti-gradient steps (scipy's select_step)."""
    if np.all((L.x + p >= L.lb) & (L.x + p <= L.ub)):
        return p, p_h, -_quadratic(L.J_h, L.g_h, p_h, L.diag_h)
    r, r_h, r_value = _reflected(L, p, p_h, Delta)
    p *= L.theta
    p_h *= L.theta
    p_value = _quadratic(L.J_h, L.g_h, p_h, L.diag_h)
    ag_h = -L.g_h
    ag = L.d * ag_h
    to_tr = Delta / norm(ag_h)
    to_bound, _ = _step_size_to_bound(L.x, ag, L.lb, L.ub)
    ag_stride = L.theta * to_bound if to_bound < to_tr else to_tr
    a, b, _ = _quadratic_1d(L.J_h, L.g_h, ag_h, L.diag_h)
    ag_stride, ag_value = _minimize_1d(a, b, 0, ag_stride)
    ag_h *= ag_stride
    ag *= ag_stride
    if p_value < r_value and p_value < ag_value:
        return p, p_h, -p_value
    if r_value < p_value and r_value < ag_value:
        return r, r_h, -r_value
    return ag, ag_h, -ag_value


def _termination(dF, F, dx_norm, x_norm, ratio, ftol, xtol):
    """scipy's check_termination: 2 (ftol), 3 (xtol), 4 (both) or None."""
    f_ok = dF < ftol * F and ratio > 0.25
    x_ok = dx_norm < xtol * (xtol + x_norm)
    if f_ok and x_ok:
        return 4
    return 2 if f_ok else (3 if x_ok else None)


def _jac_scale(J, scale_inv_old=None):
    scale_inv = np.sum(J**2, axis=0)**0.5
    if scale_inv_old is None:
        scale_inv[scale_inv == 0] = 1
    else:
        scale_inv = np.maximum(scale_inv, scale_inv_old)
    return 1 / scale_inv, scale_inv


@dataclass(frozen=True, eq=False)
class _Options:
    lb: np.ndarray
    ub: np.ndarray
    ftol: float
    xtol: float
    max_nfev: int


def _local(x, J, g, scale, scale_inv, g_norm, opt):
    """The scaled problem at ``x``: its SVD and the :class:`_Local` record."""
    import scipy.linalg as sla

    v, dv = _cl_scaling(x, g, opt.lb, opt.ub)
    v[dv != 0] *= scale_inv[dv != 0]
    d = v**0.5 * scale
    diag_h = g * dv * scale
    m, n = J.shape
    J_aug = np.empty((m + n, n))
    J_aug[:m] = J * d
    J_aug[m:] = np.diag(diag_h**0.5)
    U, s, VT = sla.svd(J_aug, full_matrices=False)
    L = _Local(x, J_aug[:m], diag_h, d * g, d, opt.lb, opt.ub, max(0.995, 1 - g_norm))
    return L, s, VT.T, U


def _inner(fun, L, svd, f, cost, state, opt):
    """Trial steps until the cost decreases (or termination); the accepted trial."""
    s, V, U = svd
    m, n = L.J_h.shape
    uf = U.T.dot(np.concatenate([f, np.zeros(n)]))
    Delta, alpha, nfev = state
    actual, status, x_new, f_new, cost_new = -1, None, None, None, None
    while actual <= 0 and nfev < opt.max_nfev:
        p_h, alpha = _solve_trust_region(n, m, uf, s, V, Delta, alpha)
        step, step_h, predicted = _select_step(L, L.d * p_h, p_h, Delta)
        x_new = _strictly_feasible(L.x + step, L.lb, L.ub, 0)
        f_new = fun(x_new)
        nfev += 1
        step_h_norm = norm(step_h)
        if not np.all(np.isfinite(f_new)):
            Delta = 0.25 * step_h_norm
            continue
        cost_new = 0.5 * np.dot(f_new, f_new)
        actual = cost - cost_new
        if predicted > 0:
            ratio = actual / predicted
        else:
            ratio = 1 if predicted == actual == 0 else 0
        Delta_new = Delta
        if ratio < 0.25:
            Delta_new = 0.25 * step_h_norm
        elif ratio > 0.75 and step_h_norm > 0.95 * Delta:
            Delta_new = 2.0 * Delta
        status = _termination(actual, cost, norm(step), norm(L.x), ratio, opt.ftol, opt.xtol)
        if status is not None:
            break
        alpha *= Delta / Delta_new
        Delta = Delta_new
    return actual, status, (x_new, f_new, cost_new), (Delta, alpha, nfev)


def trf_least_squares(fun, jac, x0, lb, ub, ftol=1e-8, xtol=1e-8, gtol=1e-8, max_nfev=None):
    """Minimise ``0.5 ||fun(x)||^2`` subject to ``lb <= x <= ub`` (Trust Region Reflective).

    Parameters
    ----------
    fun : callable
        ``fun(x) -> ndarray (m,)``, the residual.
    jac : callable
        ``jac(x) -> ndarray (m, n)``, its dense Jacobian.
    x0 : ndarray, shape (n,)
        Initial point, inside the bounds.
    lb, ub : ndarray, shape (n,)
        Bounds (finite or infinite), ``lb < ub``.
    ftol, xtol, gtol : float
        Tolerances of scipy's ``least_squares`` (same meanings).
    max_nfev : int, optional
        Evaluations of ``fun`` (default ``100 n``).

    Returns
    -------
    TRFResult
        ``x``, ``cost``, ``status`` (scipy's codes, > 0 converged), ``nfev``, ``njev``.
    """
    x = _strictly_feasible(np.asarray(x0, float), lb, ub, 1e-10)
    opt = _Options(lb, ub, ftol, xtol, x.size * 100 if max_nfev is None else max_nfev)
    f = fun(x)
    J = jac(x)
    nfev = njev = 1
    cost = 0.5 * np.dot(f, f)
    g = J.T.dot(f)
    scale, scale_inv = _jac_scale(J)
    v, dv = _cl_scaling(x, g, lb, ub)
    v[dv != 0] *= scale_inv[dv != 0]
    Delta = norm(x * scale_inv / v**0.5)
    state = (Delta if Delta != 0 else 1.0, 0.0, nfev)
    status = None
    while True:
        v, _ = _cl_scaling(x, g, lb, ub)
        g_norm = norm(g * v, ord=np.inf)
        if g_norm < gtol:
            status = 1
        if status is not None or state[2] == opt.max_nfev:
            break
        L, *svd = _local(x, J, g, scale, scale_inv, g_norm, opt)
        actual, status, new, state = _inner(fun, L, svd, f, cost, state, opt)
        if actual > 0:
            x, f, cost = new
            J = jac(x)
            njev += 1
            g = J.T.dot(f)
            scale, scale_inv = _jac_scale(J, scale_inv)
    return TRFResult(x=x, cost=float(cost), status=0 if status is None else status,
                     nfev=state[2], njev=njev)
