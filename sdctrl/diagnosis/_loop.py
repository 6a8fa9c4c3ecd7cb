"""Closing the loop with measured data: :func:`diagnose`.

Residual -> candidate effects (each a physical hypothesis with few parameters, fitted to the
data) -> ranking by the extended BIC (:mod:`._residual_map`) -> the best effect accepted only
when significant (Bonferroni chi-square test, :func:`._residual_map.false_alarm`) -> all
accepted effects refitted together (:mod:`._joint_fit`) -> the same again on the new
residual, until no candidate helps enough.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, replace

import numpy as np

from sdctrl._lib.threads import single_thread
from sdctrl._lib.validate import check_executor, check_int, check_scalar
from sdctrl.diagnosis._apply import DelayedModel, apply_effect
from sdctrl.diagnosis._band_rules import in_band, trend
from sdctrl.diagnosis._candidates import Candidates, candidate_groups
from sdctrl.diagnosis._effect_statistics import joint_std, undetermined
from sdctrl.diagnosis._global_effects import (fit_delay, fit_free_mode, fit_nonproportional,
                                              fit_residual_terms, leaves_region)
from sdctrl.diagnosis._joint_fit import pruned, refit, shed_trends
from sdctrl.diagnosis._locations import checked_locations
from sdctrl.diagnosis._placed_data import place
from sdctrl.diagnosis._residual_map import (
    ALPHA,
    complex_residual,
    cost,
    ebic_score,
    false_alarm,
    noise_floor,
    noise_level,
)
from sdctrl.diagnosis._result import Diagnosis, Effect
from sdctrl.diagnosis._candidate_scan import physical_proposals, setup

__all__ = ["diagnose"]

#: an effect must explain at least this share of the error above the noise level ...
MIN_GAIN = 0.05
#: ... and at least this share of the initial error above the noise level
MIN_SHARE = 0.001
#: costs below this are round-off: the model reproduces the data
ROUNDOFF = 1e-24
#: at most this many steps, whatever ``max_effects``
MAX_STEPS = 50
#: runner-up candidates kept per step
N_RUNNERS = 8
#: candidates tried in turn in a step when a joint refit rejects the best
N_TRIES = 3
#: why a candidate whose joint refit left a free mode's region is rejected
EDGE = ("its joint refit moved a free mode onto the edge of its region (a broadband trend, "
        "not a mode)")
#: after an effect, the next scan is skipped when even a noise level this share of the
#: data's noise floor leaves less error than an effect must remove (:func:`_exhausted`)
NOISE_SHARE = 0.9


@dataclass(frozen=True, eq=False)
class _Settings:
    """The options of one :func:`diagnose` call, checked."""

    band: tuple | None
    reach: float | None
    locations: tuple | None
    max_effects: int
    noise: float | None
    progress: bool | None


def _check(model, frf, fe, executor, max_effects, noise, reach):
    from sdctrl.fe import FEModel
    from sdctrl.data._frf import FRF
    from sdctrl.identification import ComplexModeModel
    from sdctrl.modal._normal_model import NormalModeModel

    inner = model.model if isinstance(model, DelayedModel) else model
    if not isinstance(inner, NormalModeModel | ComplexModeModel):
        raise TypeError("model must be a NormalModeModel (identified, FE-derived or hybrid), a "
                        f"ComplexModeModel or a DelayedModel, got {type(model).__name__}")
    if not isinstance(frf, FRF):
        raise TypeError(f"frf must be an sdctrl.FRF, got {type(frf).__name__}")
    if fe is not None and not isinstance(fe, FEModel):
        raise TypeError(f"fe must be an sdctrl.FEModel or None, got {type(fe).__name__}")
    check_executor(executor)
    check_int(max_effects, "max_effects", minimum=0)
    check_scalar(noise, "noise", nonneg=True, optional=True)
    check_scalar(reach, "reach", positive=True, optional=True, allow_inf=True)
    physical = fe is not None and isinstance(inner, NormalModeModel)
    if physical and (inner.shapes is None or fe.nodes is None):
        warnings.warn("diagnose: physical candidates (dampers, springs, masses, resonators) need "
                      "fe with node coordinates and a model whose shapes live on fe's DOFs (or "
                      "whose sensor/actuator labels are fe's DOF labels, so that it can be "
                      "placed on fe); build a hybrid model (sd.hybrid) from identified modes",
                      stacklevel=3)
        physical = False
    return physical


def _on_fe(model, fe):
    """``(model, what was built)``: a model without shapes whose sensor and actuator labels are
    DOF labels of ``fe`` is placed on ``fe`` as a hybrid model (expansion 4.7, as
    :func:`sdctrl.hybrid` does); a complex-mode model through its normal modes (3.3) first.
    Unchanged, with None, when that is not possible or not needed."""
    from sdctrl.diagnosis._static_states import static_shapes
    from sdctrl.hybrids import hybrid
    from sdctrl.identification import ComplexModeModel, normal_modes
    from sdctrl.modal._normal_model import NormalModeModel

    from sdctrl.fe import FEModel

    delayed = isinstance(model, DelayedModel)
    inner = model.model if delayed else model
    if (not isinstance(fe, FEModel) or fe.nodes is None
            or getattr(inner, "shapes", None) is not None):
        return model, None                        # (a wrong fe is refused by _check)
    dofs = set(fe.dofs)
    if not (set(inner.sensors) <= dofs and set(inner.actuators) <= dofs):
        return model, None
    what = ""
    if isinstance(inner, ComplexModeModel):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                inner = normal_modes(inner)
        except ValueError as exc:
            return model, f"not placed on the FE model: its normal modes cannot be formed ({exc})"
        what = f"normal modes of the complex-mode model (3.3, {inner.n} modes), then "
    if not isinstance(inner, NormalModeModel):
        return model, None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        # only the measured modes' expanded shapes are read: the same for every residual
        # representation, so the cheapest is built (not the default's leave-one-out choice)
        hy = hybrid(fe, inner, list(inner.sensors), list(inner.actuators),
                    residual="identified")
    w, wh = np.diag(inner.Omega), np.diag(hy.Omega)
    idx = np.array([int(np.argmin(np.abs(wh - x))) for x in w], dtype=int)
    if np.allclose(wh[idx], w, rtol=1e-12, atol=0) and np.unique(idx).size == idx.size:
        placed, k = static_shapes(fe, inner.replace(shapes=hy.shapes[:, idx], dofs=hy.dofs),
                                  hy.construction.pairing)
        what += (f"its {inner.n} modes given shapes on the FE model's {fe.N} DOFs by the "
                 "expansion of a hybrid model (4.7, as sd.hybrid does)"
                 + (f", {k} static-correction states those of the FE's static correction "
                    "of its inputs (4.23)" if k else "")
                 + ", its response at the tested channels unchanged, so that physical "
                 "candidates can be placed on it")
    else:
        placed = hy
        what += (f"a hybrid model of its {inner.n} modes on the FE model's {fe.N} DOFs "
                 "(measured shapes expanded, 4.7, as sd.hybrid does), so that physical "
                 "candidates can be placed on it")
    return (DelayedModel(placed, model.tau) if delayed else placed), what


def _fe_flexibility(S, placed, model):
    """The FE's residual flexibility of the data actuators at the data sensors (w.r.t. the
    model's shapes), when the model carries none (no ``E``)."""
    if model.E is not None:
        return None
    pos = {int(d): i for i, d in enumerate(S.dof_idx)}
    out = np.zeros(placed.Hd.shape[1:])
    for j, lab in enumerate(placed.actuators):
        i = {lab_: k for k, lab_ in enumerate(S.fe.dofs)}.get(lab)
        if i is not None and i in pos:
            out[:, j] = S.static.Fyd[placed.rows, pos[i]]
    return out if np.any(out) else None


