"""FE model update by logLS on reanalysed reduced models (thesis 4.4), :func:`update`.

The algorithm of section 4.4 (measured FRFs, logLS cost (3.12), additive parameters
(4.15), reanalysis (4.17) on a basis with static correction modes (4.23)-(4.24)) with a
first stage that makes it robust: the logLS cost has local minima as soon as the FE
frequencies are a few half-power bandwidths off (section 3.1.3, Figure 3.2), and initial
FE models are often several percent off.  So:

1. **frequencies** -- the FE modes are paired by MAC (4.9) with the modes identified from
   the data and the relative frequency errors (4.8) are minimised (a smooth criterion,
   nearly linear in the parameters, whose minimum is the right one);
2. **logLS** -- from there, the logLS cost of all the measured FRFs is minimised on the
   reanalysed model (4.17) (bounded trust-region least squares);
3. **re-solve** -- the full FE model is solved again at the optimum (its own modes and
   static correction modes) and stage 2 runs again around it while that is predicted to
   move the parameters by a tenth of their standard deviation or more (the reduced basis's
   optimum is not the full model's), each step kept if the model solved again agrees.

The cost before and after, the parameter table and the paired modes are in
:class:`UpdateResult`.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from sdctrl._lib.progress import progress_bar
from sdctrl._lib.threads import single_thread
from sdctrl._lib.display import markdown_table
from sdctrl._lib.validate import check_int, check_scalar
from sdctrl.fe._parameters import Parameter
from sdctrl.fe._fe_model import check_fe_model
from sdctrl.updating._basis_growth import grown, on_richer_basis
from sdctrl.updating._final_stages import Solved, refined, resolved
from sdctrl.updating._fit_floor import FitFloor, basis_limited, fit_floor
from sdctrl.updating._global_start import StartBox, fit_stages
from sdctrl.updating._placed_test import measured_modes, place_test
from sdctrl.updating._problem import build_problem
from sdctrl.updating._update_statistics import fitted_std

__all__ = ["UpdateResult", "check_parameters", "damping_choice", "update"]

#: normal modes of the reduced basis up to this many times the band top
FMAX_FACTOR = 2.5
_STRATEGIES = ("two-stage", "logls", "frequencies")


@dataclass(frozen=True, eq=False)
class UpdateResult:
    """Result of :func:`update`.

    Parameters
    ----------
    values : dict
        Parameter name -> fitted value ``p``.
    fe : FEModel
        The updated model ``M + sum p dM``, ``C + sum p dC``, ``K + sum p dK`` (full matrices).
    cost_before : float
        logLS cost (3.12) of the nominal model against the data.
    cost_after : float
        logLS cost of the updated model (solved again in full) against the data.
    parameters : tuple of Parameter
        The parameters.
    pairing : dict
        Paired modes: ``test_hz``, ``fe_hz_before``, ``mac_before``, ``fe_hz_after``,
        ``mac_after`` (arrays, one entry per test mode).
    stages : tuple of dict
        ``{"stage", "values", "cost", "nfev"}`` per stage.
    model : NormalModeModel
        The updated model reduced on the test's sensors and actuators (its modes and
        static correction modes, the damping of the update), with shapes on ``fe.dofs``:
        ``model.frf(freq, quantity)`` overlays the data.
    info : dict
        ``basis`` (sizes), ``time`` (s), ``strategy``.
    damping : str
        How the damping was modelled (``"FE damping matrix C (projected)"``, a given modal
        ratio, or modal damping from the data and where it came from).
    test_modes : str
        Source of the test modes paired with the FE modes (4.9): ``"identified complex
        modes"``, ``"identified normal modes"``, ``"given normal modes"``...
    std : dict
        Parameter name -> one standard deviation of the fitted ``p``: the larger of the
        test's noise's (Cramer-Rao bound of the logLS fit at the optimum) and the sensors'
        scatter (a model error that differs between sensors,
        :mod:`~sdctrl.updating._update_statistics`).
    fit : FitFloor or None
        The final cost against the noise floor estimated from the data
        (:mod:`~sdctrl.updating._fit_floor`): ``fit.noise_floor``, ``fit.ratio``,
        ``fit.above`` (more than ten times the floor: warned), ``fit.at_peaks`` (the share
        of the excess at the resonances) and ``fit.text`` (the verdict, with what to try).
    """

    values: dict
    fe: object
    cost_before: float
    cost_after: float
    parameters: tuple
    pairing: dict
    stages: tuple
    model: object
    info: dict = field(default_factory=dict, repr=False)
    damping: str | None = None
    test_modes: str | None = None
    std: dict = field(default_factory=dict)
    fit: FitFloor | None = None

    def __repr__(self) -> str:
        vals = ", ".join(f"{k}={v:.4g}" for k, v in self.values.items())
        return (f"UpdateResult({vals}; logLS {self.cost_before:.3g} -> "
                f"{self.cost_after:.3g})")

    def report(self) -> str:
        """Markdown report: parameters, costs, paired modes before/after.

        Returns
        -------
        str
        """
        rows = [(p.name, "0", f"{self.values[p.name]:.5g}",
                 f"{self.std.get(p.name, float('nan')):.2g}",
                 f"[{p.bounds[0]:g}, {p.bounds[1]:g}]", p.description or "")
                for p in self.parameters]
        out = ["## FE model update (logLS, reanalysis)", "",
               markdown_table(["parameter", "initial", "final", "std", "bounds", "description"],
                              rows),
               "", (f"logLS cost (3.12): before **{self.cost_before:.4g}**, after "
               f"**{self.cost_after:.4g}** (damping: {self.damping or '?'})."), ""]
        if self.fit is not None:
            out += [f"Final cost against the noise floor: {self.fit.text}.", ""]
        st = [(s["stage"], ", ".join(f"{v:.4g}" for v in s["values"]), f"{s['cost']:.4g}",
               s["nfev"]) for s in self.stages]
        out += [markdown_table(["stage", "values", "cost", "evaluations"], st), ""]
        pr = self.pairing
        if len(pr.get("test_hz", ())):
            rows = [(j + 1, f"{pr['test_hz'][j]:.4g}", f"{pr['fe_hz_before'][j]:.4g}",
                     f"{pr['mac_before'][j]:.3f}", f"{pr['fe_hz_after'][j]:.4g}",
                     f"{pr['mac_after'][j]:.3f}") for j in range(len(pr["test_hz"]))]
            out += ["Test modes paired by MAC (4.9) with the FE modes:", "",
                    markdown_table(["test mode", "test (Hz)", "FE before (Hz)", "MAC before",
                                    "FE after (Hz)", "MAC after"], rows)]
        return "\n".join(out)

    def _repr_markdown_(self) -> str:
        return self.report()


def check_parameters(parameters, fe, name: str = "parameters") -> tuple:
    """Validated tuple of parameters for ``fe`` (unique names, matrices of size N).

    Parameters
    ----------
    parameters : Parameter or sequence of Parameter
        The parameters.
    fe : FEModel
        The model.
    name : str
        Name in error messages.

    Returns
    -------
    tuple of Parameter
    """
    pars = (parameters,) if isinstance(parameters, Parameter) else parameters
    if isinstance(pars, str) or not isinstance(pars, Sequence):
        raise TypeError(f"{name} must be a Parameter or a sequence of Parameter objects")
    pars = tuple(pars)
    if not pars:
        raise ValueError(f"{name} must hold at least one Parameter")
    for p in pars:
        if not isinstance(p, Parameter):
            raise TypeError(f"{name} must contain sdctrl.Parameter objects, got "
                            f"{type(p).__name__}")
        if p.N != fe.N:
            raise ValueError(f"{name}: {p.name!r} has ({p.N}, {p.N}) matrices, the FE model "
                             f"has N={fe.N} DOFs")
    names = [p.name for p in pars]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ValueError(f"{name}: duplicate parameter names {dup}")
    return pars


def damping_choice(fe, damping):
    """``(kind, ratio)`` of the damping model and the identified model given as ``damping``.

    Parameters
    ----------
    fe : FEModel
        The model (``fe.C`` or not).
    damping : None, "data", "fe", float, NormalModeModel or ComplexModeModel
        The user's choice (see :func:`update`).

    Returns
    -------
    (str, float or None)
        ``("matrix", None)`` or ``("modal", ratio or None)``.
    model or None
        The identified model passed as ``damping``.
    """
    from sdctrl.identification import ComplexModeModel
    from sdctrl.modal._normal_model import NormalModeModel

    if damping is None:
        return (("matrix", None) if fe.C is not None else ("modal", None)), None
    if isinstance(damping, NormalModeModel | ComplexModeModel):
        return ("modal", None), damping
    if isinstance(damping, str):
        if damping == "data":
            return ("modal", None), None
        if damping == "fe":
            if fe.C is None:
                raise ValueError("damping='fe' needs an FE model with a damping matrix C")
            return ("matrix", None), None
        raise ValueError(f"damping must be None, 'data', 'fe', a damping ratio or an "
                         f"identified model, got {damping!r}")
    try:
        z = float(damping)
    except (TypeError, ValueError):
        raise TypeError("damping must be None, 'data', 'fe', a damping ratio or an identified "
                        f"model, got {type(damping).__name__}") from None
    if not (np.isfinite(z) and 0 <= z <= 1):
        raise ValueError(f"damping must be a modal damping ratio in [0, 1], got {damping!r}")
    return ("modal", z), None


def update(fe, frf, parameters, band=None, damping=None, *, strategy: str = "two-stage",
           identified=None, fmax: float | None = None, loads: str = "modal",
           max_nfev: int | None = None, progress: bool | None = None) -> UpdateResult:
    """Update FE parameters (4.15) by minimising the logLS cost (3.12) against measured FRFs.

    The test is placed on the FE model through the FRF's labels (DOF labels of ``fe``);
    the FE prediction is evaluated by reanalysis (4.17) on a reduced basis of normal modes
    up to ``fmax`` with static correction modes (4.23)-(4.24) of the actuators and of the
    parameters.  Stages (see :mod:`sdctrl.updating._update_fit`): frequencies of the MAC-paired
    modes (4.8)-(4.9), logLS refinement, then the full FE model solved again at the
    optimum (and refined around it while that moves the parameters by a tenth of their
    standard deviation or more).

    Parameters
    ----------
    fe : FEModel
        The nominal model (``p = 0``).
    frf : FRF
        Measured FRFs (any quantity) whose sensor/actuator labels are DOF labels of ``fe``.
    parameters : Parameter or sequence of Parameter
        The parameters, with unique names; their ``bounds`` are respected.
    band : (float, float), optional
        Band (Hz) of the cost; default all the lines of ``frf``.
    damping : None, "data", "fe", float, NormalModeModel or ComplexModeModel
        None: ``fe.C`` when the model has one (plus the parameters' ``dC``), else damping
        estimated from the data.  ``"data"``: modal damping from the modes identified in
        the data (:func:`sdctrl.identify`, :func:`sdctrl.normal_modes`), transferred to
        the FE modes paired by MAC -- the full identified ``Gamma`` between paired modes,
        the mean ratio on the others.  A float: that damping ratio on every mode.  An
        identified model: its damping (a NormalModeModel's full ``Gamma``) and its modes.
    strategy : {"two-stage", "logls", "frequencies"}
        ``"two-stage"`` (default) as above; ``"logls"``: logLS from the nominal values
        only (a plain local optimiser, for comparison: it stops in a local minimum when
        the FE frequencies are off); ``"frequencies"``: the first stage only.
    identified : NormalModeModel or ComplexModeModel, optional
        Modes of the test used for pairing (default: identified from ``frf``).
    fmax : float, optional
        Highest normal-mode frequency (Hz) of the reduced basis; default 2.5 times the
        band top, doubled (at most twice) while it limits the fit (``_basis_growth``).
    loads : {"modal", "range"}
        Load shapes of the parameters' static correction modes: the loads ``dX phi`` in
        the retained modes (default), or the range of the parameter matrices.
    max_nfev : int, optional
        Evaluation limit of each optimisation stage (default ``100 (1 + npar)``).
    progress : bool, optional
        Show a progress bar (default: ``sdctrl.config.progress``, else on a terminal).

    Returns
    -------
    UpdateResult

    Raises
    ------
    TypeError
        ``fe`` is not an FEModel, ``frf`` not an FRF, a parameter not a Parameter.
    ValueError
        FRF labels that are not FE DOFs, duplicate parameter names, parameter matrices of
        the wrong size, an empty band, bad options.

    Examples
    --------
    >>> import sdctrl as sd
    >>> frf = sd.testbed_frf(n=200, band=(10.0, 30.0))
    >>> fe = sd.testbed(link_stiffness=0.8)
    >>> links = fe.stiffness_parameter("links", section=["post_AB", "post_C"])
    >>> res = sd.update(fe, frf, [links], damping=0.003, progress=False)
    >>> round(0.8 * (1 + res.values["links"]), 2)
    1.0
    """
    t0 = time.perf_counter()
    check_fe_model(fe, "fe")
    pars = check_parameters(parameters, fe)
    if strategy not in _STRATEGIES:
        raise ValueError(f"strategy must be one of {_STRATEGIES}, got {strategy!r}")
    measured = place_test(fe, frf, band)
    choice, given = damping_choice(fe, damping)
    fmax = given_fmax = check_scalar(fmax, "fmax", positive=True, optional=True)
    max_nfev = check_int(max_nfev, "max_nfev", minimum=1, optional=True)
    if fmax is None:
        fmax = FMAX_FACTOR * float(measured.freq[-1])
    modes = measured_modes(measured, identified if identified is not None else given)
    npar = len(pars)
    lo = np.array([p.bounds[0] for p in pars])
    hi = np.array([p.bounds[1] for p in pars])
    scale = np.array([abs(p.standard_change) for p in pars])
    nfev_max = int(max_nfev) if max_nfev is not None else 100 * (1 + npar)
    stages = []
    bar = progress_bar(total=3 if strategy == "two-stage" else 2, desc="update", unit="stage",
                       enabled=progress)
    try:
        with single_thread():
            setup = UpdateSetup(measured, pars, choice, modes, fmax, loads)
            prob = setup.problem(fe)
            if modes.n == 0:
                warnings.warn("update: no mode identified in the test; frequencies and MAC "
                              "are not reported", RuntimeWarning, stacklevel=2)
            p = np.zeros(npar)
            cost_before = prob.cost(p)
            before = prob.pairing(p) if modes.n else None
            prob, p = fit_stages(prob, StartBox(lo, hi, scale, nfev_max), strategy, stages, bar)
            box = (lo, hi, scale, nfev_max)
            solved = resolved(fe, setup, p, box, stages, strategy)
            if given_fmax is None and strategy != "frequencies":
                richer = grown(fe, solved, box, stages)
                if richer.setup is not solved.setup:
                    richer = refined(fe, richer, box, stages)
                solved = richer
            setup, fe1, prob1, p, cost_after = (solved.setup, solved.fe1, solved.prob1,
                                                solved.p, solved.cost)
            bar.update()
            after = prob1.pairing(np.zeros(npar)) if modes.n else None
            model = _normal_mode_model(prob1, fe1, measured)
            std = fitted_std(prob1, measured, [par.name for par in pars], scale)
    finally:
        bar.close()
    return UpdateResult(
        values={par.name: float(v) for par, v in zip(pars, p)}, fe=fe1,
        cost_before=float(cost_before), cost_after=float(cost_after), parameters=pars,
        pairing=_pairing_table(modes, before, after), stages=tuple(stages), model=model,
        info={"basis": {"modes": prob1.basis.n_modes, "static": prob1.basis.n_static},
              "strategy": strategy, "time": time.perf_counter() - t0},
        damping=_damping_text(choice, modes), test_modes=modes.source, std=std,
        fit=_floor(model, solved, cost_before))


def _floor(model, solved: Solved, cost_before) -> FitFloor:
    """The final cost against the nominal one and the data's noise floor
    (:mod:`~sdctrl.updating._fit_floor`), with a warning when it is worse or above it; above
    it, the same parameters on a basis with modes to twice ``fmax`` tell whether the reduced
    basis is what limits the fit (:func:`~sdctrl.updating._fit_floor.basis_limited`)."""
    setup, cost = solved.setup, solved.cost
    if cost > cost_before:
        warnings.warn(f"update: the updated model fits the data worse than the nominal one "
                      f"(logLS {cost_before:.3g} -> {cost:.3g}); check the parameters, "
                      "the band and the damping", RuntimeWarning, stacklevel=3)
    frf, modes = setup.measured.frf, setup.modes
    H = model.frf(frf.freq, quantity=frf.quantity).H
    fit = fit_floor(cost, frf.freq, H, frf.H, modes.frequency, modes.damping)
    if fit.above:                 # grown() may have evaluated the richer basis already
        richer = solved.richer if solved.richer is not None else on_richer_basis(solved)[2]
        fit = basis_limited(fit, cost, setup.fmax, richer)
    if fit.above:
        warnings.warn(f"update: the final cost is {fit.text}", RuntimeWarning, stacklevel=3)
    return fit


@dataclass(frozen=True, eq=False)
class UpdateSetup:
    """What every update problem of one :func:`update` call shares (4.15)-(4.23).

    Attributes
    ----------
    measured : PlacedTest
        The test placed on the FE DOFs.
    parameters : tuple of Parameter
        The parameters.
    damping : tuple
        The damping choice (:func:`damping_choice`).
    modes : MeasuredModes
        The test modes paired with the FE modes (4.9).
    fmax : float
        Highest frequency (Hz) of the normal modes of the reduced basis.
    loads : array_like or None
        Extra loads of the static correction (4.23).
    """

    measured: object
    parameters: tuple
    damping: tuple
    modes: object
    fmax: float
    loads: object = None

    def problem(self, fe):
        """The update problem (reduced model, costs) of ``fe`` (:func:`build_problem`).

        Parameters
        ----------
        fe : FEModel
            The FE model the problem is built around (``p = 0``).

        Returns
        -------
        UpdateProblem
        """
        return build_problem(fe, self.measured, self.parameters, self.damping, self.modes,
                             fmax=self.fmax, loads=self.loads)


def _normal_mode_model(prob, fe1, measured):
    """The updated model on the test's I/O as a NormalModeModel (shapes on the FE DOFs)."""
    from sdctrl.modal._normal_model import NormalModeModel

    rm = prob.rm
    z = np.zeros(rm.npar)
    _M, C, _K = rm.matrices(z)
    w2, X = rm.modes(z)
    G = X.T @ C @ X
    return NormalModeModel(np.diag(np.clip(w2, 0, None)), 0.5 * (G + G.T), rm.c @ X,
                           X.T @ rm.b, sensors=measured.frf.sensors,
                           actuators=measured.frf.actuators, shapes=prob.basis.T @ X,
                           dofs=fe1.dofs, info={"source": "update"})


def _pairing_table(modes, before, after) -> dict:
    if before is None or after is None:
        return {k: np.zeros(0) for k in ("test_hz", "fe_hz_before", "mac_before",
                                          "fe_hz_after", "mac_after")}
    return {"test_hz": modes.frequency.copy(), "fe_hz_before": before[2][before[0]],
            "mac_before": before[1], "fe_hz_after": after[2][after[0]], "mac_after": after[1]}


def _damping_text(choice, modes) -> str:
    kind, ratio = choice
    if kind == "matrix":
        return "FE damping matrix C (projected)"
    if ratio is not None:
        return f"modal, ratio {ratio:g} on every mode"
    return f"modal, from the data ({modes.source}, paired by MAC)"
