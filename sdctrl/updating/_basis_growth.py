"""The update's reduced basis grown until it no longer limits the fit (4.23)-(4.24).

The update fits the parameters on a reduced basis: the normal modes up to ``fmax`` (default
:data:`~sdctrl.updating._update_fit.FMAX_FACTOR` times the band top) with static correction
modes.  What the truncated modes' dynamics leave out is a model error no parameter can
reach: on a structure whose modes above the band matter more than the default assumes (a
held-out aircraft model: 74x the noise floor at 1% with modes to 155 Hz, 6x with modes to
620 Hz), the update stops above the floor for want of modes, not of parameters.  The rule
is decided from the data: while the final cost is above :data:`FLOOR_FACTOR` times the
data's noise floor and the same parameters on a basis with modes to twice ``fmax`` lower it
by more than half, the basis is doubled and the parameters refined on it (at most
:data:`DOUBLINGS` times), then around the model solved again on it
(:func:`~sdctrl.updating._final_stages.refined`).  Growing it also while the richer basis
merely moves the parameters by a tenth of their standard deviation (the cluster at 1%
noise: hub stiffness 7.9e-4 -> 1.2e-4 off, both within the stated standard deviation) was
measured and not kept: every member's basis then grows, and the testbed's update takes 2.7x
as long (``benchmarks/bench_update.py``).  A caller who gives ``fmax`` keeps it (the
verdict says when it limits the fit, :func:`~sdctrl.updating._fit_floor.basis_limited`).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from sdctrl.updating._fit_floor import FLOOR_FACTOR, noise_floor
from sdctrl.updating._global_start import solve_bounded
from sdctrl.updating._final_stages import Solved
from sdctrl.updating._problem import apply_parameters

__all__ = ["DOUBLINGS", "grown", "on_richer_basis"]

#: most doublings of ``fmax``
DOUBLINGS = 2


def on_richer_basis(solved: Solved):
    """``(setup, problem, cost)`` of ``solved``'s parameters with modes to twice its
    ``fmax`` (the problem built around ``solved.fe1``).

    Parameters
    ----------
    solved : Solved

    Returns
    -------
    tuple
    """
    setup = replace(solved.setup, fmax=2 * solved.setup.fmax)
    prob = setup.problem(solved.fe1)
    return setup, prob, prob.cost(np.zeros(solved.p.size))


def grown(fe, solved: Solved, box, stages: list) -> Solved:
    """``solved`` on a basis grown while it limits the fit (module notes).

    Parameters
    ----------
    fe : FEModel
        The model the parameters apply to.
    solved : Solved
        The solution on the default basis.
    box : (lo, hi, scale, nfev_max)
        Parameter bounds, scales and the evaluation limit of a refinement.
    stages : list
        The update's stage records (a stage is added per doubling).

    Returns
    -------
    Solved
    """
    lo, hi, scale, nfev_max = box
    floor = noise_floor(solved.setup.measured.frf.H)
    for _ in range(DOUBLINGS):
        if not solved.cost > FLOOR_FACTOR * floor:
            break
        richer, prob2, cost2 = on_richer_basis(solved)
        if not cost2 < 0.5 * solved.cost:
            return replace(solved, richer=cost2)
        q0 = np.zeros(solved.p.size)
        p = solved.p
        q, n = solve_bounded(prob2.residual, q0, lo - p, hi - p, scale, 1e-6, nfev_max)
        p = np.clip(p + q, lo, hi)
        fe1 = apply_parameters(fe, richer.parameters, p)
        prob1 = richer.problem(fe1)
        cost = prob1.cost(q0)
        stages.append({"stage": f"basis grown: modes to {richer.fmax:.4g} Hz",
                       "values": p.copy(), "cost": cost, "nfev": n + 1})
        solved = Solved(richer, fe1, prob1, p, cost)
    return solved
