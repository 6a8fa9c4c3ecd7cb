"""Chapter V.2 of the thesis: structured uncertainty and robust stability.

Workflow: a normal-mode model and bounds on its parameters (``nm.uncertain(...)``, 5.5, or
bounds from several tests, 5.2.3) give an :class:`UncertainModel`; its linear fractional form
(``lft``) closed with a controller gives the structured singular value problem that
:func:`robust_stability` bounds from above (D-G scalings, certified over the frequency axis)
and from below (a destabilising real perturbation).

- ``_uncertainty``: :class:`UncertainModel`, bounds (:func:`psd_gamma_bound`: the damping
  couplings ``Gamma`` positive semi-definite allows, 5.2.2), the LFT (5.5);
- ``_multitest``: statistics of several identified models of one structure (5.2.3);
- ``_from_data``: :func:`uncertain_from_data`, bounds from identification statistics or tests;
- ``_stability``: :func:`robust_stability`, :func:`worst_case_gain`;
- ``mu``: the structured singular value of one matrix and over frequency.

This package works on the matrices of a second-order model and never imports
:mod:`sdctrl.modal`, so that ``NormalModeModel.uncertain`` can build an :class:`UncertainModel`.
"""

from sdctrl.robust._from_data import uncertain_from_data
from sdctrl.robust._multitest import MultiTestResult, multi_test_statistics
from sdctrl.robust._stability import RobustResult, robust_stability, worst_case_gain
from sdctrl.robust._uncertainty import UncertainModel, psd_gamma_bound

__all__ = ["MultiTestResult", "RobustResult", "UncertainModel", "multi_test_statistics",
           "psd_gamma_bound", "robust_stability", "uncertain_from_data", "worst_case_gain"]
