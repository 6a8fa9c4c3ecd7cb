"""Pole search for fixed data: cost (3.18), gradient (3.19), variable projection (3.2.1).

For fixed poles the residues solve the linear least-squares problem (3.16) (see
:mod:`sdctrl.identification._residues`); the quadratic cost (3.11) is then a function of the
poles only, ``J(lambda) = ||(I - P_Phi) Y||^2`` (3.18).  Two optimisers update the poles
(parameters ``ln omega_j`` and ``ln zeta_j``, so steps are relative):

``"gradient"``
    The thesis algorithm: the gradient (3.19) ``dJ/dtheta = 2 eps^T (dPhi/dtheta) R`` gives,
    for every parameter, whether it is over- or under-estimated; each parameter moves by
    its own step in the descent direction and its step is halved every time it passes
    over its optimum (sign change of its gradient component).
``"varpro"`` (default)
    Variable projection: the residues are eliminated inside the pole search and a
    bounded trust-region method (:func:`sdctrl._lib.trustregion.bounded_least_squares`:
    interior, reflective, Coleman-Li scaling; the bounds, Jacobian scaling and stopping
    tests of ``scipy.optimize.least_squares(method="trf", x_scale="jac")``, in numpy so
    that identification imports no scipy) minimises ``J`` over the poles with the
    Kaufman Jacobian ``-P_perp (dPhi/dtheta) R``.  The Jacobian is passed in a
    compact form (Cholesky factor of ``[J r]^T [J r]``) of size ``2n+1``, so the cost of an
    iteration does not grow with the number of frequency lines times sensors.

Internal module: the functions trust their inputs (validated by ``identify``).
"""

from __future__ import annotations

import numpy as np

from sdctrl._lib.triangular import solve_upper
from sdctrl._lib.trustregion import bounded_least_squares
from sdctrl.identification._residues import (
    LSQ,
    basis,
    basis_derivatives,
    n_per_pole,
    pole_from_params,
    stack,
)

__all__ = ["OUT_FACTOR", "ZETA_MAX", "ZETA_MIN", "PoleProblem", "SubProblem", "search_poles"]

#: damping bounds of every pole search
ZETA_MIN, ZETA_MAX = 1e-6, 0.6
#: out-of-band poles lie within this factor of the band edge (further, the asymptotic
#: terms E, F/s^2 carry a mode's tail in the band; a factor 10 gave the same fits on the
#: family of test structures with more poles at the far bounds)
OUT_FACTOR = 4.0


