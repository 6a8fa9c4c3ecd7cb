"""Matplotlib plumbing shared by the figures of :mod:`sdctrl.plot` (internal).

matplotlib is imported only when a figure is drawn; on a Linux machine without a
display the non-interactive ``Agg`` backend is selected so that scripts, CI and the
``sdctrl`` command never need a screen.  No function here calls ``show()``.
"""

from __future__ import annotations

import os
import sys

import numpy as np

#: SI unit of ``H`` (response per unit force) for each measured quantity
UNITS = {"displacement": "m/N", "velocity": "m/s/N", "acceleration": "m/s^2/N"}
FREQ_LABEL = "frequency (Hz)"
PHASE_LABEL = "phase (deg)"
#: figure size caps (inches): large channel counts shrink panels instead of growing the page
MAX_WIDTH, MAX_HEIGHT = 15.0, 18.0
#: line styles cycled over overlaid systems (colours follow matplotlib's cycle)
STYLES = ("-", "--", ":", "-.")


def pyplot():
    """``matplotlib.pyplot``, with the ``Agg`` backend when no display is available.

    A backend chosen by the user (``MPLBACKEND``, an earlier pyplot import, a notebook
    kernel) is left alone; only a headless Linux session is switched to ``Agg``.
    """
    import matplotlib

    if (sys.platform.startswith("linux") and "matplotlib.pyplot" not in sys.modules
            and not os.environ.get("MPLBACKEND") and not os.environ.get("DISPLAY")
            and not os.environ.get("WAYLAND_DISPLAY") and "ipykernel" not in sys.modules):
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def db_label(quantity: str) -> str:
    """Magnitude axis label, e.g. ``"|H| (dB re 1 m/s^2/N)"``."""
    return f"|H| (dB re 1 {UNITS[quantity]})"


def db(h) -> np.ndarray:
    """``20 log10 |h|`` with NaN (not ``-inf``) where ``h`` is exactly zero."""
    a = np.abs(np.asarray(h))
    with np.errstate(divide="ignore"):
        return np.where(a > 0, 20 * np.log10(np.where(a > 0, a, 1.0)), np.nan)


def grid_shape(n: int, max_cols: int = 3) -> tuple[int, int]:
    """``(rows, cols)`` of a grid holding ``n`` panels, at most ``max_cols`` wide."""
    cols = max(1, min(int(n), int(max_cols)))
    return -(-int(n) // cols), cols


def figure(width: float, height: float):
    """A new pyplot figure, its size capped at ``MAX_WIDTH x MAX_HEIGHT`` inches."""
    plt = pyplot()
    return plt.figure(figsize=(min(width, MAX_WIDTH), min(height, MAX_HEIGHT)),
                      layout="constrained")


def channel_grid(n: int, phase: bool = True, max_cols: int = 3):
    """Figure with one magnitude (and phase) panel pair per channel, wrapping rows.

    Returns ``fig, pairs`` where ``pairs[k] = (ax_mag, ax_phase or None)``.  Panels of a
    column share their frequency axis; the phase panel sits under its magnitude panel.
    """
    rows, cols = grid_shape(n, max_cols)
    fig = figure(4.3 * cols + 0.6, (3.6 if phase else 2.5) * rows + 0.7)
    outer = fig.add_gridspec(rows, cols)
    pairs = []
    for k in range(n):
        r, c = divmod(k, cols)
        if not phase:
            pairs.append((fig.add_subplot(outer[r, c]), None))
            continue
        inner = outer[r, c].subgridspec(2, 1, height_ratios=[1.6, 1.0], hspace=0.0)
        ax_m = fig.add_subplot(inner[0])
        ax_p = fig.add_subplot(inner[1], sharex=ax_m)
        ax_m.tick_params(labelbottom=False)
        pairs.append((ax_m, ax_p))
    return fig, pairs


def log_x_if_wide(ax, freq) -> None:
    """Logarithmic frequency axis when the band spans more than two decades."""
    f = np.asarray(freq)
    if f.size > 1 and f[0] > 0 and f[-1] / f[0] > 100:
        ax.set_xscale("log")


def finish(fig, path=None, title: str | None = None, dpi: int = 110):
    """Title and optional save (then the figure is closed); returns ``fig``.

    Figures use matplotlib's constrained layout, so nothing is laid out here.
    """
    if title:
        fig.suptitle(title)
    if path is not None:
        fig.savefig(os.fspath(path), dpi=dpi)
        pyplot().close(fig)
    return fig