def _proposals(inner, placed, H, S, executor, progress):
    """Every candidate effect fitted to the current residual."""
    from sdctrl.modal._normal_model import NormalModeModel

    props = [fit_delay(placed, H)]
    props += fit_residual_terms(placed, H, None if S is None else
                                _fe_flexibility(S, placed, inner))
    free = fit_free_mode(placed, H)
    if free is not None:
        props.append(free)
    if isinstance(inner, NormalModeModel):
        npd = fit_nonproportional(placed, inner, placed.rows, placed.cols, H)
        if npd is not None:
            props.append(npd)
    if S is not None:
        mode = None if free is None else (free["payload"]["omega"], free["payload"]["zeta"])
        props += physical_proposals(S, placed, H, mode, executor, progress)
    return props


def _summary(p) -> dict:
    return {k: p[k] for k in ("kind", "location", "parameters", "cost", "k", "m", "score",
                              "false_alarm")}


def diagnose(model, frf, fe=None, executor=None, *, band=None, reach: float | None = None,
             locations=None, max_effects: int = 4, noise: float | None = None,
             progress: bool | None = None) -> Diagnosis:
    """Trace the residual between a model and measured FRFs to the effects the model lacks.

    Each step fits every candidate effect to the current residual -- a measurement delay,
    residual flexibility and mass terms, an extra mode, non-proportional damping and, with
    an FE model, a dashpot or a stiffness change between any two nodes (every element and
    every unconnected pair within ``reach``), a mass change at any node and a resonator (a
    mass on a spring along one axis) at any node translation -- ranks them by their error
    reduction penalised by their number of parameters and of hypotheses scanned (extended
    BIC on the complex logLS residual, noise level from its second differences), adds the
    best to the model, refits the sizes of all the effects accepted so far together
    (:mod:`._joint_fit`) and starts again, until no candidate helps enough.

    Nothing is invented: the best candidate is accepted only when (a) the error it removes
    exceeds what noise alone would remove by chance in a search over that many candidates --
    under the null hypothesis (residual = complex Gaussian noise of variance ``sigma^2``,
    estimated from the data) ``T = 2 N (J - J_e) / sigma^2`` is chi-square with ``k`` (its
    number of parameters) degrees of freedom, and the Bonferroni bound over the ``M`` hypotheses
    of the step (every family's locations, lines or channels together), ``M P(chi^2_k > T)``,
    must be below ``ALPHA = 1e-3`` -- and (b) it removes at least 5% of the error above the
    noise level and 0.1% of the initial one (a second effect may be much smaller than the
    first). After an effect, the next scan is not run when no effect could pass (b) any more: an
    effect cannot remove the measurement noise, so when the error left less 0.9 x a low estimate
    of the noise (robust to correlated neighbouring lines) is below the share (b) asks, the
    search stops (said in :attr:`Diagnosis.steps`; the result is the one the scan would give).
    (c) Its size must be determined: more than 3 standard deviations from zero (the dashpot,
    mass, spring or delay; a missing mode's damping), else nothing is added in that step (a
    dashpot driven to a rigid link, a "mode" as uncertain in damping as it is damped, absorb
    model error without a size). A free extra mode stays a mode: when the joint refit of the
    effects moves it onto the edge of its region (frequency 0.8-1.2 times the band's ends,
    damping ratio 0.5) it is a broadband trend, and the step's next significant candidate is
    tried instead (said in :attr:`Diagnosis.steps` and the report). An extra mode found inside
    the band (its peak and half-power points in it) and significant excludes the residual
    flexibility/mass terms of that step: those stand for effects outside the band and would
    otherwise absorb a missing in-band mode. Physical candidates are evaluated by reanalysis
    (4.17), (5.2): the change is a low-rank feedback on its load shape (4.22), completed by its
    static correction (4.23), evaluated on all lines at once by a Woodbury update of the model's
    complex modes; a vectorised screen ranks them all, the best are fitted on all the data.

    Parameters
    ----------
    model : NormalModeModel, ComplexModeModel or DelayedModel
        The model: identified, FE-derived or hybrid.  Physical candidates need ``fe`` and a
        normal-mode model with ``shapes`` on the FE DOFs (FE-derived or hybrid); a model
        without shapes whose sensor and actuator labels are DOF labels of ``fe`` (an
        identified model, a complex-mode model through its normal modes) is placed on ``fe``
        first as a hybrid model (4.7, :func:`sdctrl.hybrid`), said in
        :attr:`Diagnosis.built` and the report.  Its sensor/actuator labels must include the
        data's.
    frf : FRF
        Measured FRFs (any quantity).
    fe : FEModel, optional
        The FE model the effects are located on (node coordinates for pairs).
    executor : concurrent.futures.Executor, optional
        Runs the screen chunks and the fits (a Dask client's executor works); the ranking is
        identical to the serial one.
    band : (float, float), optional
        Band (Hz) of the comparison; default all lines of ``frf``.
    reach : float, optional
        Largest distance (m) between two unconnected nodes scanned as a pair; default 1.5
        times the longest element, elements longer than 4 times the median one left out
        (a brace or a damper across the structure is not the mesh's scale).
    locations : list of str and (str, str), optional
        Scan only these physical locations (instead of every element, node and pair within
        ``reach``): node names (a mass change at the node, a resonator on each of its
        translations) and pairs of node names (a dashpot and a stiffness change between them;
        a beam element listed is also scaled whole).  The scan then grows with the locations
        listed, not with the FE model.  Needs ``fe``; not with ``reach``.
    max_effects : int
        At most this many effects are added.
    noise : float, optional
        Expected complex logLS cost of the measurement noise alone (e.g. from coherence:
        ``mean((1 - coh) / (n_averages coh))``); default estimated from the residual's
        second differences along frequency.
    progress : bool, optional
        Progress bars (default: the policy of :mod:`sdctrl.config`).

    Returns
    -------
    Diagnosis
        ``error_before``/``error_after`` (complex logLS cost 3.12), ``effects`` (ranked
        :class:`Effect` list), ``model`` (the corrected model), ``report()``.

    Raises
    ------
    TypeError
        Wrong types of ``model``, ``frf``, ``fe`` or ``executor``.
    ValueError
        Data channels missing from the model, bad options.

    Examples
    --------
    >>> import sdctrl as sd
    >>> fe = sd.testbed()
    >>> nm = fe.normal_mode_model(list(sd.testbeds.SHAKERS), list(sd.testbeds.SENSORS), 28,
    ...                           static=True, static_damping="projected")
    >>> frf = nm.frf(sd.testbed_frf(n=200).freq, "acceleration")
    >>> sd.diagnose(nm, frf, fe).effects             # the model's own prediction
    []
    """
    model, built = _on_fe(_checked_model(model), fe)
    physical = _check(model, frf, fe, executor, max_effects, noise, reach)
    opts = _Settings(band, reach, checked_locations(locations, fe, reach), max_effects, noise,
                     progress)
    with single_thread():         # small dense kernels: BLAS threads only add contention
        out = _run_steps(model, frf, fe, executor, opts, physical)
    return replace(out, built=built) if built else out


