"""Figures of the statistics of identified models and FE updates (thesis 3.4, 4.2; issue 24).

- :func:`mode_table` -- each identified mode's frequency and damping with its interval at a
  given level (``ComplexModeModel.frequency_std``, ``.damping_std``), over the CMIF of the
  test when given, and the same figures as a table of ``value +- half-width``;
- :func:`correlation` -- the predicted correlation of the estimates of FE parameters
  (``Identifiability.estimate_correlation``), the confounded pairs framed.

The uncertainty envelope of an uncertain model from the data
(:func:`sdctrl.uncertain_from_data`) is :func:`sdctrl.plot.envelope`.
"""

from __future__ import annotations

import os

import numpy as np

from sdctrl.plot._figure import FREQ_LABEL, figure, finish

__all__ = ["correlation", "level_quantile", "mode_table"]


def level_quantile(level) -> float:
    """Half-width in standard deviations of a two-sided normal interval of probability
    ``level`` (1.96 at 0.95).

    Parameters
    ----------
    level : float
        Probability in (0, 1).

    Returns
    -------
    float
    """
    from scipy.stats import norm

    if isinstance(level, bool) or not isinstance(level, int | float) or not 0 < level < 1:
        raise ValueError(f"level must be a probability in (0, 1), got {level!r}")
    return float(norm.ppf(0.5 + level / 2))


def mode_table(cm, frf=None, level: float = 0.95, path: str | os.PathLike | None = None,
               title: str | None = None):
    """Identified frequencies and damping ratios with their intervals at ``level``.

    Top: the CMIF of ``frf`` (when given) with each mode's frequency interval shaded;
    middle: damping ratio against frequency with both intervals as error bars; bottom: the
    table ``f +- df (Hz)``, ``zeta +- dzeta (%)`` (half-widths ``z sigma``, ``z`` the normal
    quantile of ``level``; "n/a" where the data do not determine them).

    Parameters
    ----------
    cm : ComplexModeModel
        An identified model (with statistics; a model without them shows "n/a").
    frf : FRF, optional
        The test, drawn as its CMIF (singular values per line).
    level : float
        Probability of the intervals, in (0, 1).
    path : str or os.PathLike, optional
        Save the figure there and close it.
    title : str, optional
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
        ``fig.axes[1].containers[0]`` holds the error bars; the table's cell texts are in
        ``fig.axes[2].tables[0]``.
    """
    if not all(hasattr(cm, k) for k in ("frequency_std", "damping_std", "poles")):
        raise TypeError(f"cm must be a ComplexModeModel, got {type(cm).__name__}")
    z = level_quantile(level)
    f, zeta = np.asarray(cm.frequency), np.asarray(cm.damping)
    hf, hz = z * np.asarray(cm.frequency_std), z * np.asarray(cm.damping_std)
    n = f.size
    fig = figure(8.0, 5.5 + 0.22 * n)
    gs = fig.add_gridspec(3, 1, height_ratios=[1.2, 1.0, 0.25 + 0.08 * n])
    ax_c, ax_z, ax_t = (fig.add_subplot(gs[i]) for i in range(3))
    if frf is not None:
        sv = np.linalg.svd(np.asarray(frf.H), compute_uv=False)
        ax_c.semilogy(frf.freq, sv, lw=0.8)
        ax_c.set_ylabel("CMIF")
    for fi, h in zip(f, hf):
        ax_c.axvline(fi, color="k", lw=0.5, alpha=0.5)
        if np.isfinite(h):
            ax_c.axvspan(fi - h, fi + h, color="C3", alpha=0.3)
    ax_c.set_title(f"modes with their {level:.0%} intervals")
    ax_z.errorbar(f, 100 * zeta, xerr=np.nan_to_num(hf), yerr=100 * np.nan_to_num(hz),
                  fmt="o", ms=3, capsize=3)
    ax_z.set_xlabel(FREQ_LABEL)
    ax_z.set_ylabel("damping (%)")
    if frf is not None:
        ax_z.sharex(ax_c)
    rows = [[f"{i + 1}", _pm(f[i], hf[i], 4), _pm(100 * zeta[i], 100 * hz[i], 3)]
            for i in range(n)]
    ax_t.axis("off")
    if rows:
        ax_t.table(cellText=rows, colLabels=["mode", f"frequency (Hz) +- {level:.0%}",
                                             f"damping (%) +- {level:.0%}"],
                   loc="center", cellLoc="center")
    return finish(fig, path, title)


def _pm(x, h, digits):
    if not np.isfinite(h):
        return f"{x:.{digits}g} +- n/a"
    return f"{x:.{digits + 2}g} +- {h:.2g}"


def correlation(ident, path: str | os.PathLike | None = None, title: str | None = None):
    """Predicted correlation of the FE parameters' estimates, confounded pairs framed.

    Parameters
    ----------
    ident : Identifiability
        From :func:`sdctrl.identifiability`.
    path : str or os.PathLike, optional
        Save the figure there and close it.
    title : str, optional
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
        ``fig.axes[0].images[0].get_array()`` is the correlation matrix; one rectangle
        patch per confounded pair (both cells).
    """
    C = getattr(ident, "estimate_correlation", None)
    if C is None or not hasattr(ident, "names"):
        raise TypeError(f"ident must be an Identifiability, got {type(ident).__name__}")
    names = list(ident.names)
    n = len(names)
    fig = figure(2.5 + 0.55 * n, 2.0 + 0.5 * n)
    ax = fig.add_subplot(1, 1, 1)
    im = ax.imshow(np.asarray(C), vmin=-1.0, vmax=1.0, cmap="coolwarm",
                   interpolation="nearest")
    for i, j in np.ndindex(n, n):
        ax.text(j, i, f"{C[i, j]:+.2f}", ha="center", va="center", fontsize=8)
    idx = {nm: i for i, nm in enumerate(names)}
    from matplotlib.patches import Rectangle

    for a, b in ident.confounded:
        for i, j in ((idx[a], idx[b]), (idx[b], idx[a])):
            ax.add_patch(Rectangle((j - 0.5, i - 0.5), 1, 1, fill=False, lw=2.5, ec="k"))
    ax.set_xticks(range(n), names, rotation=45, ha="right", fontsize=8)
    ax.set_yticks(range(n), names, fontsize=8)
    fig.colorbar(im, ax=ax, label="correlation of the estimates", fraction=0.05)
    return finish(fig, path, title or "predicted correlation of the estimates")
