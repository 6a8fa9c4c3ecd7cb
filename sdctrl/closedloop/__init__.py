"""Closed loops and what they achieve: feedback keeping signal names, band-limited RMS,
D-strut placement (thesis 5.3-5.4).

- ``_loops``: :func:`feedback` (python-control's drops signal names), :func:`rms` (band-limited,
  closed form), the D-strut plant and controller;
- ``_placement``: :func:`placement_study`, a D-strut over candidate bars of a hybrid model.
"""

from sdctrl.closedloop._loops import feedback, rms
from sdctrl.closedloop._placement import PlacementStudy, placement_study

__all__ = ["PlacementStudy", "feedback", "placement_study", "rms"]