def _checked_model(model):
    from sdctrl.identification import ComplexModeModel
    from sdctrl.modal._normal_model import NormalModeModel

    inner = model.model if isinstance(model, DelayedModel) else model
    if not isinstance(inner, NormalModeModel | ComplexModeModel):
        raise TypeError("model must be a NormalModeModel (identified, FE-derived or hybrid), a "
                        f"ComplexModeModel or a DelayedModel, got {type(model).__name__}")
    return model


def _hypotheses(props) -> int:
    """Number of hypotheses searched in a step: the sizes ``m`` of its families (one count
    per kind of effect and way of fitting it), summed."""
    fams = {}
    for p in props:
        key = (p["kind"], p["action"])
        fams[key] = max(fams.get(key, 0), p["m"])
    return int(sum(fams.values()))


def _ranked(props, J, sigma2, N, freq):
    """Proposals scored (extended BIC), tested (false-alarm probability over all the step's
    hypotheses) and ranked; residual terms, which stand for effects outside the band, are
    left out when a significant extra mode lies inside it (they would absorb it)."""
    props = [p for p in props if not trend(p, freq)]
    M = _hypotheses(props)
    for p in props:
        p["score"] = ebic_score(J, p["cost"], sigma2, N, p["k"], p["m"])
        p["false_alarm"] = false_alarm(J, p["cost"], sigma2, N, p["k"], M)
    if any(in_band(p, freq) and p["false_alarm"] < ALPHA for p in props):
        props = [p for p in props if p["action"] != "residual"]
    return sorted(props, key=lambda p: -p["score"])


