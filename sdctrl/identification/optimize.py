"""Complex-mode identification: pole update and automatic pole selection (thesis 3.2.1).

For fixed poles the residues solve the linear least-squares problem (3.16) (see
:mod:`sdctrl.identification.residues`); the quadratic cost (3.11) is then a function of the
poles only, ``J(lambda) = ||(I - P_Phi) Y||^2`` (3.18).  Two optimisers update the poles
(parameters ``ln omega_j`` and ``ln zeta_j``, so steps are relative):

``"gradient"``
    The thesis algorithm: the gradient (3.19) ``dJ/dtheta = 2 eps^T (dPhi/dtheta) R`` gives,
    for every parameter, whether it is over- or under-estimated; each parameter moves by
    its own step in the descent direction and its step is halved every time it passes
    over its optimum (sign change of its gradient component).
``"varpro"`` (default)
    Variable projection: the residues are eliminated inside the pole search and
    ``scipy.optimize.least_squares`` (trust region, bounds) minimises ``J`` over the poles
    with the Kaufman Jacobian ``-P_perp (dPhi/dtheta) R``.  The Jacobian is passed in a
    compact form (Cholesky factor of ``[J r]^T [J r]``) of size ``2n+1``, so the cost of an
    iteration does not grow with the number of frequency lines times sensors.

Scale: the stacked data ``Y = [Re H; Im H]`` (2 nf x ns na) only enter the pole search
through their dominant column space; ``Y`` is compressed once to ``Y V`` with ``V`` a
real orthonormal basis (exact SVD for small sets, randomised range finder otherwise),
so that the pole search costs the same for 10 or 10,000 sensors and residues stay real.
The final residues are solved on the full data (cost linear in the number of sensors).

With no poles given, :func:`identify` starts from :func:`~sdctrl.identification.initial_poles`
and iterates: add a pole where the residual shows a missed mode, drop poles that do not
converge (pushed to a bound), fit noise (half-power bandwidth below a fraction of the line
spacing), are in-band fillers with very large damping or are not statistically
significant, and try out-of-band poles just below and above the band (held outside by
bounds) that absorb modes the asymptotic terms ``E``, ``F/s^2`` cannot represent.  A
side's trial is repeated whenever the in-band pole set has changed since its last
trial: on a first fit that still misses in-band modes (common with single-reference
data, whose indicator functions propose fewer candidates), their residual pulls the
trial pole to a bound, and the out-of-band mode is only found once they are fitted.

Significance on noisy data.  Noise in real tests is heteroscedastic: multiplicative
(larger at peaks), an additive floor (dominant at antiresonances and, for accelerations,
at low frequency), and unequal between channels.  A pole is kept, and a residual peak
becomes a candidate, only if its cost change exceeds what pure noise would give:

* the noise variance per line and data column is estimated locally and robustly
  (running medians of the residual over ``max(41, nf/20)`` lines, standardised by the
  leverage ``h`` of each line, ``|r|^2 / (1 - h)``, since a pole absorbs part of the noise
  of the lines it fits), as the larger of an additive level and a level proportional to
  a shape: the point variance ``|H|^2 (1 - coherence)`` (3.59) when ``frf.coherence`` is
  given, else the fitted ``|H|^2`` (multiplicative noise);
* it is weighted by the diagonal of the projector on the pole's columns (orthogonalised
  against the other poles): a pole on a peak meets the noise of the peak;
* the cost change of a noise-fitting pole, ``sum_c s_c chi2(npp)`` over the data
  columns, is approximated by a scaled chi-square with the same mean and variance
  (Welch-Satterthwaite), so that a few noisy channels give the heavier tail they have;
  the threshold is its ``1e-3/nf`` quantile (the pole could sit at any line) times
  ``significance`` (2 by default, covering the two nonlinear parameters fitted).

Initial candidates far below this threshold (noise peaks of the indicator functions)
are dropped before the first fit, and isolated insignificant poles are removed together,
so the add/remove loop (at most 20 rounds) stays short.  The rank-one test of the
residues (3.2.2, :meth:`ComplexModeModel.singular_value_ratios`) is not used to reject
poles: a real mode at the noise level (a weak local mode) has a far-from-dyadic residue
too, single-input data carry no such information, and the significance test already
rejects the noise poles it would catch.
"""

from __future__ import annotations

import warnings

import numpy as np
from threadpoolctl import threadpool_limits

from sdctrl._validate import QUANTITY_POWER, as_array
from sdctrl.identification.residues import (
    LSQ,
    basis,
    basis_derivatives,
    coefficients_to_model,
    n_per_pole,
    pole_from_params,
    stack,
)

__all__ = ["IdentificationWarning", "identify"]

_ZMIN, _ZMAX = 1e-6, 0.6


class IdentificationWarning(UserWarning):
    """Numerical trouble during identification (ill-conditioning, no convergence, ...)."""


