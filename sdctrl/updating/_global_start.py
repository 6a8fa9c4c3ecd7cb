"""A first update stage that holds away from the nominal model (thesis 4.2-4.3).

The MAC-paired frequency criterion (4.8)-(4.9) is smooth and nearly linear in the
parameters *while the pairing is right*.  It is not when the sensors see only part of the
structure (shapes of distinct modes look alike at the sensors, the MAC no longer tells them
apart) or when a large correction swaps modes: a local solver started at ``p = 0`` then
follows a wrong pairing into a local minimum (issue 22: 0.445 / -0.048 for 0.25 / -0.15).

:func:`frequency_start` makes the stage global over the plausible range of the parameters:

1. screen a deterministic low-discrepancy design (a scrambled Sobol sequence, fixed seed)
   over the box of each parameter's plausible values -- its standard change
   (:attr:`~sdctrl.Parameter.standard_change`, Table 4.1) from halving to doubling,
   ``p / s`` in ``[-0.5, 1]``, clipped to the bounds -- with the nominal point, by the
   pairing criterion: squared frequency errors (4.8) plus ``(1 - MAC)^2`` (4.9) of the
   paired modes (soft-L1), so that a point cannot look good by pairing test modes with
   FE modes whose shapes differ;
2. solve the frequency criterion locally from the best few distinct points, with a robust
   (soft-L1) loss: a test mode identified or paired wrongly is an outlier of a few
   half-power bandwidths, not a quadratic pull on every parameter;
3. hand the distinct solutions, best first, to the logLS stage (3.12), which starts from
   each and keeps the lowest cost: the criterion that decides is the one being minimised.

Every evaluation is one eigen-solution of the reduced model (4.17): the screening costs a
few dozen reduced solves, nothing on the full FE model.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

__all__ = ["StartBox", "fit_stages", "frequency_start", "outlier_scale", "pairing_criterion",
           "solve_bounded"]

#: screened points per parameter (at least :data:`MIN_POINTS`)
POINTS_PER_PARAMETER = 12
MIN_POINTS = 32
#: local frequency solves started from the best screened points (with the nominal one)
N_LOCAL = 3
#: plausible range of ``p`` in standard changes: from halving to doubling the quantity
BOX = (-0.5, 1.0)


@dataclass(frozen=True, eq=False)
class StartBox:
    """Bounds and scales of the parameters of one update.

    Parameters
    ----------
    lo, hi : ndarray, shape (npar,)
        Bounds of ``p``.
    scale : ndarray, shape (npar,)
        Standard change of each parameter (positive).
    max_nfev : int
        Evaluation limit of each local solve.
    """

    lo: np.ndarray
    hi: np.ndarray
    scale: np.ndarray
    max_nfev: int

    def design(self, seed: int = 0) -> np.ndarray:
        """Screened points: the nominal one then a scrambled Sobol design over the box.

        Parameters
        ----------
        seed : int
            Seed of the scrambling (fixed: the update is deterministic).

        Returns
        -------
        ndarray, shape (n_points, npar)
        """
        from scipy.stats import qmc

        npar = self.lo.size
        n = max(MIN_POINTS, POINTS_PER_PARAMETER * npar)
        m = int(np.ceil(np.log2(n)))
        u = qmc.Sobol(npar, scramble=True, seed=seed).random_base2(m)
        a = np.maximum(self.lo, BOX[0] * self.scale)
        b = np.minimum(self.hi, BOX[1] * self.scale)
        b = np.maximum(a, b)
        return np.vstack([np.clip(np.zeros(npar), self.lo, self.hi), a + u * (b - a)])


def _robust(r, c: float) -> np.ndarray:
    """Soft-L1 loss ``2 c^2 (sqrt(1 + (r/c)^2) - 1)``: quadratic below ``c``, linear above."""
    return 2.0 * c * c * (np.sqrt(1.0 + (np.asarray(r) / c) ** 2) - 1.0)


def outlier_scale(prob) -> float:
    """Residual size above which a paired mode counts as an outlier (soft-L1 scale).

    A mode identified or paired wrongly (a test that sees part of the structure, an
    identification that merged two modes) is off by more than a half-power bandwidth
    ``2 zeta`` (section 3.1.3): the scale is twice the median identified damping ratio,
    at least 0.005.

    Parameters
    ----------
    prob : UpdateProblem
        The problem (its test modes).

    Returns
    -------
    float
    """
    z = np.asarray(prob.modes.damping, float)
    z = z[np.isfinite(z) & (z > 0)]
    return max(2.0 * float(np.median(z)) if z.size else 0.0, 0.005)


def pairing_criterion(prob, p, c: float) -> float:
    """Robust sum over the paired modes of frequency errors (4.8) and ``1 - MAC`` (4.9).

    Parameters
    ----------
    prob : UpdateProblem
        The problem (its test modes and reduced model).
    p : array_like, shape (npar,)
        Parameter values.
    c : float
        Soft-L1 scale (:func:`outlier_scale`).

    Returns
    -------
    float
    """
    index, mac, f, _ = prob.pairing(p)
    fid = prob.modes.frequency
    return float(np.sum(_robust((f[index] - fid) / fid, c)) + np.sum(_robust(1.0 - mac, c)))


def frequency_start(prob, box: StartBox, solve) -> tuple[list, int]:
    """The first update stage over the plausible range of the parameters (see module).

    Parameters
    ----------
    prob : UpdateProblem
        The problem, with at least as many test modes as parameters.
    box : StartBox
        Bounds, scales and evaluation limit.
    solve : callable
        ``solve(fun, x0, f_scale) -> (x, nfev)``: the bounded local least-squares solver
        with a soft-L1 loss of scale ``f_scale``.

    Returns
    -------
    candidates : list of ndarray, shape (npar,)
        Distinct local solutions, lowest pairing criterion first; the next stage (logLS)
        starts from each and keeps the lowest cost.
    nfev : int
        Evaluations of the reduced model (screening and local solves).
    """
    c = outlier_scale(prob)
    pts = box.design()
    crit = np.array([pairing_criterion(prob, q, c) for q in pts])
    nfev = len(pts)
    span = np.maximum(box.hi - box.lo, 1e-12)

    def distinct(x, xs):
        return all(np.max(np.abs(x - y) / span) > 0.01 for y in xs)

    starts = [pts[0]]
    for i in np.argsort(crit):
        if len(starts) > N_LOCAL:
            break
        if distinct(pts[i], starts):
            starts.append(pts[i])
    sols = []
    for x0 in starts:
        x, n = solve(prob.frequency_residual, x0, c)
        nfev += n
        if distinct(x, [s for _, s in sols]):
            sols.append((pairing_criterion(prob, x, c), x))
    sols.sort(key=lambda t: t[0])
    return [x for _, x in sols[:N_LOCAL]], nfev


def solve_bounded(fun, x0, lo, hi, scale, diff_step, max_nfev, what="logLS", f_scale=None):
    """Bounded trust-region least squares; warns when the evaluation limit stops it.

    Parameters
    ----------
    fun : callable
        Residual vector of ``p``.
    x0, lo, hi, scale : ndarray, shape (npar,)
        Start, bounds and typical change of each parameter.
    diff_step : float
        Relative finite-difference step.
    max_nfev : int
        Evaluation limit.
    what : str
        Stage named in the warning.
    f_scale : float, optional
        Soft-L1 loss of this scale (robust to outliers); default the plain squares.

    Returns
    -------
    x : ndarray, shape (npar,)
        The solution, within the bounds.
    nfev : int
        Evaluations.
    """
    robust = {} if f_scale is None else {"loss": "soft_l1", "f_scale": float(f_scale)}
    res = least_squares(fun, x0, bounds=(lo, hi), x_scale=scale, diff_step=diff_step,
                        ftol=1e-12, xtol=1e-10, gtol=1e-12, max_nfev=max_nfev, method="trf",
                        **robust)
    if res.status == 0:
        warnings.warn(f"update: the {what} stage stopped at its evaluation limit "
                      f"(max_nfev={max_nfev}) before converging", RuntimeWarning, stacklevel=4)
    return np.clip(res.x, lo, hi), int(res.nfev)


def fit_stages(prob, box: StartBox, strategy: str, stages: list, bar):
    """Stages 1-2 on the reduced model: MAC-paired frequencies (4.8)-(4.9) over the
    parameters' plausible range (:mod:`~sdctrl.updating._global_start`), then logLS (3.12)
    from each distinct frequency solution, keeping the lowest cost.

    Parameters
    ----------
    prob : UpdateProblem
        The problem at ``p = 0``.
    box : StartBox
        Bounds, scales and evaluation limit.
    strategy : {"two-stage", "logls", "frequencies"}
        The stages to run (:func:`sdctrl.update`).
    stages : list
        Stage records, appended to.
    bar : progress bar
        Updated once per stage.

    Returns
    -------
    prob : UpdateProblem
        The problem with its modal damping referenced at the chosen start.
    p : ndarray, shape (npar,)
        The solution.
    """
    p = np.zeros(prob.npar)
    starts = [p]
    if strategy in ("two-stage", "frequencies"):
        if prob.modes.n < prob.npar:
            warnings.warn(f"update: {prob.modes.n} test modes for {prob.npar} parameters; "
                          "the frequency stage is skipped", stacklevel=3)
            n = 0
        else:
            starts, n = frequency_start(prob, box, lambda fun, x0, c: solve_bounded(
                fun, x0, box.lo, box.hi, box.scale, 1e-4, box.max_nfev, "frequency", c))
        prob = prob.damped_at(starts[0])
        stages.append({"stage": "frequencies (4.8)", "values": starts[0].copy(),
                       "cost": prob.cost(starts[0]), "nfev": n})
        bar.update()
        if strategy == "frequencies":
            return prob, starts[0]
    best = None
    for x0 in starts:
        pr = prob.damped_at(x0) if strategy == "two-stage" else prob
        x, n = solve_bounded(pr.residual, x0, box.lo, box.hi, box.scale, 1e-6, box.max_nfev)
        cost = pr.cost(x)
        if best is None or cost < best[0]:
            best = (cost, x, pr, n)
    cost, p, prob, n = best
    stages.append({"stage": "logLS (3.12) on the reduced model", "values": p.copy(),
                   "cost": cost, "nfev": n})
    bar.update()
    return prob, p