def _exhausted(J, J0, sigma2, floor) -> bool:
    """No effect can pass the share test of :func:`_accepted` any more.

    An effect's cost ``J_e`` includes the measurement noise, which no smooth change of the
    model removes (a ``k``-parameter effect fits a share ``k / N`` of it): ``J_e >=
    sigma_t^2``, the true noise level, and the most an effect can remove is ``J -
    sigma_t^2``.  ``floor`` is a low estimate of ``sigma_t^2`` (:func:`noise_floor`: robust
    to correlated neighbouring lines, three standard deviations below its estimate): when
    ``J - NOISE_SHARE floor`` is below the least share an effect must remove (``MIN_SHARE``
    of the initial error above the noise ``sigma2``), the scan could not accept anything
    and is not run."""
    return bool(J - NOISE_SHARE * floor < MIN_SHARE * max(J0 - sigma2, 0.0))


def _skip_reason(J, J0, floor) -> str:
    """Why the scan after the last effect was not run (:func:`_exhausted`)."""
    return (f"not scanned: the error left ({J:.3g}) less {NOISE_SHARE:g} x the noise floor "
            f"({floor:.3g}) is below what an effect must remove, {100 * MIN_SHARE:g}% of "
            f"the initial error ({J0:.3g}) above the noise")


def _accepted(best, J, J0, sigma2) -> bool:
    """Significant (false alarm below ALPHA) and a real share of the error above noise."""
    gain = J - best["cost"]
    return bool(best["false_alarm"] < ALPHA and gain >= MIN_GAIN * max(J - sigma2, 0.0)
                and gain >= MIN_SHARE * max(J0 - sigma2, 0.0))