# ---------------------------------------------------------------------------------------
# data compression
# ---------------------------------------------------------------------------------------
def compress(Hm: np.ndarray, rank: int, seed=0, power: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """Real orthonormal basis ``V`` (m, r) of the dominant row space of ``Y = [Re H; Im H]``.

    Exact (SVD) when ``m`` is small, otherwise a randomised range finder with ``power``
    subspace iterations (Halko, Martinsson & Tropp 2011); columns are ordered by
    decreasing singular value, which are returned too.
    """
    nf, m = Hm.shape
    rank = int(min(rank, m, 2 * nf))
    if m <= max(3 * rank, 300):
        Y = stack(Hm)
        if 2 * nf >= m:
            ev, W = np.linalg.eigh(Y.T @ Y)
            order = np.argsort(ev)[::-1][:rank]
            return W[:, order], np.sqrt(np.clip(ev[order], 0, None))
        _, sv, Vt = np.linalg.svd(Y, full_matrices=False)
        return Vt[:rank].T.copy(), sv[:rank]
    rng = np.random.default_rng(seed)
    ell = min(m, rank + 10)
    Om = rng.standard_normal((nf, ell)) + 1j * rng.standard_normal((nf, ell))
    Z = (Hm.conj().T @ Om).real                       # Y^T Omega, without stacking Y
    V, _ = np.linalg.qr(Z)
    for _ in range(power):
        W = Hm @ V                                    # Y V as complex (nf, ell)
        Z = Hm.real.T @ W.real + Hm.imag.T @ W.imag   # Y^T (Y V)
        V, _ = np.linalg.qr(Z)
    W = stack(Hm @ V)
    _, sv, Vt = np.linalg.svd(W, full_matrices=False)
    return (V @ Vt.T)[:, :rank], sv[:rank]


# ---------------------------------------------------------------------------------------
# pole search on (compressed) real data
# ---------------------------------------------------------------------------------------
class _Problem:
    """Pole-search problem on real stacked data ``Y`` (2nf, k) at Laplace points ``s``."""

    def __init__(self, Y, s, k, model, asymptotic, bar=None):
        # unit-norm data: the cost is relative, so optimiser tolerances are scale-free
        self.Y = Y / np.sqrt(max(float(np.sum(Y**2)), 1e-300))
        self.s, self.k, self.model, self.asym = s, k, model, asymptotic
        self.normY2 = float(np.sum(self.Y**2))
        self.npp = n_per_pole(model)
        self.bar = bar
        self.nfev = 0
        self._cache = {}

    def evaluate(self, x, jac=False, free=None):
        """Cost, residual, coefficients, gradient (3.19) and, with ``jac``, the Gauss-Newton
        matrix, for the parameters ``free`` (indices into ``x``; all by default)."""
        key = (x.tobytes(), jac, None if free is None else free.tobytes())
        if key in self._cache:
            return self._cache[key]
        n = x.size // 2
        w, z = np.exp(x[:n]), np.exp(x[n:])
        lam = pole_from_params(w, z)
        Phi = basis(lam, self.s, self.k, self.model, self.asym)
        lsq = LSQ(Phi)
        QtY = lsq.Q.T @ self.Y
        r = self.Y - lsq.Q @ QtY
        C = lsq.coefficients(QtY)
        cost = float(np.sum(r**2))
        out = {"cost": cost, "r": r, "C": C, "lsq": lsq, "lam": lam}
        self.nfev += 1
        if self.bar is not None:
            self.bar.update(1)
        # gradient (3.19) and Gauss-Newton matrix of the Kaufman Jacobian; parameter
        # par[a] (ln w_j for j < n, ln z_j for n + j) owns columns a*npp:(a+1)*npp of D
        npp = self.npp
        par = np.arange(2 * n) if free is None else np.asarray(free)
        P = par.size
        poles_needed = np.unique(par % n)
        deriv = basis_derivatives(lam[poles_needed], w[poles_needed], z[poles_needed],
                                  self.s, self.k, self.model)      # (2, nf, needed, npp)
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
        self._cache = {key: out}
        return out


class _SubProblem:
    """The pole search restricted to some parameters, the others held at ``x_full``."""

    def __init__(self, prob, x_full, free):
        self.prob, self.x_full, self.free = prob, x_full, free
        self.npp = prob.npp

    @property
    def nfev(self):
        return self.prob.nfev

    def evaluate(self, xs, jac=False):
        x = self.x_full.copy()
        x[self.free] = xs
        return self.prob.evaluate(x, jac, self.free)


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
    from scipy.optimize import least_squares

    def fun(x):
        return _compact(prob.evaluate(x, jac=True))[0]

    def jac(x, *_):
        return _compact(prob.evaluate(x, jac=True))[1]

    res = least_squares(fun, x0, jac=jac, bounds=(lo, hi), method="trf", x_scale="jac",
                        ftol=tol, xtol=tol, gtol=tol, max_nfev=max_iter)
    return res.x, {"status": int(res.status), "nfev": int(res.nfev),
                   "converged": bool(res.status > 0), "message": str(res.message)}


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


def _search(prob, w, z, side, fband, optimizer, max_iter, tol, only=None):
    """Optimise poles (w rad/s, z) with bounds from ``side`` (0 in band, -1 below, +1 above).

    ``only`` (indices of poles) restricts the search to those poles, the others fixed.
    """
    n = w.size
    fl = np.abs(prob.s) / (2 * np.pi)
    dw_line = 2 * np.pi * float(np.median(np.diff(fl))) if fl.size > 1 else 0.0
    if n == 0 or optimizer == "none":
        return w.copy(), z.copy(), {"converged": True, "nfev": 0, "status": 1}
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
            lo[j], hi[j] = np.log(wlo / 4), np.log(wlo)
        else:
            lo[j], hi[j] = np.log(whi), np.log(4 * whi)
    lo[n:], hi[n:] = np.log(_ZMIN), np.log(_ZMAX)
    inb = side == 0
    # in-band damping within a factor 20 of the guess (at most 0.05 above it)
    hi[n:][inb] = np.log(np.minimum(_ZMAX, np.maximum(20 * z[inb], 0.05)))
    x0 = np.concatenate([np.log(w), np.log(z)])
    eps = 1e-9 * (hi - lo)
    x0 = np.clip(x0, lo + eps, hi - eps)
    run = _varpro if optimizer == "varpro" else _gradient
    if only is None:
        x, info = run(prob, x0, lo, hi, max_iter, tol)
    else:
        only = np.asarray(only, int)
        free = np.concatenate([only, n + only])
        xs, info = run(_SubProblem(prob, x0, free), x0[free], lo[free], hi[free], max_iter, tol)
        x = x0.copy()
        x[free] = xs
    w, z = np.exp(x[:n]), np.exp(x[n:])
    span = hi - lo
    at_bound = (np.minimum(x[:n] - lo[:n], hi[:n] - x[:n]) < 1e-7 * span[:n]) | \
               (np.minimum(x[n:] - lo[n:], hi[n:] - x[n:]) < 1e-7 * span[n:])
    info["at_bound"] = at_bound
    return w, z, info


# ---------------------------------------------------------------------------------------
# automatic pole selection
# ---------------------------------------------------------------------------------------
def _running_median(X: np.ndarray, win: int) -> np.ndarray:
    """Running median over ``win`` lines (axis 0, edges held), per column of ``X`` (nf, k).

    Evaluated every ``win // 8`` lines and interpolated linearly in between: the noise
    level is smooth on the scale of the window, and the cost is ``8 nf k`` instead of
    ``nf k win``."""
    nf = X.shape[0]
    win = int(min(win, nf))
    half = win // 2
    step = max(1, win // 8)
    Xp = np.concatenate([np.repeat(X[:1], half, axis=0), X,
                         np.repeat(X[-1:], win - 1 - half, axis=0)])
    centres = np.unique(np.append(np.arange(0, nf, step), nf - 1))
    view = np.lib.stride_tricks.sliding_window_view(Xp, win, axis=0)   # (nf, k, win)
    # median by one partition (np.median's own path is several times slower here and
    # gives the same numbers: the middle element, or the mean of the two middle ones)
    h = win // 2
    if win % 2:
        med = np.partition(view[centres], h, axis=-1)[..., h]            # (nc, k)
    else:
        part = np.partition(view[centres], [h - 1, h], axis=-1)
        med = np.mean(part[..., h - 1:h + 1], axis=-1)
    if centres.size == nf:
        return med
    t = np.arange(nf)
    j = np.clip(np.searchsorted(centres, t, side="right") - 1, 0, centres.size - 2)
    a = ((t - centres[j]) / (centres[j + 1] - centres[j]))[:, None]
    return (1 - a) * med[j] + a * med[j + 1]


class _Auto:
    """Add/remove loop of :func:`identify` when no poles are given."""

    def __init__(self, prob, freq, fband, optimizer, max_iter, tol, min_bandwidth, zeta_max,
                 significance, warn, shape=None):
        self.prob, self.freq, self.fband = prob, freq, fband
        self.shape = shape                      # noise shape (nf, k) from the coherence
        self.win = max(41, freq.size // 20)     # running-median window of the noise
        self.optimizer, self.max_iter, self.tol = optimizer, max_iter, tol
        self.df = float(np.median(np.diff(freq)))
        self.min_bw, self.zeta_max, self.signif = min_bandwidth, zeta_max, significance
        self.log = []
        self.warn = warn
        self.tried = []
        self.best = None
        self._trials = {}                       # trial-pole bases of the residual scan

    def fit(self, w, z, side, only=None):
        w, z, info = _search(self.prob, w, z, side, self.fband, self.optimizer,
                             self.max_iter, self.tol, only)
        if not info.get("converged", True):
            self.log.append(("not converged", info.get("message", "")))
        x = np.concatenate([np.log(w), np.log(z)])
        ev = self.prob.evaluate(x)
        return w, z, ev, info

    def noise_field(self, r, Yfit, Q):
        """Heteroscedastic noise variance ``E[r_re^2 + r_im^2]`` per line and data column.

        Two robust local estimates (running medians over ``self.win`` lines of the
        residual ``r`` standardised by the leverage ``h`` of each line of the current basis
        ``Q``, ``e = |r|^2 / (1 - h)``, corrected by ``1/ln 2``, the mean/median ratio of the exponential
        law of ``r_re^2 + r_im^2``), the larger of which is kept at every line:

        * an additive level, ``median(e)`` (noise floor, antiresonances);
        * a level proportional to a shape ``s(f)``: ``median(e/s) s``, with ``s`` the
          point variance ``|H|^2 (1 - coherence)`` (3.59) when the coherence is known,
          else the fitted response ``|Y_fit|^2`` (multiplicative noise, larger at peaks).
        """
        nf = r.shape[0] // 2
        lev = np.sum(Q * Q, axis=1)
        lev = 0.5 * (lev[:nf] + lev[nf:])                    # leverage of each line
        e = (r[:nf] ** 2 + r[nf:] ** 2) / np.maximum(1.0 - lev, 0.05)[:, None]
        shape = self.shape if self.shape is not None else Yfit[:nf] ** 2 + Yfit[nf:] ** 2
        tiny = 1e-300 + 1e-30 * float(np.max(shape))
        add = _running_median(e, self.win)
        mult = _running_median(e / (shape + tiny), self.win) * shape
        return np.maximum(add, mult) / np.log(2.0)

    def noise(self, ev):
        """:meth:`noise_field` of the fit ``ev``, computed once per fit (the pruning test,
        the residual scan and the acceptance of new poles meet the same fit)."""
        if "sig2" not in ev:
            r = ev["r"]
            ev["sig2"] = self.noise_field(r, self.prob.Y - r, ev["lsq"].Q)
        return ev["sig2"]

    def _threshold(self, s):
        """Noise threshold of a pole's cost change from per-column variances ``s`` (.., k).

        For pure noise the change is ``sum_c s_c chi2(npp)`` (``s_c`` the variance seen
        through the pole's projection in column ``c``); its law is approximated by a
        scaled ``g chi2(h)`` with the same mean and variance (Welch-Satterthwaite), so
        that columns with unequal noise (a few dominate) give the heavier tail they
        have.  The quantile is ``1e-3 / nf`` (the pole could sit at any line) and
        ``significance`` multiplies it.
        """
        from scipy.stats import chi2

        npp = self.prob.npp
        s1 = np.sum(s, axis=-1)
        s2 = np.maximum(np.sum(s * s, axis=-1), 1e-300)
        g = s2 / np.maximum(s1, 1e-300)
        h = np.maximum(npp * s1 * s1 / s2, 1e-3)
        return self.signif * g * chi2.isf(1e-3 / max(self.freq.size, 1), df=h)

    @staticmethod
    def _proj_diag(G):
        """Diagonal of the projector on the columns of ``G`` (2nf, npp) per trial.

        ``G`` has shape (2nf, T, npp); returns (2nf, T)."""
        if G.shape[-1] == 1:
            g = G[..., 0]
            return g * g / np.maximum(np.sum(g * g, axis=0), 1e-300)
        g0, g1 = G[..., 0], G[..., 1]
        a = np.sum(g0 * g0, axis=0)
        b = np.sum(g0 * g1, axis=0)
        c = np.sum(g1 * g1, axis=0)
        return (c * g0 * g0 - 2 * b * g0 * g1 + a * g1 * g1) / np.maximum(a * c - b * b,
                                                                           1e-300)

    def significance(self, w, z, ev):
        """Cost increase when each pole is removed, over its noise threshold (>1 keeps).

        The noise is estimated (:meth:`noise_field`) from the residual of the full model,
        standardised by the leverage of each line (a pole absorbs part of the noise of
        the lines it fits: ``E r_i^2 = sigma_i^2 (1 - h_i)``), and weighted by where the
        pole's basis function lives (diagonal of the projector on its columns orthogonal
        to the others), so that a pole on a peak is compared with the larger noise at
        the peak and a pole in a noise floor with that floor.
        """
        import scipy.linalg as sla

        prob = self.prob
        n = w.size
        npp = prob.npp
        nf = self.freq.size
        floor = 1e-11 * prob.normY2
        lsq = ev["lsq"]
        # one QR for all the poles: with A = Q R (scaled columns), the part of pole j's
        # columns S orthogonal to the others is B = Q R^-T[:, S] M_SS^-1 (M = R^-1 R^-T),
        # B^T B = M_SS^-1, and removing j raises the cost by tr(C_S^T M_SS^-1 C_S) and
        # the residual by B C_S (C: coefficients of the scaled columns)
        Rinv = sla.solve_triangular(lsq.Rr, np.eye(lsq.Rr.shape[0]), check_finite=False)
        W = lsq.Q @ Rinv.T
        M = Rinv @ Rinv.T
        Cs = sla.solve_triangular(lsq.Rr, lsq.Q.T @ prob.Y, check_finite=False)
        sig2 = self.noise(ev)
        dJ = np.empty(n)
        sc = np.empty((n, sig2.shape[1]))
        for j in range(n):
            S = np.arange(j * npp, (j + 1) * npp)
            MSS = M[np.ix_(S, S)]
            Ginv = np.linalg.inv(MSS)
            B = W[:, S] @ Ginv
            dJ[j] = float(np.sum(Cs[S] * (Ginv @ Cs[S])))
            d = np.sum((B @ MSS) * B, axis=1)                           # projector diagonal
            dl = d[:nf] + d[nf:]
            sc[j] = 0.5 * (dl @ sig2) / npp                     # per column
        return dJ / np.maximum(self._threshold(sc), floor)

    def prune(self, w, z, side, ev, info):
        f = w / (2 * np.pi)
        reasons = self._rejected(w, z, side, info)
        if not reasons:
            sig = self.significance(w, z, ev)
            weak = np.flatnonzero(sig < 1.0)
            if weak.size:
                # the weakest, and with it every clearly insignificant pole with no other
                # pole nearby (two poles sharing one mode each look insignificant)
                isolated = [j for j in weak if sig[j] < 0.5 and not np.any(
                    (np.arange(w.size) != j)
                    & (np.abs(f - f[j]) < max(10 * self.df, 10 * z[j] * f[j])))]
                for j in {int(weak[np.argmin(sig[weak])]), *isolated}:
                    reasons[j] = f"not significant (cost change {sig[j]:.3g} x noise threshold)"
        if not reasons:
            return None
        drop = np.array(sorted(reasons))
        for j in drop:
            self.log.append(("removed", float(f[j]), float(z[j]), reasons[j]))
            self.tried.append(float(f[j]))
        keep = np.ones(w.size, bool)
        keep[drop] = False
        return w[keep], z[keep], side[keep]

    def _trial_basis(self, key, fl, zl):
        """Stacked basis of the scan's trial poles (frequencies ``fl`` Hz, damping ``zl``),
        kept between scans when the whole grid takes at most ``2^23`` numbers: the
        trial poles do not depend on the current model."""
        G = self._trials.get(key)
        if G is None:
            prob = self.prob
            lam = pole_from_params(2 * np.pi * fl, zl)
            G = stack(basis(lam, prob.s, prob.k, prob.model, (False, False)))
            # four damping levels, about 1 + 1/2 + 1/4 + 1/16 trials per line
            if 2 * prob.s.size * 1.9 * self.freq.size * prob.npp <= 2**23:
                self._trials[key] = G
        return G

    def missed(self, w, z, ev, max_add=6, chunk=256):
        """Missed modes (frequency Hz, damping): a matched-filter scan of the residual.

        For a trial pole on a grid of lines (four damping levels, half-power bandwidths of
        2, 8, 32 and 128 lines, capped at 5% damping) the cost decrease of adding it with fixed parameters,
        ``||(G_p^T G_p)^-1/2 G_p^T r||^2`` with ``G_p`` its basis orthogonalised against the
        current one, is compared with the significance threshold of :meth:`significance`
        (noise level from the running median of the residual).  Local maxima above the
        threshold are returned, strongest first.
        """
        from scipy.signal import argrelmax

        prob = self.prob
        Q, r = ev["lsq"].Q, ev["r"]
        nf, npp = self.freq.size, prob.npp
        sig2 = self.noise(ev)
        sig2s = 0.5 * np.concatenate([sig2, sig2]) / npp              # per real entry
        floor = 1e-11 * prob.normY2
        found = []                                # (ratio, line index, damping)
        for mult, stride in ((1.0, 1), (4.0, 2), (16.0, 4), (64.0, 16)):
            idx = np.arange(4, nf - 4, stride)    # grid finer than a quarter bandwidth
            level = np.zeros(idx.size)
            zlev = np.zeros(idx.size)
            for i0 in range(0, idx.size, chunk):
                ii = idx[i0:i0 + chunk]
                fl = self.freq[ii]
                zl = np.clip(mult * self.df / fl, _ZMIN * 10, 0.05)
                G = self._trial_basis((mult, i0), fl, zl)
                G = G - Q @ (Q.T @ G)
                Gr = G.T @ r
                if npp == 2:
                    # cost decrease and d^T sig2s, d the diagonal of the projector on
                    # [g0 g1]: (c g0^2 - 2b g0 g1 + a g1^2) / (ac - b^2), by products
                    g0, g1 = G[:, 0::2], G[:, 1::2]
                    g00, g01, g11 = g0 * g0, g0 * g1, g1 * g1
                    a = np.sum(g00, axis=0)
                    b = np.sum(g01, axis=0)
                    c = np.sum(g11, axis=0)
                    det = np.maximum(a * c - b * b, 1e-300)
                    p0, p1 = Gr[0::2], Gr[1::2]
                    num = (c * np.sum(p0 * p0, axis=1) - 2 * b * np.sum(p0 * p1, axis=1)
                           + a * np.sum(p1 * p1, axis=1))
                    dJ = num / det
                    ds = (c[:, None] * (g00.T @ sig2s) - 2 * b[:, None] * (g01.T @ sig2s)
                          + a[:, None] * (g11.T @ sig2s)) / det[:, None]
                else:
                    dJ = np.sum(Gr**2, axis=1) / np.maximum(np.sum(G * G, axis=0), 1e-300)
                    ds = self._proj_diag(G[:, :, None]).T @ sig2s
                thr = np.maximum(self._threshold(ds), floor)
                level[i0:i0 + ii.size] = dJ / thr
                zlev[i0:i0 + ii.size] = zl
            pk = argrelmax(level, order=2)[0]
            found += [(level[i], idx[i], zlev[i]) for i in pk if level[i] > 1.0]
        # strongest first; one candidate per half-power band (non-maximum suppression)
        found.sort(key=lambda c: -c[0])
        cand = []
        for _, i, zi in found:
            fi = float(self.freq[i])
            excl = [(t, 1.5 * self.df) for t in self.tried] + \
                   [(c[0], max(2 * c[1] * c[0], 2 * self.df)) for c in cand]
            if any(abs(fi - t) < d for t, d in excl):
                continue
            cand.append((fi, float(zi)))
            if len(cand) >= max_add:
                break
        return cand

    def run(self, w, z, side, bar=None, rounds=20):
        # initial candidates far below the noise threshold at their picked position
        # (noise peaks of the indicator functions) are dropped before the first, costly,
        # fit; a true mode dropped here is not excluded from the residual scan
        if w.size > 1:
            x = np.concatenate([np.log(w), np.log(z)])
            sig0 = self.significance(w, z, self.prob.evaluate(x))
            keep = (sig0 >= 0.2) | (side != 0)
            for j in np.flatnonzero(~keep):
                self.log.append(("dropped candidate", float(w[j] / (2 * np.pi)), float(z[j]),
                                 f"cost change {sig0[j]:.3g} x noise threshold"))
            w, z, side = w[keep], z[keep], side[keep]
        w, z, ev, info = self.fit(w, z, side)
        self.best = (w, z, side, ev, info)
        tried_side = {-1: None, 1: None}     # in-band poles at the last trial per side
        failed_adds = 0
        for _ in range(rounds):
            if bar is not None:
                bar.set_postfix(poles=w.size, cost=f"{ev['cost'] / self.prob.normY2:.2e}")
            pr = self.prune(w, z, side, ev, info)
            if pr is not None:
                w, z, side = pr
                w, z, ev, info = self.fit(w, z, side)
                self.best = (w, z, side, ev, info)
                continue
            # modes just outside the band (their tails distort the in-band residual);
            # retried on each side whenever the number of in-band poles has changed
            changed = False
            for sd in (-1, 1):
                nin = int(np.count_nonzero(side == 0))
                if tried_side[sd] == nin or np.any(side == sd):
                    continue
                tried_side[sd] = nin
                f0 = self.fband[0] * 0.97 if sd < 0 else self.fband[1] * 1.03
                wn = np.concatenate([w, [2 * np.pi * f0]])
                zn = np.concatenate([z, [0.01]])
                sn = np.concatenate([side, [sd]])
                new = np.array([wn.size - 1])
                w2, z2, ev2, info2 = self.fit(wn, zn, sn, only=new)
                if not self._accept(w2, z2, ev2, info2, new, sn).size:
                    continue
                w2, z2, ev2, info2 = self.fit(w2, z2, sn)
                if self._accept(w2, z2, ev2, info2, new, sn).size:
                    self.log.append(("added", float(w2[-1] / (2 * np.pi)), float(z2[-1]),
                                     "out-of-band mode " + ("below" if sd < 0 else "above")))
                    w, z, side, ev, info = w2, z2, sn, ev2, info2
                    self.best = (w, z, side, ev, info)
                    changed = True
            if changed:
                failed_adds = 0
                continue
            # missed in-band modes: add at residual peaks, keep the significant ones
            if failed_adds >= 2:
                break
            with threadpool_limits(None):         # large products: all cores
                cand = self.missed(w, z, ev)
            if not cand:
                break
            n0 = w.size
            wn = np.concatenate([w, [2 * np.pi * c[0] for c in cand]])
            zn = np.concatenate([z, [c[1] for c in cand]])
            sn = np.concatenate([side, np.zeros(len(cand), int)])
            # first the new poles alone (the others fixed), then all of them
            w2, z2, ev2, info2 = self.fit(wn, zn, sn, only=np.arange(n0, wn.size))
            for fi, _ in cand:
                self.tried.append(float(fi))
            ok = self._accept(w2, z2, ev2, info2, np.arange(n0, w2.size), sn)
            if not ok.size:
                failed_adds += 1                   # rejected ones are in self.tried
                continue
            failed_adds = 0
            keep = np.concatenate([np.arange(n0), ok])
            w2, z2, ev2, info2 = self.fit(w2[keep], z2[keep], sn[keep])
            for j in range(n0, keep.size):
                self.log.append(("added", float(w2[j] / (2 * np.pi)), float(z2[j]),
                                 "residual peak"))
            w, z, side, ev, info = w2, z2, sn[keep], ev2, info2
            self.best = (w, z, side, ev, info)
        else:
            self.warn(f"automatic pole selection stopped after {rounds} rounds")
        return self.best

    def _accept(self, w, z, ev, info, new, side):
        """Indices in ``new`` of poles that converged, are not rejected and are significant."""
        bad = self._rejected(w, z, side, info)
        sig = self.significance(w, z, ev)
        ok = [j for j in new if sig[j] >= 1.0 and j not in bad]
        return np.array(ok, int)

    def _rejected(self, w, z, side, info):
        """{index: reason} of poles at a bound, fitting noise or filling in."""
        f = w / (2 * np.pi)
        reasons = {}
        edge = (side == 0) & ((f - self.fband[0] < 0.5 * self.df) |
                              (self.fband[1] - f < 0.5 * self.df))
        for j in np.flatnonzero(info.get("at_bound", np.zeros(w.size, bool)) | edge):
            reasons[j] = "did not converge (pushed to a bound)"
        for j in np.flatnonzero(2 * z * f < self.min_bw * self.df):
            reasons.setdefault(j, "noise fitting (half-power bandwidth below "
                                  f"{self.min_bw:g} line spacing)")
        for j in np.flatnonzero((side == 0) & (z > self.zeta_max)):
            reasons.setdefault(j, f"filler (damping above {self.zeta_max:g})")
        return reasons


# ---------------------------------------------------------------------------------------
# public function
# ---------------------------------------------------------------------------------------
def identify(frf, poles=None, band=None, *, model: str = "complex", optimizer: str = "varpro",
             in_band=None, asymptotic: bool = True, compress_rank: int | None = None,
             max_iter: int | None = None, tol: float = 1e-10, min_bandwidth: float = 0.5,
             zeta_max: float = 0.1, significance: float = 2.0, seed: int | None = 0,
             progress: bool = True):
    """Identify a complex-mode model (3.7) from measured FRFs (thesis 3.2.1).

    All sensors and actuators are fitted together with a common set of poles.  For
    given poles the residues ``R_j`` and the real asymptotic terms ``E`` (residual
    flexibility) and ``F/s^2`` (residual mass) solve the linear least-squares problem
    (3.15)-(3.16) by QR; the poles are updated by the gradient (3.19) or by variable
    projection (see the module notes).  The measured quantity is accounted for in the
    basis, so residues, ``E`` and ``F`` describe the displacement/force response.

    Parameters
    ----------
    frf : FRF
        Measured FRFs (displacement, velocity or acceleration per unit force).
    poles : array_like of complex, optional
        Initial poles in rad/s (Im > 0, Re < 0).  When None, the poles are found
        automatically: :func:`~sdctrl.identification.initial_poles` candidates (peaks of the
        summed FRF and of the first singular values of ``H(f)``, damping from the
        half-power width), then rounds of adding poles at residual peaks (missed modes),
        removing poles that do not converge, fit noise, are fillers or are not
        significant, and trying out-of-band poles just below and above the band.
    band : (float, float), optional
        Frequency band in Hz (default: all lines of ``frf``).
    model : {"complex", "real"}
        Complex-mode parametrisation (3.7), or the real-mode one (3.9) (proportional
        damping, purely imaginary residues) for comparison.
    optimizer : {"varpro", "gradient", "none"}
        Pole update: variable projection with ``scipy.optimize.least_squares``, the
        thesis sign-gradient with per-parameter step halving (3.19), or none (residues
        of the given poles only).
    in_band : array_like of bool, optional
        For given ``poles``: which are in-band poles (default: those whose frequency lies
        in the band).  Out-of-band poles are held outside the band by bounds.
    asymptotic : bool
        Fit the asymptotic terms ``E`` and ``F/s^2``.
    compress_rank : int, optional
        Rank of the real basis the stacked data are compressed to for the pole search
        (default ``p + 16`` with ``p`` the number of basis functions of the initial
        poles plus six, at least 40);
        0 disables compression.
    max_iter : int, optional
        Maximum function evaluations (varpro, default 200) or iterations (gradient,
        default 2000) per pole search.
    tol : float
        Relative tolerance of the pole search.
    min_bandwidth : float
        Poles whose half-power bandwidth ``2 zeta f`` is below this fraction of the line
        spacing are rejected as noise fitting (automatic mode); such a peak is resolved
        by fewer than two lines and cannot be told from noise.
    zeta_max : float
        In-band poles with a larger damping ratio are rejected as fillers (automatic mode).
    significance : float
        Multiplier of the noise threshold a pole's contribution must exceed to be kept
        (automatic mode); the threshold is the 1e-3/nf quantile of the cost change of a
        pole fitting pure noise, with a heteroscedastic noise level estimated locally
        from the residual (and the coherence when ``frf.coherence`` is given), see the
        module notes.
    seed : int, optional
        Seed of the randomised range finder (results are deterministic given a seed).
    progress : bool
        Show a tqdm progress bar.

    Returns
    -------
    ComplexModeModel
        Poles sorted by frequency, displacement residues, ``E``, ``F``, ``in_band``,
        ``cost`` (relative FRF error ``||H_fit - H||_F / ||H||_F`` in the band) and
        ``info`` (optimiser, evaluations, compression rank, added/removed poles,
        warnings).

    Raises
    ------
    ValueError
        Empty band, fewer frequency lines than parameters, non-finite, unstable or
        lower half-plane poles, NaN in the data, unknown options.

    Examples
    --------
    >>> import numpy as np, sdctrl as sd
    >>> f = np.linspace(5, 15, 400)
    >>> lam = -0.01 * 2 * np.pi * 10 + 2j * np.pi * 10
    >>> s = 2j * np.pi * f
    >>> H = 1 / (s - lam) + 1 / (s - lam.conjugate())
    >>> cm = sd.identify(sd.FRF(f, 1j * H), progress=False)
    >>> bool(abs(cm.frequency[0] - 10.0005) < 1e-3)
    True
    """
    from threadpoolctl import threadpool_limits
    from tqdm.auto import tqdm

    from sdctrl._validate import check_band as _check_band
    from sdctrl.frf import FRF
    from sdctrl.identification.complex_modes import ComplexModeModel
    from sdctrl.identification.poles import peak_candidates

    if not isinstance(frf, FRF):
        raise TypeError(f"frf must be an sdctrl.FRF, got {type(frf).__name__}")
    if model not in ("complex", "real"):
        raise ValueError(f"model must be 'complex' or 'real', got {model!r}")
    if optimizer not in ("varpro", "gradient", "none"):
        raise ValueError(f"optimizer must be 'varpro', 'gradient' or 'none', got {optimizer!r}")
    if max_iter is None:
        max_iter = 200 if optimizer == "varpro" else 2000
    for name, val in (("max_iter", max_iter),):
        if isinstance(val, bool) or not isinstance(val, int | np.integer) or val < 1:
            raise ValueError(f"{name} must be a positive integer, got {val!r}")
    for name, val in (("tol", tol), ("min_bandwidth", min_bandwidth), ("zeta_max", zeta_max),
                      ("significance", significance)):
        if not (isinstance(val, int | float) and np.isfinite(val) and val > 0):
            raise ValueError(f"{name} must be a positive number, got {val!r}")
    if not np.all(np.isfinite(frf.H)):          # FRF validates, but keep the promise here too
        raise ValueError("frf.H must contain only finite values (no NaN or inf)")
    fband = (float(frf.freq[0]), float(frf.freq[-1]))
    data = frf
    if band is not None:
        fband = _check_band(band, "band")
        data = frf.band(*fband)
    freq = data.freq
    nf, ns, na = data.H.shape
    m = ns * na
    k = QUANTITY_POWER[data.quantity]
    asym = (True, True) if asymptotic else (False, False)
    n_asym = sum(asym)
    npp = n_per_pole(model)
    s = 2j * np.pi * freq
    Hm = data.H.reshape(nf, m)

    messages = []

    def warn(msg):
        messages.append(msg)
        warnings.warn(msg, IdentificationWarning, stacklevel=3)

    # --- initial poles ------------------------------------------------------------------
    auto = poles is None
    if auto:
        f0, z0, _ = peak_candidates(freq, data.H, 4, 2.0, None) if nf >= 3 else ([], [], [])
        w0 = 2 * np.pi * np.asarray(f0, float)
        z0 = np.asarray(z0, float)
        side = np.zeros(w0.size, int)
        # peaks in data just outside the band, when the FRF has them
        lo_extra = (frf.freq >= 0.75 * fband[0]) & (frf.freq < fband[0])
        hi_extra = (frf.freq > fband[1]) & (frf.freq <= 1.25 * fband[1])
        for sel, sd in ((lo_extra, -1), (hi_extra, 1)):
            if np.count_nonzero(sel) >= 5:
                fo, zo, so = peak_candidates(frf.freq[sel], frf.H[sel], 4, 2.0, None)
                if fo.size:
                    i = np.argmax(so)
                    w0 = np.append(w0, 2 * np.pi * fo[i])
                    z0 = np.append(z0, zo[i])
                    side = np.append(side, sd)
    else:
        lam0 = as_array(poles, "poles", ndim=(0, 1), dtype=complex).reshape(-1)
        if lam0.size == 0:
            raise ValueError("poles must contain at least one pole (or be None for automatic "
                             "selection)")
        if np.any(lam0.imag <= 0):
            raise ValueError("poles must lie in the upper half-plane (Im > 0), one per mode")
        if np.any(lam0.real >= 0):
            raise ValueError("poles must be stable (Re < 0): initial poles with Re >= 0 given")
        w0 = np.abs(lam0)
        z0 = np.clip(-lam0.real / w0, _ZMIN * 1.01, _ZMAX * 0.99)
        f0 = w0 / (2 * np.pi)
        if in_band is None:
            ib = (f0 >= fband[0]) & (f0 <= fband[1])
        else:
            ib = np.array(in_band, dtype=bool).reshape(-1)
            if ib.size != lam0.size:
                raise ValueError(f"in_band must have one entry per pole ({lam0.size}), "
                                 f"got {ib.size}")
        side = np.where(ib, 0, np.where(f0 < fband[0], -1, 1))
        bad = (side == 0) & ((f0 < fband[0]) | (f0 > fband[1]))
        if np.any(bad):
            raise ValueError("in_band: poles marked in band must have their frequency in the "
                             f"band {fband}")
        if np.any((side != 0) & (f0 >= fband[0]) & (f0 <= fband[1])):
            raise ValueError("in_band: poles marked out of band must lie outside the band")
    n_par = (npp + 2) * w0.size + n_asym
    if 2 * nf < n_par or nf < 3:
        raise ValueError(f"frf: the band has {nf} frequency lines, fewer than needed for the "
                         f"{n_par} real parameters per channel of {w0.size} poles "
                         f"(need 2 * n_lines >= parameters)")

    normH2 = float(np.sum(Hm.real**2) + np.sum(Hm.imag**2))
    if normH2 == 0:
        raise ValueError("frf.H is identically zero in the band")

    # --- compression ---------------------------------------------------------------------
    p_guess = npp * (w0.size + 6) + n_asym
    rank = max(p_guess + 16, 40) if compress_rank is None else int(compress_rank)
    if rank <= 0 or rank >= m:
        V, _sv = None, None
        Y = stack(Hm)
        rank = m
    else:
        V, _sv = compress(Hm, rank, seed)
        Y = stack(Hm @ V)
    info = {"optimizer": optimizer, "model": model, "asymptotic": bool(asymptotic),
            "compress_rank": int(rank),
            "lines": int(nf), "channels": int(m)}
    if V is not None:
        info["compression_residual"] = float(max(normH2 - float(np.sum(Y**2)), 0) / normH2)

    bar = tqdm(desc="identify", disable=not progress, leave=False, unit="eval")
    try:
        with threadpool_limits(1):
            prob = _Problem(Y, s, k, model, asym, bar)
            if auto:
                shape = None
                if data.coherence is not None:      # point variance (3.59), up to a scale
                    pv = (np.abs(Hm) ** 2 * (1.0 - data.coherence.reshape(nf, m)))
                    shape = pv if V is None else pv @ V**2
                runner = _Auto(prob, freq, fband, optimizer, max_iter, tol, min_bandwidth,
                               zeta_max, significance, warn, shape)
                try:
                    w, z, side, _ev, sinfo = runner.run(w0, z0, side, bar)
                except KeyboardInterrupt:
                    if runner.best is None:
                        raise
                    w, z, side, _ev, sinfo = runner.best
                    info["interrupted"] = True
                    warn("interrupted: returning the last complete fit")
                info["log"] = runner.log
            else:
                w, z, sinfo = _search(prob, w0, z0, side, fband, optimizer, max_iter, tol)
                if np.any(sinfo.get("at_bound", [])):
                    warn("poles at a bound of the search (frequency or damping limit): "
                         + ", ".join(f"{x:.4g} Hz" for x in
                                     (w[sinfo['at_bound']] / (2 * np.pi))))
            info["search"] = {kk: vv for kk, vv in sinfo.items() if kk != "at_bound"}
            info["nfev"] = prob.nfev
            if not sinfo.get("converged", True):
                warn(f"pole search did not converge: {sinfo.get('message', '')}")
    finally:
        bar.close()

    # --- final residues on the full data ---------------------------------------------------
    order = np.argsort(w)
    w, z, side = w[order], z[order], side[order]
    lam = pole_from_params(w, z)
    Phi = basis(lam, s, k, model, asym)
    lsq = LSQ(Phi)
    QtY = lsq.project(Hm)
    C = lsq.coefficients(QtY)
    cost2 = max(normH2 - float(np.sum(QtY**2)), 0.0)
    if lsq.rcond < 1e-12:
        warn(f"ill-conditioned pole basis (reciprocal condition {lsq.rcond:.2e}): poles too "
             "close together or too many asymptotic terms")
    info["rcond"] = lsq.rcond
    R, E, F = coefficients_to_model(C, lam, model, asym, ns, na)
    info["warnings"] = messages
    return ComplexModeModel(poles=lam, residues=R, E=E, F=F, in_band=side == 0,
                            cost=float(np.sqrt(cost2 / normH2)), sensors=data.sensors,
                            actuators=data.actuators, collocated=data.collocated, band=fband,
                            info=info)
