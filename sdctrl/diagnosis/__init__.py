"""Closing the loop with measured data: :func:`diagnose` (issue "residual -> missing effect ->
corrected model -> error before/after").

- residuals.py: the complex logLS residual (3.12), where it concentrates, its noise level and
  the information criterion (extended BIC) that ranks candidate effects;
- placed.py: measured FRFs placed on a model's channels (displacement/force);
- effects.py: global candidates (delay, residual flexibility/mass, a free extra mode,
  non-proportional damping);
- candidates.py, lowrank.py, scan.py: physical candidates on an FE model (dashpots and
  stiffness changes between node pairs, mass changes at nodes, resonators), evaluated by
  reanalysis (4.17) as low-rank feedback (4.22) with static corrections (4.23), Woodbury on
  the model's complex modes;
- apply.py: corrected models (quasi-static correction modes, re-diagonalisation;
  :class:`DelayedModel`);
- joint_fit.py: the accepted effects refitted together after each step;
  effect_statistics.py: their standard deviations (Cramer-Rao, one joint Jacobian);
- result.py: :class:`Effect` and :class:`Diagnosis`; loop.py: :func:`diagnose` (an effect
  accepted only when significant: a Bonferroni chi-square test over the step's hypotheses,
  residuals.py).
"""

from sdctrl.diagnosis._apply import DelayedModel
from sdctrl.diagnosis._loop import diagnose
from sdctrl.diagnosis._result import EFFECT_KINDS, Diagnosis, Effect

__all__ = ["EFFECT_KINDS", "DelayedModel", "Diagnosis", "Effect", "diagnose"]
