"""Closed loops and what they achieve: feedback keeping signal names, band-limited RMS,
D-strut placement (thesis 5.3-5.4).

- ``_loops``: :func:`feedback` (python-control's drops signal names), :func:`rms` (band-limited,
  closed form), :func:`modal_damping` (frequencies and damping ratios of the poles in a band,
  e.g. of a closed loop);
- ``_placement``: :func:`placement_study`, a D-strut over candidate bars of a hybrid model.
"""

from sdctrl.closedloop._loops import feedback, modal_damping, rms
from sdctrl.closedloop._placement import PlacementStudy, placement_study

__all__ = ["PlacementStudy", "feedback", "modal_damping", "placement_study", "rms"]