@dataclass(frozen=True, eq=False)
class _Extension:
    """The effects after a step (None: nothing added), the corrected model, the candidates
    rejected (:func:`_extended`) and the indices of the earlier effects the new one made
    redundant (:func:`._joint_fit.pruned`); the corrected model's response and cost when the
    joint refit computed them (else None)."""

    trial: list | None
    model: object
    rejected: list
    dropped: tuple = ()
    H: np.ndarray | None = None
    J: float | None = None


def _extended(model, current, accepted, props, errors, placed0) -> _Extension:
    """The first ranked proposal that passes the test (:func:`_accepted`; ``errors`` is
    ``(J, J0, sigma2)``) and whose joint refit with the effects already accepted keeps every
    free mode in its region (a mode refitted onto the region's edge is a broadband trend,
    not a mode: the next candidate is tried, at most ``N_TRIES``).  When the best
    explanation left has no determined size (:func:`undetermined`), nothing is added: a
    lower-ranked effect would only absorb what it leaves."""
    rejected = []
    for best in props[:N_TRIES]:
        if not _accepted(best, *errors):
            break
        fit = None                     # a lone effect keeps its own fit (fit_free_mode's)
        if accepted:
            fit, shed = shed_trends(model, accepted + [best],
                                    refit(model, accepted + [best], placed0, errors[2]),
                                    placed0, errors[2])
        why = (EDGE if fit is not None and any(leaves_region(q, placed0.omega)
                                               for q in fit.props)
               else undetermined([best] if fit is None else fit.props, model, placed0,
                                 errors[2]))
        if why is None and fit is None:
            return _Extension([best], apply_effect(current, best, placed0), rejected)
        if why is None:
            fit, dropped = pruned(model, fit, placed0, errors[2])
            kept = [i for i in range(len(accepted) + 1) if i not in shed]
            dropped = sorted(shed + [kept[j] for j in dropped])
            return _Extension(fit.props, fit.model, rejected, tuple(dropped), fit.H, fit.J)
        rejected.append({"kind": best["kind"], "location": best["location"], "reason": why})
        if why is not EDGE:            # the best explanation left has no size: stop
            break
    return _Extension(None, current, rejected)


