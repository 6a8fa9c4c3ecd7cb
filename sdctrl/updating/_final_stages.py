"""The update's last stages: the full FE model solved again at the optimum of the reduced
model (4.17) and the logLS refined around it while that pays (thesis 4.4,
:func:`sdctrl.update`).

The optimum of a reduced model is that of its basis (the normal modes up to ``fmax`` and the
static correction modes of the nominal model, 4.23-4.24), not the full model's.  Solved
again at that optimum, the model gives a basis built around it; the logLS refined there moves
the parameters toward the full model's optimum.  Each step is worth a model solve while it
moves the parameters by :data:`REFINE_STEP` of their standard deviation or more
(:func:`worth_a_step`), on the default basis and on a grown one
(:mod:`sdctrl.updating._basis_growth`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sdctrl.updating._global_start import solve_bounded
from sdctrl.updating._problem import apply_parameters
from sdctrl.updating._update_statistics import fitted_std

__all__ = ["REFINE_STEP", "RESOLVE_ROUNDS", "Solved", "refined", "resolved", "solved_at",
           "worth_a_step"]

#: a refinement is worth its model solve when it moves the parameters by this many standard
#: deviations or more (:func:`worth_a_step`)
REFINE_STEP = 0.1
#: at most this many refinements around a re-solved model
RESOLVE_ROUNDS = 3


@dataclass(frozen=True, eq=False)
class Solved:
    """An update's solution on one basis: its setup (``fmax``), the updated FE model, its
    reduced problem (``p = 0`` at ``fe1``), the parameter values and the cost; ``richer``
    the cost of the same parameters with modes to twice ``fmax`` when it was evaluated."""

    setup: object
    fe1: object
    prob1: object
    p: np.ndarray
    cost: float
    richer: float | None = None


def worth_a_step(step, std) -> bool:
    """Whether a refinement's ``step`` moves some parameter by :data:`REFINE_STEP` of its
    standard deviation ``std`` or more (the update's stated one: the larger of the noise's and
    the sensors' scatter, :func:`~sdctrl.updating._update_statistics.fitted_std`; an
    undetermined std counts as no limit).

    Parameters
    ----------
    step : ndarray, shape (npar,)
        The refinement's change of the parameters.
    std : ndarray, shape (npar,)
        Their standard deviations.

    Returns
    -------
    bool
    """
    std = np.where(np.isfinite(std), std, 0.0)
    return bool(np.any(np.abs(step) > REFINE_STEP * std))


def resolved(fe, setup, p, opts, stages: list, strategy: str) -> Solved:
    """Stage 3: the full model solved again at ``p`` and refined around it (:func:`refined`;
    not for ``strategy="frequencies"``).

    Parameters
    ----------
    fe : FEModel
        The nominal model the parameters apply to.
    setup : UpdateSetup
        What the update's problems share (:class:`~sdctrl.updating._update_fit.UpdateSetup`).
    p : ndarray
        The reduced model's optimum.
    opts : (lo, hi, scale, nfev_max)
        Parameter bounds, scales and the evaluation limit of a refinement.
    stages : list
        The update's stage records (appended to).
    strategy : str
        The update's strategy.

    Returns
    -------
    Solved
    """
    fe1, prob1, cost = solved_at(fe, setup, p, stages)
    if strategy == "frequencies":
        return Solved(setup, fe1, prob1, p, cost)
    return refined(fe, Solved(setup, fe1, prob1, p, cost), opts, stages)


def refined(fe, solved: Solved, opts, stages: list) -> Solved:
    """``solved`` refined on the basis built around it, again while that pays.

    The optimum of a reduced model (4.17) is that of its basis: built around another model,
    it holds the solution only approximately (on the family of test structures, noise-free,
    1.3e-4 from the full model's optimum at a cost below the noise floor: several standard
    deviations of the parameters at 1% noise).  So the logLS is refined on the basis built
    around the current solution while its step is :data:`REFINE_STEP` of a standard deviation
    or more (:func:`worth_a_step`), at most
    :data:`RESOLVE_ROUNDS` times; a step is kept where the model solved again agrees, and
    the refinement stops when that model gains less than half the predicted gain (the
    basis, not the parameters, then limits the fit).

    Parameters
    ----------
    fe : FEModel
        The nominal model the parameters apply to.
    solved : Solved
        The solution and the problem built around it.
    opts : (lo, hi, scale, nfev_max)
        Parameter bounds, scales and the evaluation limit of a refinement.
    stages : list
        The update's stage records (appended to).

    Returns
    -------
    Solved
    """
    lo, hi, scale, nfev_max = opts
    setup, fe1, prob1, p, cost = solved.setup, solved.fe1, solved.prob1, solved.p, solved.cost
    q0 = np.zeros(p.size)
    names = [par.name for par in setup.parameters]
    for _ in range(RESOLVE_ROUNDS):
        q, n = solve_bounded(prob1.residual, q0, lo - p, hi - p, scale, 1e-6, nfev_max)
        predicted = prob1.cost(q)
        std = fitted_std(prob1, setup.measured, names, scale)
        if predicted >= cost or not worth_a_step(q, np.array(list(std.values()))):
            break
        p_new = np.clip(p + q, lo, hi)
        stages.append({"stage": "logLS around the new solution", "values": p_new.copy(),
                       "cost": predicted, "nfev": n})
        fe2, prob2, cost2 = solved_at(fe, setup, p_new, stages)
        if cost2 >= cost:
            break
        gain_ratio = (cost - cost2) / (cost - predicted)
        fe1, prob1, p, cost = fe2, prob2, p_new, cost2
        if gain_ratio < 0.5:
            break
    return Solved(setup, fe1, prob1, p, cost)


def solved_at(fe, setup, p, stages: list):
    """The model at ``p``, its problem (basis built around it) and its cost there, recorded
    as a stage.

    Parameters
    ----------
    fe : FEModel
        The nominal model.
    setup : UpdateSetup
        What the update's problems share.
    p : ndarray
        Parameter values.
    stages : list
        The update's stage records (appended to).

    Returns
    -------
    fe1 : FEModel
    prob1 : UpdateProblem
    cost : float
    """
    fe1 = apply_parameters(fe, setup.parameters, p)
    prob1 = setup.problem(fe1)
    cost = prob1.cost(np.zeros(len(setup.parameters)))
    stages.append({"stage": "full FE solved again", "values": np.array(p, float),
                   "cost": cost, "nfev": 1})
    return fe1, prob1, cost
