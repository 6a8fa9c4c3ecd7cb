"""Normal-mode models (thesis 2.1, eq. 2.15): :class:`NormalModeModel` and its operations.

A model holds ``Omega`` (diagonal, (rad/s)^2), the full modal damping ``Gamma`` (rad/s), the
modal observability ``cphi`` and controllability ``phib``, and optional residual terms ``E``
(flexibility) and ``F`` (mass).  Workflow: build one from matrices, from an FE model
(``FEModel.normal_mode_model``), from identified complex modes (:func:`sdctrl.normal_modes`) or
as a hybrid (:func:`sdctrl.hybrid`); change it (``modified``, ``with_feedback``: changes in
reduced coordinates re-diagonalised, 5.3-5.4); evaluate it (``frf``) or realise it as a
python-control ``StateSpace`` (``to_statespace``, correction modes 2.19-2.24).

- ``_normal_model``: the container, its FRF and state-space realisation;
- ``_normal_realisation``: its state-space form (modes, residual dynamics, correction modes);
- ``_residual_dynamics``: complex modes kept as they are (what could not be made proper);
- ``_operations``: re-diagonalisation after changes of ``Omega``, ``Gamma``, inputs, feedback.
"""

from sdctrl.modal._normal_model import NormalModeModel
from sdctrl.modal._residual_dynamics import ResidualDynamics

__all__ = ["NormalModeModel", "ResidualDynamics"]
