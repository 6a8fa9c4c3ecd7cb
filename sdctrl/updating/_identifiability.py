"""Identifiability of FE parameters by a test, before any update (thesis 4.2, Table 4.1, Fig. 4.6).

For each parameter and its standard change ``delta`` (:attr:`Parameter.standard_change`):

- **sensitivity** -- the logLS cost (3.12) between the nominal model and the model changed
  by ``delta`` on the test's lines, sensors and actuators (Table 4.1);
- **correlation** -- of the parameters' effects on the measured responses: the columns
  ``J_i = d log|H| / d p_i * delta_i`` of the logLS residual's Jacobian at the nominal;
- **std** -- the standard deviation each parameter would have if updated with this test:
  the covariance ``(J^T J)^-1 J^T diag(v) J (J^T J)^-1`` of the logLS estimate with the
  measurement's point variance ``v`` of ``log|H|`` (from the coherence, else the error
  level: the misfit of an identified model), all parameters fitted together
  (:mod:`sdctrl.updating._update_statistics`, the prediction of ``UpdateResult.std``);
- **weak** -- a predicted standard deviation above the standard change: the test cannot
  determine a standard change of that parameter (section 4.2.1: "the only parameters that
  can be updated are those that have an influence on the tested response larger than the
  residual error");
- **confounded** -- pairs of parameters (neither weak) whose estimates the test cannot tell
  apart: the predicted correlation of the two estimates beyond ``0.95`` (a long, thin
  joint confidence region) *and* that region spanning the bounds -- its 95% semi-major
  axis, in units of the standard changes, beyond one.  A correlation near one alone does
  not confound: two estimates each determined to 1e-5 of their standard change are told
  apart by the update whatever their correlation (the plate masses of
  ``examples/update_fe.py``, correlated 0.99, fitted to 1e-5 in every noise draw);
- **separation** -- for information, the mean squared effect of the least-distinguishable
  unit combination of standard changes of each pair (the smallest singular value of
  ``[J_i, J_j]``, squared and averaged like the cost);
- a **cost map** over two parameters against the data (Figure 4.6): a long flat valley is
  a pair the test cannot separate (the thesis's mirror and plate masses).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np

from sdctrl._lib.frozen import FrozenState
from sdctrl._lib.progress import progress_bar
from sdctrl._lib.threads import single_thread
from sdctrl._lib.display import markdown_table
from sdctrl._lib.validate import check_executor, check_int, check_scalar
from sdctrl.data._coherence import measured_coherence
from sdctrl.fe._fe_model import check_fe_model
from sdctrl.updating._update_fit import FMAX_FACTOR, check_parameters, damping_choice
from sdctrl.updating._placed_test import error_level, identify_measured, measured_modes, place_test
from sdctrl.updating._problem import build_problem, log_frf
from sdctrl.updating._update_statistics import (
    log_point_variance,
    parameter_covariance,
    std_and_correlation,
)

__all__ = ["CostMap", "CostProblem", "Identifiability", "identifiability"]

#: pairs whose effects correlate above this are confounded
CORRELATION_MAX = 0.95


@dataclass(frozen=True, eq=False)
class CostMap:
    """logLS cost against the data over a grid of two parameters (Figure 4.6).

    ``sd.plot.cost_map(cm)`` (or ``sd.plot.cost_map(cm.x, cm.y, cm.cost, xlabel=cm.xlabel,
    ylabel=cm.ylabel)``) draws it.

    Parameters
    ----------
    x, y : ndarray
        Values of the two parameters (``p``).
    cost : ndarray, shape (len(x), len(y))
        ``cost[i, j]`` at ``(x[i], y[j])``, the other parameters at 0.
    xlabel, ylabel : str
        Parameter names.
    """

    x: np.ndarray
    y: np.ndarray
    cost: np.ndarray
    xlabel: str
    ylabel: str

    def __repr__(self) -> str:
        return (f"CostMap({self.xlabel!r} x {self.ylabel!r}, {self.x.size} x {self.y.size}, "
                f"min {np.nanmin(self.cost):.3g})")


def _row_costs(task):
    """Costs along one row of a cost map (picklable for executors)."""
    prob, p0, ia, ib, xa, ys = task
    out = []
    for yb in ys:
        p = p0.copy()
        p[ia], p[ib] = xa, yb
        out.append(prob.cost(p))
    return np.array(out)


@dataclass(frozen=True, eq=False)
class Identifiability:
    """How well a test determines each FE parameter (Table 4.1).

    Parameters
    ----------
    names : tuple of str
        Parameter names.
    sensitivity : dict
        Name -> logLS cost change for the parameter's standard change.
    correlation : ndarray, shape (n, n)
        Correlation of the parameters' effects on the measured responses.
    confounded : list of (str, str)
        Pairs the test cannot tell apart: predicted correlation of their estimates beyond
        ``corr_max`` and their 95% joint confidence region longer than their standard
        changes (module notes).
    weak : list of str
        Parameters whose predicted standard deviation exceeds their standard change.
    error_level : float
        The measurement's own logLS error level.
    error_source : str
        ``"coherence"``, ``"identified fit"`` or ``"given"``.
    standard_change : dict
        Name -> the standard change used.
    separation : ndarray, shape (n, n)
        Mean squared effect of the least-distinguishable unit combination of standard
        changes of each pair (inf on the diagonal).
    problem : CostProblem
        The reduced update problem (for :meth:`cost_map`).
    std : dict
        Name -> predicted standard deviation of ``p`` if updated with this test.
    estimate_correlation : ndarray, shape (n, n)
        Predicted correlation of the estimates of the parameters (the confounded verdict).
    """

    names: tuple
    sensitivity: dict
    correlation: np.ndarray
    confounded: list
    weak: list
    error_level: float
    error_source: str
    standard_change: dict
    separation: np.ndarray
    problem: object = field(repr=False)
    std: dict = field(default_factory=dict)
    estimate_correlation: np.ndarray | None = field(default=None, repr=False)

    def __repr__(self) -> str:
        return (f"Identifiability({len(self.names)} parameters, weak {self.weak}, confounded "
                f"{self.confounded})")

    def report(self) -> str:
        """Markdown report: Table 4.1 (sensitivity), weak and confounded parameters.

        Returns
        -------
        str
        """
        rows = [(n, f"{self.standard_change[n]:.4g}", f"{self.sensitivity[n]:.3g}",
                 f"{self.std.get(n, float('nan')):.3g}", "weak" if n in self.weak else "ok")
                for n in self.names]
        out = ["## Identifiability of the parameters (Table 4.1)", "",
               markdown_table(["parameter", "standard change", "logLS change", "predicted std",
                               "verdict"], rows),
               "", (f"Measurement error level (logLS): {self.error_level:.3g} "
               f"({self.error_source})."), ""]
        if len(self.names) > 1:
            corr = [[self.names[i]] + [f"{self.correlation[i, j]:+.3f}"
                                       for j in range(len(self.names))]
                    for i in range(len(self.names))]
            out += ["Correlation of the parameters' effects on the measured responses:", "",
                    markdown_table([""] + list(self.names), corr), ""]
        conf = ", ".join(f"({a}, {b})" for a, b in self.confounded) or "none"
        out.append(f"Confounded pairs (the test cannot tell them apart): {conf}.")
        return "\n".join(out)

    def _repr_markdown_(self) -> str:
        return self.report()

    def cost_map(self, a: str, b: str, values_a=None, values_b=None, n: int = 21,
                 executor=None, progress: bool | None = None) -> CostMap:
        """logLS cost against the data over a grid of two parameters (Figure 4.6).

        Parameters
        ----------
        a, b : str
            Parameter names (horizontal, vertical axis).
        values_a, values_b : array_like, optional
            Grid values of ``p``; default ``n`` values over plus/minus the standard change
            (clipped to the bounds).
        n : int
            Grid size per axis when the values are not given.
        executor : concurrent.futures.Executor, optional
            Evaluates the rows of the grid (``executor.map``); serial when None.
        progress : bool, optional
            Show a progress bar.

        Returns
        -------
        CostMap
        """
        executor = check_executor(executor)
        idx = {nm: i for i, nm in enumerate(self.names)}
        for nm, label in ((a, "a"), (b, "b")):
            if nm not in idx:
                raise ValueError(f"{label} must be a parameter name among {list(self.names)}, "
                                 f"got {nm!r}")
        if a == b:
            raise ValueError("a and b must be two different parameters")
        xs = self._grid(a, values_a, n, "values_a")
        ys = self._grid(b, values_b, n, "values_b")
        p0 = np.zeros(len(self.names))
        tasks = [(self.problem, p0, idx[a], idx[b], float(x), ys) for x in xs]
        run = map if executor is None else executor.map
        with single_thread():
            rows = list(progress_bar(run(_row_costs, tasks), total=len(tasks), desc="cost map",
                                     enabled=progress))
        return CostMap(xs, ys, np.array(rows), a, b)

    def _grid(self, name, values, n, label) -> np.ndarray:
        if values is not None:
            v = np.asarray(values, float).ravel()
            if v.size < 2 or not np.all(np.isfinite(v)):
                raise ValueError(f"{label} must hold at least 2 finite values")
            return v
        if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 2:
            raise ValueError(f"n must be an integer >= 2, got {n!r}")
        d = abs(self.standard_change[name])
        par = next(p for p in self.problem.parameters if p.name == name)
        lo, hi = max(-d, par.bounds[0]), min(d, par.bounds[1])
        return np.linspace(lo, hi, int(n))


def _effects(prob, deltas, h: float = 1e-3):
    """Finite standard-change costs and linearised effect columns ``J_i`` (scaled to delta)."""
    npar = prob.npar
    base = prob.log_response(np.zeros(npar))
    sens, cols = [], []
    for i, d in enumerate(deltas):
        e = np.zeros(npar)
        e[i] = d
        r = prob.log_response(e) - base
        sens.append(float(np.mean(r**2)))
        up, down = prob.log_response(h * e), prob.log_response(-h * e)
        cols.append(((up - down) / (2 * h)).ravel())
    return np.array(sens), np.array(cols).T


#: chi-square quantile (2 degrees of freedom) of a 95% joint confidence region
CHI2_95_2DOF = 5.991464547107979


def _region_axis(est_corr, scaled_std, i, j) -> float:
    """Semi-major axis of the 95% joint confidence region of estimates ``i``, ``j`` in
    units of their standard changes (``scaled_std`` = std / standard change)."""
    s = scaled_std[[i, j]]
    cov = np.outer(s, s) * np.array([[1.0, est_corr[i, j]], [est_corr[i, j], 1.0]])
    return float(np.sqrt(CHI2_95_2DOF * np.max(np.linalg.eigvalsh(cov))))


def _pairs(names, est_corr, J, weak, corr_max, scaled_std):
    n_el = J.shape[0]
    sep = np.full((len(names),) * 2, np.inf)
    confounded = []
    for i, j in itertools.combinations(range(len(names)), 2):
        s = np.linalg.svd(J[:, [i, j]], compute_uv=False)
        sep[i, j] = sep[j, i] = float(s[-1] ** 2 / n_el)
        if names[i] in weak or names[j] in weak:
            continue
        if not np.isfinite(est_corr[i, j]):                 # NaN: not determined apart
            confounded.append((names[i], names[j]))
        elif abs(est_corr[i, j]) > corr_max and _region_axis(est_corr, scaled_std, i, j) > 1:
            confounded.append((names[i], names[j]))
    return confounded, sep


def identifiability(fe, frf, parameters, band=None, *, damping=None, noise: float | None = None,
                    n_averages: int = 1, corr_max: float = CORRELATION_MAX,
                    fmax: float | None = None) -> Identifiability:
    """How well a test can determine each FE parameter, before any update (Table 4.1).

    Parameters
    ----------
    fe : FEModel
        The nominal model.
    frf : FRF
        The test (labels are DOF labels of ``fe``): its lines, sensors and actuators define
        the measured responses; its coherence (or an identified model's misfit) the error.
    parameters : Parameter or sequence of Parameter
        The candidate parameters (unique names); each one's standard change is its
        :attr:`~sdctrl.Parameter.standard_change`.
    band : (float, float), optional
        Band in Hz (default all lines).
    damping : None, "data", "fe", float or identified model
        Damping of the predictions, as in :func:`sdctrl.update`.
    noise : float, optional
        The measurement's error level (mean squared log-magnitude error) when known;
        default from the coherence, else from an identified model's misfit.
    n_averages : int
        Averages behind the coherence (the error level divides by it).
    corr_max : float
        Predicted correlation of two estimates above which the parameters are confounded
        (when their joint 95% confidence region also spans their standard changes).
    fmax : float, optional
        Highest normal-mode frequency (Hz) of the reduced basis (default 2.5 x band top).

    Returns
    -------
    Identifiability

    Examples
    --------
    >>> import sdctrl as sd
    >>> fe = sd.testbed()
    >>> links = fe.stiffness_parameter("links", section=["post_AB", "post_C"])
    >>> truss = fe.stiffness_parameter("longerons", section="longeron")
    >>> frf = sd.testbed_frf(n=150, noise=0.01, seed=0)
    >>> ident = sd.identifiability(fe, frf, [links, truss])
    >>> ident.weak, ident.confounded
    ([], [])
    """
    check_fe_model(fe, "fe")
    pars = check_parameters(parameters, fe)
    measured = place_test(fe, frf, band)
    choice, given = damping_choice(fe, damping)
    corr_max = check_scalar(corr_max, "corr_max", positive=True)
    if not corr_max < 1:
        raise ValueError(f"corr_max must lie in (0, 1), got {corr_max!r}")
    noise = check_scalar(noise, "noise", nonneg=True, optional=True)
    n_averages = check_int(n_averages, "n_averages", minimum=1)
    fmax = check_scalar(fmax, "fmax", positive=True, optional=True)
    cm = None
    need_id = (choice[0] == "modal" and choice[1] is None and given is None) or \
        (noise is None and measured_coherence(measured.frf) is None)
    if need_id:
        cm = identify_measured(measured)
    modes = None
    if choice[0] == "modal" and choice[1] is None:
        modes = measured_modes(measured, given if given is not None else cm)
    if noise is not None:
        level, source = noise, "given"
    else:
        level, source = error_level(measured, cm, n_averages)
    fmax = FMAX_FACTOR * float(measured.freq[-1]) if fmax is None else fmax
    with single_thread():
        prob = build_problem(fe, measured, pars, choice, modes, fmax=fmax)
        deltas = np.array([p.standard_change for p in pars])
        sens, J = _effects(prob, deltas)
    norms = np.linalg.norm(J, axis=0)
    corr = (J.T @ J) / np.outer(np.maximum(norms, 1e-300), np.maximum(norms, 1e-300))
    names = tuple(p.name for p in pars)
    var = log_point_variance(measured.frf if source == "coherence" else None,
                             measured.logH.shape, n_averages, level=level).ravel()
    std, est_corr = std_and_correlation(names, parameter_covariance(J / deltas, var))
    weak = [nm for nm, d in zip(names, deltas) if not std[nm] <= abs(d)]   # NaN: weak
    scaled = np.array([std[nm] for nm in names]) / np.abs(deltas)
    confounded, sep = _pairs(names, est_corr, J, weak, corr_max, scaled)
    return Identifiability(names, dict(zip(names, sens.tolist())), corr, confounded, weak,
                           level, source, dict(zip(names, deltas.tolist())), sep,
                           CostProblem(prob.rm, measured.omega, measured.logH, pars), std,
                           est_corr)


@dataclass(frozen=True, eq=False)
class CostProblem(FrozenState):
    """What cost maps need, lean enough to pickle for executors (and to save with
    :func:`sdctrl.save`): the reduced model, the data's lines and ``log |H|``, the parameters.

    Parameters
    ----------
    rm : ReducedModel
        The parametric reduced model (4.17) on the test's sensors and actuators.
    omega : ndarray, shape (nf,)
        The test's lines (rad/s).
    logH : ndarray, shape (nf, ns, na)
        ``log |H|`` of the measured displacement FRF.
    parameters : tuple of Parameter
        The parameters, in the order of ``rm.names``.
    """

    rm: object
    omega: np.ndarray
    logH: np.ndarray
    parameters: tuple

    def cost(self, p) -> float:
        """logLS cost (3.12) at parameter values ``p``.

        Parameters
        ----------
        p : array_like, shape (npar,)
            Parameter values.

        Returns
        -------
        float
        """
        r = log_frf(self.rm, p, self.omega) - self.logH
        return float(np.mean(r**2))