class PoleProblem:
    """Pole-search problem on real stacked data ``Y`` (2nf, k) at Laplace points ``s``.

    Parameters
    ----------
    Y : ndarray, shape (2 nf, k)
        Stacked (possibly compressed) data, normalised to unit norm here.
    s : ndarray, shape (nf,)
        Laplace points ``2 pi j f`` (rad/s).
    k : int
        Power of ``s`` of the measured quantity (0, 1, 2).
    model : {"complex", "real"}
        Parametrisation (3.7) or (3.9).
    asymptotic : (bool, bool)
        Whether the basis carries ``E`` and ``F/s^2``.
    bar : progress bar, optional
        Updated once per evaluation.
    weight : ndarray, shape (nf,), optional
        Weight of each line, already applied to ``Y`` (:mod:`._line_weights`): every basis
        on these lines is weighted alike.
    """

    def __init__(self, Y, s, k, model, asymptotic, bar=None, weight=None):
        # unit-norm data: the cost is relative, so optimiser tolerances are scale-free
        self.Y = Y / np.sqrt(max(float(np.sum(Y**2)), 1e-300))
        self.s, self.k, self.model, self.asym = s, k, model, asymptotic
        self.weight = weight
        self.normY2 = float(np.sum(self.Y**2))
        self.npp = n_per_pole(model)
        self.bar = bar
        self.nfev = 0
        self._cache = {}

    def evaluate(self, x, jac=False, free=None):
        """Cost, residual, coefficients, gradient (3.19) and, with ``jac``, the Gauss-Newton
        matrix, for the parameters ``free`` (indices into ``x``; all by default).

        Parameters
        ----------
        x : ndarray, shape (2 n,)
            ``[ln omega; ln zeta]`` of the ``n`` poles.
        jac : bool
            Also return the Gauss-Newton matrix ``"JtJ"``.
        free : ndarray of int, optional
            Parameters the gradient is taken for.

        Returns
        -------
        dict
            ``"cost"``, ``"r"`` (residual), ``"C"`` (coefficients), ``"lsq"`` (QR of the
            basis), ``"lam"`` (poles), ``"grad"`` and, with ``jac``, ``"JtJ"``.
        """
        key = (x.tobytes(), jac, None if free is None else free.tobytes())
        if key in self._cache:
            return self._cache[key]
        n = x.size // 2
        w, z = np.exp(x[:n]), np.exp(x[n:])
        lam = pole_from_params(w, z)
        Phi = basis(lam, self.s, self.k, self.model, self.asym, self.weight)
        lsq = LSQ(Phi)
        QtY = lsq.Q.T @ self.Y
        r = self.Y - lsq.Q @ QtY
        C = lsq.coefficients(QtY)
        cost = float(np.sum(r**2))
        out = {"cost": cost, "r": r, "C": C, "lsq": lsq, "lam": lam}
        self.nfev += 1
        if self.bar is not None:
            self.bar.update(1)
        self._derivatives(out, w, z, free, jac)
        self._cache = {key: out}
        return out

    def _derivatives(self, out, w, z, free, jac):
        """Gradient (3.19) and Gauss-Newton matrix of the Kaufman Jacobian; parameter
        par[a] (ln w_j for j < n, ln z_j for n + j) owns columns a*npp:(a+1)*npp of D."""
        lam, r, C, lsq = out["lam"], out["r"], out["C"], out["lsq"]
        n = w.size
        npp = self.npp
        par = np.arange(2 * n) if free is None else np.asarray(free)
        P = par.size
        if P == 0:                                     # no pole: nothing to differentiate
            out["grad"] = np.zeros(0)
            if jac:
                out["JtJ"] = np.zeros((0, 0))
            return
        poles_needed = np.unique(par % n)
        deriv = basis_derivatives(lam[poles_needed], w[poles_needed], z[poles_needed],
                                  self.s, self.k, self.model, self.weight)   # (2, nf, ., npp)
        D = stack(deriv[par // n, :, np.searchsorted(poles_needed, par % n)]
                  .transpose(1, 0, 2).reshape(self.s.size, P * npp))
        crow = (par % n)[:, None] * npp + np.arange(npp)[None, :]            # (P, npp)
        Cp = C[crow.ravel()]                                                # (P npp, k)
        Dr = D.T @ r                                                        # (P npp, k)
        g = -2.0 * np.sum((Dr * Cp).reshape(P, npp, -1), axis=(1, 2))       # dJ/dtheta (3.19)
        out["grad"] = g
        if jac:
            Dp = D - lsq.Q @ (lsq.Q.T @ D)                 # P_perp dPhi/dtheta
            G = (Dp.T @ Dp).reshape(P, npp, P, npp)
            CC = (Cp @ Cp.T).reshape(P, npp, P, npp)
            out["JtJ"] = np.einsum("aubv,aubv->ab", G, CC)


class SubProblem:
    """The pole search restricted to some poles, the others held at ``x_full``.

    The fixed poles and the asymptotic terms keep their columns during the search, so
    their QR factorisation ``[Q_f, R_ff]`` and the residual ``r_f`` of the data on them
    are computed once; an evaluation factorises only the free poles' columns
    orthogonalised against ``Q_f`` (block Gram-Schmidt, twice), ``Q = [Q_f, Q_n]``: the
    cost, the gradient (3.19) and the Gauss-Newton matrix are those of the full problem
    to round-off, at a fraction of its cost when few poles are free.

    Parameters
    ----------
    prob : PoleProblem
        The full problem.
    x_full : ndarray, shape (2 n,)
        Values of all the parameters.
    free : ndarray of int
        Indices of the parameters searched: ``[only, n + only]`` for the poles ``only``.
    """

    def __init__(self, prob, x_full, free):
        self.prob, self.x_full, self.free = prob, x_full, np.asarray(free)
        self.npp = prob.npp
        n = x_full.size // 2
        m = self.free.size // 2
        self.only = self.free[:m]
        fixed = np.setdiff1d(np.arange(n), self.only)
        lam_f = pole_from_params(np.exp(x_full[fixed]), np.exp(x_full[n + fixed]))
        A = stack(basis(lam_f, prob.s, prob.k, prob.model, prob.asym, prob.weight))
        scale = np.linalg.norm(A, axis=0)
        scale[scale == 0] = 1.0
        if A.shape[1]:
            self.Qf = np.linalg.qr(A / scale)[0]
        else:
            self.Qf = np.zeros((A.shape[0], 0))
        self.rf = prob.Y - self.Qf @ (self.Qf.T @ prob.Y)
        self._cache = {}

    @property
    def nfev(self):
        """Evaluations of the full problem."""
        return self.prob.nfev

    def evaluate(self, xs, jac=False):
        """Cost, residual, gradient (3.19) and, with ``jac``, the Gauss-Newton matrix with
        the free parameters set to ``xs`` (``"grad"`` and ``"JtJ"`` for those only).

        Parameters
        ----------
        xs : ndarray
            Values of the free parameters ``[ln w_only; ln z_only]``.
        jac : bool
            Also return the Gauss-Newton matrix.

        Returns
        -------
        dict
            ``"cost"``, ``"r"``, ``"grad"`` and, with ``jac``, ``"JtJ"``.
        """
        key = (xs.tobytes(), jac)
        if key in self._cache:
            return self._cache[key]
        prob, npp = self.prob, self.npp
        m = xs.size // 2
        w, z = np.exp(xs[:m]), np.exp(xs[m:])
        lam = pole_from_params(w, z)
        A = stack(basis(lam, prob.s, prob.k, prob.model, (False, False), prob.weight))
        scale = np.linalg.norm(A, axis=0)
        scale[scale == 0] = 1.0
        A = A / scale
        for _ in range(2):                             # block Gram-Schmidt, twice
            A = A - self.Qf @ (self.Qf.T @ A)
        Qn, Rn = np.linalg.qr(A)
        QtY = Qn.T @ self.rf
        r = self.rf - Qn @ QtY
        Cn = solve_upper(Rn, QtY) / scale[:, None]
        out = {"cost": float(np.sum(r**2)), "r": r}
        prob.nfev += 1
        if prob.bar is not None:
            prob.bar.update(1)
        deriv = basis_derivatives(lam, w, z, prob.s, prob.k, prob.model,
                                  prob.weight)                   # (2, nf, m, npp)
        D = stack(deriv.transpose(1, 0, 2, 3).reshape(prob.s.size, 2 * m * npp))
        Cp = np.concatenate([Cn, Cn])                  # rows of param a: pole a % m
        Dr = D.T @ r
        out["grad"] = -2.0 * np.sum((Dr * Cp).reshape(2 * m, npp, -1), axis=(1, 2))
        if jac:
            Dp = D - self.Qf @ (self.Qf.T @ D)
            Dp = Dp - Qn @ (Qn.T @ Dp)                 # P_perp dPhi/dtheta
            P = 2 * m
            G = (Dp.T @ Dp).reshape(P, npp, P, npp)
            CC = (Cp @ Cp.T).reshape(P, npp, P, npp)
            out["JtJ"] = np.einsum("aubv,aubv->ab", G, CC)
        self._cache = {key: out}
        return out


def _compact(ev):
    """Residual/Jacobian of size 2n+1 with the same J^T J, J^T f and ||f|| (Kaufman VP)."""
    JtJ, Jtf, ff = ev["JtJ"], 0.5 * ev["grad"], ev["cost"]
    P = JtJ.shape[0]
    d = np.sqrt(np.maximum(np.diag(JtJ), 1e-300))
    Gs = JtJ / d[:, None] / d[None, :] + 1e-13 * np.eye(P)
    try:
        Rs = np.linalg.cholesky(Gs).T                      # Rs^T Rs = Gs
    except np.linalg.LinAlgError:
        ew, EV = np.linalg.eigh(Gs)
        Rs = np.sqrt(np.clip(ew, 1e-13, None))[:, None] * EV.T
    R11 = Rs * d[None, :]                                 # R11^T R11 = JtJ
    r12 = np.linalg.solve(R11.T, Jtf)
    r22 = np.sqrt(max(ff - float(r12 @ r12), 0.0))
    Jc = np.vstack([R11, np.zeros((1, P))])
    fc = np.concatenate([r12, [r22]])
    return fc, Jc


def _varpro(prob, x0, lo, hi, max_iter, tol):
    """Variable projection: the bounded trust-region method of
    :func:`sdctrl._lib.trustregion.bounded_least_squares` on the compact residual of
    :func:`_compact` (scaled by the Jacobian's column norms; ftol = xtol = gtol = tol)."""

    def fun(x):
        return _compact(prob.evaluate(x, jac=True))

    res = bounded_least_squares(fun, x0, lo, hi, ftol=tol, xtol=tol, gtol=tol,
                                max_nfev=max_iter)
    return res.x, {"status": res.status, "nfev": res.nfev, "converged": res.status > 0,
                   "message": res.message}


def _gradient(prob, x0, lo, hi, max_iter, tol):
    """Thesis pole update (3.19): each parameter moves by its own step against the sign of
    its gradient component; the step is halved every time the parameter passes over its
    optimum (sign change).  Steps that keep their sign grow by 1.2 (the Rprop rule), which
    the thesis' fixed initial step lacks and which saves many iterations."""
    n = x0.size // 2
    x = x0.copy()
    z0 = np.exp(x0[n:])
    # initial steps: a quarter of the half-power bandwidth in frequency, 30% in damping
    step = np.concatenate([np.clip(0.25 * z0, 1e-5, 0.02), np.full(n, 0.3)])
    smax = step * 4
    tol_x = np.concatenate([np.full(n, max(tol, 1e-13) * 100), np.full(n, tol * 1e4)])
    ev = prob.evaluate(x)
    prev = np.zeros_like(x)
    it = 0
    converged = False
    for it in range(1, max_iter + 1):
        sg = np.sign(ev["grad"])
        flip = sg * prev < 0
        same = sg * prev > 0
        step[flip] *= 0.5                                  # passed over the optimum
        step[same] = np.minimum(step[same] * 1.2, smax[same])
        sg[flip] = 0.0                                     # iRprop-: wait one iteration
        xn = np.clip(x - sg * step, lo, hi)
        evn = prob.evaluate(xn)
        if evn["cost"] <= ev["cost"]:
            x, ev, prev = xn, evn, sg
        else:                                              # overshoot: shorter steps
            step *= 0.5
            prev = np.zeros_like(x)
        if np.all(step < tol_x):
            converged = True
            break
    return x, {"status": int(converged), "nfev": prob.nfev, "iterations": it,
               "converged": converged,
               "message": "steps below tolerance" if converged else "max_iter reached"}


def _bounds(prob, w, z, side, fband):
    """Bounds (lo, hi) of ``[ln w; ln z]``: in-band poles near their guess, out-of-band
    poles held outside the band (``side`` 0 in band, -1 below, +1 above)."""
    n = w.size
    fl = np.abs(prob.s) / (2 * np.pi)
    dw_line = 2 * np.pi * float(np.median(np.diff(fl))) if fl.size > 1 else 0.0
    wlo, whi = 2 * np.pi * fband[0], 2 * np.pi * fband[1]
    lo = np.empty(2 * n)
    hi = np.empty(2 * n)
    for j in range(n):
        if side[j] == 0:
            # in band: the band, and (thesis 3.2.1: "only allowing solutions near the
            # guess") within +-max(5 half-power bandwidths, 4 lines) of the initial pole
            dw = max(5 * z[j] * w[j], 4 * dw_line, 1e-3 * w[j])
            lo[j], hi[j] = np.log(max(wlo, w[j] - dw)), np.log(min(whi, w[j] + dw))
        elif side[j] < 0:
            lo[j], hi[j] = np.log(wlo / OUT_FACTOR), np.log(wlo)
        else:
            lo[j], hi[j] = np.log(whi), np.log(OUT_FACTOR * whi)
    lo[n:], hi[n:] = np.log(ZETA_MIN), np.log(ZETA_MAX)
    inb = side == 0
    # in-band damping within a factor 20 of the guess (at most 0.05 above it)
    hi[n:][inb] = np.log(np.minimum(ZETA_MAX, np.maximum(20 * z[inb], 0.05)))
    return lo, hi


def search_poles(prob, w, z, side, fband, optimizer, max_iter, tol, only=None):
    """Optimise poles (w rad/s, z) with bounds from ``side`` (0 in band, -1 below, +1 above).

    Parameters
    ----------
    prob : PoleProblem
        The cost to minimise.
    w, z : ndarray, shape (n,)
        Initial natural frequencies (rad/s) and damping ratios.
    side : ndarray of int, shape (n,)
        0 for in-band poles, -1/+1 for poles held below/above the band.
    fband : (float, float)
        Band in Hz.
    optimizer : {"varpro", "gradient", "none"}
        Pole update (see the module notes); "none" returns the initial poles.
    max_iter : int
        Evaluations (varpro) or iterations (gradient).
    tol : float
        Relative tolerance.
    only : array_like of int, optional
        Restricts the search to those poles, the others fixed.

    Returns
    -------
    w, z : ndarray, shape (n,)
        Optimised poles.
    info : dict
        ``"converged"``, ``"nfev"``, ``"status"``, ``"message"`` and ``"at_bound"`` (bool
        per pole: pushed to a bound of the search).
    """
    n = w.size
    if n == 0 or optimizer == "none":
        return w.copy(), z.copy(), {"converged": True, "nfev": 0, "status": 1}
    lo, hi = _bounds(prob, w, z, side, fband)
    x0 = np.concatenate([np.log(w), np.log(z)])
    eps = 1e-9 * (hi - lo)
    x0 = np.clip(x0, lo + eps, hi - eps)
    run = _varpro if optimizer == "varpro" else _gradient
    if only is None:
        x, info = run(prob, x0, lo, hi, max_iter, tol)
    else:
        only = np.asarray(only, int)
        free = np.concatenate([only, n + only])
        xs, info = run(SubProblem(prob, x0, free), x0[free], lo[free], hi[free], max_iter, tol)
        x = x0.copy()
        x[free] = xs
    w, z = np.exp(x[:n]), np.exp(x[n:])
    span = hi - lo
    at_bound = (np.minimum(x[:n] - lo[:n], hi[:n] - x[:n]) < 1e-7 * span[:n]) | \
               (np.minimum(x[n:] - lo[n:], hi[n:] - x[n:]) < 1e-7 * span[n:])
    info["at_bound"] = at_bound
    return w, z, info
