"""Matplotlib figures of sdctrl: responses, identification, shapes, maps.

Every function returns a :class:`matplotlib.figure.Figure`, never calls ``show()``, and
saves the figure when given ``path=`` (the figure is then closed).  matplotlib is imported
only when a figure is drawn; a headless Linux session uses the ``Agg`` backend.

- :func:`bode` -- overlays of FRFs, models and StateSpace objects, channels by label;
- :func:`envelope` -- min/max band of ``|H|`` of an uncertain model or of samples;
- :func:`cmif` -- indicator function (singular values of ``H`` per frequency);
- :func:`stabilisation` -- poles per model order / iteration over the CMIF, the identified
  model's modes with their frequency interval and damping (3.4);
- :func:`mac` -- MAC matrix heat map (4.9);
- :func:`complex_residues` -- residues of a mode in the complex plane (Figure 3.5);
- :func:`mode_shapes` -- mode shapes on the FE geometry (wireframe, 3-D);
- :func:`cost_map` -- cost over two parameters with its optimum (Figure 4.6);
- :func:`mode_table` -- identified frequencies and damping with their intervals (3.4);
- :func:`correlation` -- predicted correlation of FE parameters' estimates (Table 4.1);
- :func:`diagnosis` -- a diagnosis (:func:`sdctrl.diagnose`): FRFs before/after at the worst
  channel, residual per line and residual maps.
"""

from sdctrl.plot._indicators import cmif, stabilisation, stabilisation_flags
from sdctrl.plot._maps import cost_map, mac
from sdctrl.plot._diagnosis_plot import diagnosis
from sdctrl.plot._responses import bode, envelope, phase_display
from sdctrl.plot._shape_plots import complex_residues, mode_shapes, phase_dispersion
from sdctrl.plot._statistics_plot import correlation, mode_table

__all__ = ["bode", "cmif", "complex_residues", "correlation", "cost_map", "diagnosis",
           "envelope", "mac", "mode_shapes", "mode_table", "phase_dispersion", "phase_display",
           "stabilisation", "stabilisation_flags"]
