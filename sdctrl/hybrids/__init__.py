"""Chapter V.1 of the thesis: hybrid experimental/analytical models (eq. 5.1-5.4).

Workflow: measured normal modes (``sd.normal_modes``) and an FE model give, through the
expansion of the measured shapes onto every FE DOF (4.7, ``_expansion``), a hybrid model
(:func:`hybrid`, ``_build``) that keeps the measured frequencies and damping; its residual
terms and static correction modes come from ``_hybrid_basis`` (the low modes' residual
mass, 2.23, from ``_residual_mass``); what the construction found is the model's
``construction`` record (``_hybrid_records``).  The :class:`HybridModel`
predicts the effect of modifications on FE DOFs (``with_feedback``: D-struts 5.3-5.4,
``with_io``: untested shakers and sensors, ``with_modification``: ``dM, dC, dK`` by
reanalysis 5.2), ``_predictions``; :func:`pairing_report` tabulates its FE/test mode pairing.

The package is named ``hybrids`` so that ``sd.hybrid`` stays a plain function.
"""

from sdctrl.hybrids._build import hybrid
from sdctrl.hybrids._hybrid_records import pairing_report
from sdctrl.hybrids._predictions import HybridModel

__all__ = ["HybridModel", "hybrid", "pairing_report"]
