"""Chapter IV of the thesis: FE model update.

- costs.py: FRF costs (quadratic 3.11, logLS 3.12) and modal criteria (MAC 4.9, COMAC);
- correlation.py: frequency (4.8), scaled observability (4.10), orthogonality (4.12) and
  modal energy (4.13) criteria;
- expansion.py: expansion of measured modes (4.7) and FE/test mode pairing (4.9);
- reanalysis.py: reanalysis of a normal-mode model for changes on physical DOFs (4.17);
- basis.py: Ritz bases with static correction modes of modification loads (4.22)-(4.24);
- parametric.py: the parametric reduced model (4.17) and first-order perturbation (4.19);
- measured.py, problem.py, fit.py: the update, :func:`update` (section 4.4);
- sensitivity.py: identifiability (Table 4.1) and cost maps (Figure 4.6);
- sweep.py: accuracy of perturbation and reanalysis over a parameter sweep (Figure 4.3).

Parameters (4.15) are :class:`sdctrl.Parameter` objects (their one home is :mod:`sdctrl.fe`).
"""

from sdctrl.updating._ritz_basis import ReducedBasis, reduced_basis
from sdctrl.updating._mode_correlation import (
    frequency_error,
    mixed_orthogonality,
    modal_energies,
    observability_error,
)
from sdctrl.updating._costs import comac, logls, mac, quadratic, relative_error
from sdctrl.updating._update_fit import UpdateResult, update
from sdctrl.updating._parametric import ReducedModel, perturbation, reduced_model
from sdctrl.updating._problem import apply_parameters
from sdctrl.updating._identifiability import CostMap, Identifiability, identifiability
from sdctrl.updating._reduced_accuracy import ReanalysisErrors, reanalysis_errors

__all__ = ["CostMap", "Identifiability", "ReanalysisErrors", "ReducedBasis",
           "ReducedModel", "UpdateResult", "apply_parameters", "comac", "frequency_error",
           "identifiability", "logls", "mac", "mixed_orthogonality", "modal_energies",
           "observability_error", "perturbation", "quadratic", "reanalysis_errors",
           "reduced_basis", "reduced_model", "relative_error", "update"]