def _step(current, placed0, fe, cand, executor, progress, physical, H=None):
    """Proposals fitted to the residual of the current model (``H`` its response on
    ``placed0`` when already computed)."""
    inner, tau = ((current.model, current.tau) if isinstance(current, DelayedModel)
                  else (current, 0.0))
    placed = placed0.undelayed(tau)
    Hin = H if H is not None and tau == 0.0 and inner is current else placed.response(inner)
    S = setup(inner, fe, placed, cand) if physical else None
    return _proposals(inner, placed, Hin, S, executor, progress)


def _run_steps(model, frf, fe, executor, opts: _Settings, physical):
    """The steps of :func:`diagnose` (arguments checked)."""
    t0 = time.perf_counter()
    noise, progress = opts.noise, opts.progress
    inner0 = model.model if isinstance(model, DelayedModel) else model
    placed0 = place(inner0, frf, opts.band)
    H = placed0.response(model)               # the current model's response, computed once
    J0 = J = cost(H, placed0.Hd)
    sigma2 = float(noise) if noise is not None else noise_level(
        complex_residual(H, placed0.Hd))
    cand = (Candidates(*candidate_groups(fe, opts.reach, opts.locations), kinv={})
            if physical else None)
    N = placed0.n_entries
    current, accepted, errors, steps, times = model, [], [], [], []
    for _step_ in range(min(int(opts.max_effects), MAX_STEPS)):
        if J <= ROUNDOFF:
            break
        floor = (min(sigma2, noise_floor(complex_residual(H, placed0.Hd))) if accepted
                 else 0.0)
        if accepted and _exhausted(J, J0, sigma2, floor):
            steps.append({"accepted": False, "rejected": [], "dropped": [], "candidates": [],
                          "skipped": _skip_reason(J, J0, floor)})
            break
        ts = time.perf_counter()
        props = _ranked(_step(current, placed0, fe, cand, executor, progress,
                              physical, H), J, sigma2, N, placed0.freq)
        ext = _extended(model, current, accepted, props, (J, J0, sigma2), placed0)
        steps.append({"accepted": ext.trial is not None, "rejected": ext.rejected,
                      "dropped": [_summary(accepted[k]) for k in ext.dropped],
                      "candidates": [_summary(p) for p in props[:N_RUNNERS]]})
        if ext.trial is None:
            times.append(time.perf_counter() - ts)
            break
        best, trial, new = ext.trial[-1], ext.trial, ext.model
        H_new = placed0.response(new) if ext.H is None else ext.H
        J_new = cost(H_new, placed0.Hd) if ext.J is None else ext.J
        times.append(time.perf_counter() - ts)
        if not J_new < J:
            warnings.warn(f"diagnose: the corrected model does not reduce the error "
                          f"({best['kind']} at {best['location']}: {J:.3g} -> {J_new:.3g}); "
                          "stopping", RuntimeWarning, stacklevel=2)
            steps[-1]["accepted"] = False
            break
        accepted, current, J, H = trial, new, J_new, H_new
        errors = [e for k, e in enumerate(errors) if k not in ext.dropped] + [J_new]
        if noise is None:
            sigma2 = min(sigma2, noise_level(complex_residual(H, placed0.Hd)))
    effects = _effects(model, accepted, errors, J0, placed0, sigma2)
    info = {"time": time.perf_counter() - t0, "step_times": times, "n_entries": N,
            "physical": physical, "band": (float(placed0.freq[0]), float(placed0.freq[-1]))}
    if cand is not None:
        info["candidates"] = {k: g.size for k, g in cand.groups.items()}
        info["n_elements"] = cand.n_elements
        info["listed"] = opts.locations is not None
    return Diagnosis(current, effects, J0, J, model, placed0.frf, sigma2, steps, info,
                     applied=tuple(accepted))


def _effects(model, accepted, errors, J0, placed0, sigma2):
    """The accepted effects with their (jointly refitted) sizes, the errors of their steps
    and standard deviations from the joint Jacobian."""
    if not accepted:
        return []
    stds = joint_std(accepted, model, placed0, placed0, sigma2)
    out, before = [], J0
    for p, after, std in zip(accepted, errors, stds):
        out.append(Effect(p["kind"], p["location"], p["parameters"], before, after, std))
        before = after
    return out
