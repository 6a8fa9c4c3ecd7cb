"""Two-dimensional maps: the MAC matrix (4.9) and cost maps over two parameters (Figure 4.6)."""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

import numpy as np

from sdctrl._lib.validate import as_array, check_int
from sdctrl.plot._figure import figure, finish

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["cost_map", "mac"]

#: MAC values are written in the cells up to this many rows and columns
ANNOTATE_MAX = 25


def _shape_set(x, name: str):
    """``(shapes (ns, n), default tick labels)`` from an array or a model."""
    freq = getattr(x, "frequency", None)
    if getattr(x, "cphi", None) is not None:
        arr = np.asarray(x.cphi)
    elif getattr(x, "residues", None) is not None:
        R = np.asarray(x.residues)                                   # (n, ns, na)
        arr = np.linalg.svd(R)[0][:, :, 0].T if R.shape[0] else np.zeros((R.shape[1], 0))
    else:
        arr = as_array(x, name, ndim=(1, 2), dtype=complex)
        freq = None
    if arr.ndim == 1:
        arr = arr[:, None]
    if arr.shape[1] == 0:
        raise ValueError(f"{name} holds no shape")
    if freq is not None and len(freq) == arr.shape[1]:
        ticks = [f"{j + 1}: {fj:.4g} Hz" for j, fj in enumerate(np.asarray(freq))]
    else:
        ticks = [str(j + 1) for j in range(arr.shape[1])]
    return arr, ticks


def _ticks(given, default, name):
    if given is None:
        return default
    out = [str(t) for t in given]
    if len(out) != len(default):
        raise ValueError(f"{name} must have {len(default)} entries (one per shape), "
                         f"got {len(out)}")
    return out


def mac(a, b=None, path: str | os.PathLike | None = None, title: str | None = None, *,
        labels_a=None, labels_b=None, names=None, annotate: bool | None = None) -> Figure:
    """MAC matrix (4.9) as a heat map with its values written in the cells.

    Parameters
    ----------
    a : array_like, shape (ns, na), or model
        First shape set, one shape per column (real or complex), or a model: its ``cphi``
        (normal-mode models) or the first left singular vector of each residue
        (complex-mode models); tick labels then give mode frequencies.
    b : array_like, shape (ns, nb), or model, optional
        Second shape set on the same sensors; default ``a`` (auto-MAC).
    path : str or os.PathLike, optional
        Save the figure there and close it.
    title : str, optional
        Figure title (default "MAC" or "auto-MAC").
    labels_a, labels_b : sequence of str, optional
        Tick labels of the rows (``a``) and columns (``b``).
    names : (str, str), optional
        Axis labels naming the two sets (e.g. ``("test", "FE")``); default ``("a", "b")``,
        ``("mode", "mode")`` for an auto-MAC.
    annotate : bool, optional
        Write the values in the cells (default when at most 25 x 25).

    Returns
    -------
    matplotlib.figure.Figure
        ``fig.axes[0].images[0].get_array()`` is the MAC matrix (na, nb); a colour bar
        follows.
    """
    from sdctrl.updating._costs import mac as mac_matrix

    A, ta = _shape_set(a, "a")
    B, tb = (A, ta) if b is None else _shape_set(b, "b")
    if A.shape[0] != B.shape[0]:
        raise ValueError(f"a and b must have the same number of rows (sensors), got "
                         f"{A.shape[0]} and {B.shape[0]}")
    ta = _ticks(labels_a, ta, "labels_a")
    tb = _ticks(labels_b, tb, "labels_b")
    M = mac_matrix(A, B)
    na, nb = M.shape
    fig = figure(min(2.2 + 0.45 * nb, 14.0), min(1.8 + 0.4 * na, 13.0))
    ax = fig.add_subplot(1, 1, 1)
    im = ax.imshow(M, vmin=0.0, vmax=1.0, cmap="viridis", aspect="auto",
                   interpolation="nearest")
    if annotate if annotate is not None else max(na, nb) <= ANNOTATE_MAX:
        fs = 8 if max(na, nb) <= 12 else 6
        for i, j in np.ndindex(na, nb):
            ax.text(j, i, f"{M[i, j]:.2f}", ha="center", va="center", fontsize=fs,
                    color="black" if M[i, j] > 0.6 else "white")
    ax.set_xticks(range(nb), tb, rotation=45 if nb > 6 else 0, ha="right" if nb > 6 else "center",
                  fontsize=8)
    ax.set_yticks(range(na), ta, fontsize=8)
    if names is None:
        names = ("mode", "mode") if b is None else ("a", "b")
    ax.set_xlabel(str(names[1]))
    ax.set_ylabel(str(names[0]))
    fig.colorbar(im, ax=ax, label="MAC", fraction=0.05)
    return finish(fig, path, title or ("auto-MAC" if b is None else "MAC"))


def cost_map(x, y=None, cost=None, path: str | os.PathLike | None = None,
             title: str | None = None, *, xlabel: str | None = None, ylabel: str | None = None,
             optimum=None, markers=None, log: bool | None = None, levels: int = 20,
             cost_label: str = "cost") -> Figure:
    """Cost over a grid of two parameters, filled contours with the optimum (Figure 4.6).

    A long flat valley shows parameters the test cannot tell apart (thesis 4.4: the
    mirror and plate masses of the interferometer testbed).

    Parameters
    ----------
    x : array_like, shape (nx,), or CostMap
        Values of the first parameter (horizontal axis), or a
        :class:`~sdctrl.updating.CostMap` (from ``Identifiability.cost_map``) holding ``x``,
        ``y``, ``cost`` and the parameter names.
    y : array_like, shape (ny,)
        Values of the second parameter (vertical axis); omitted with a CostMap.
    cost : array_like, shape (nx, ny)
        ``cost[i, j]`` at ``(x[i], y[j])`` (``meshgrid(x, y, indexing="ij")`` order); NaN
        marks points that could not be evaluated; omitted with a CostMap.
    path : str or os.PathLike, optional
        Save the figure there and close it.
    title : str, optional
        Figure title.
    xlabel, ylabel : str, optional
        Parameter names (with units); default the CostMap's names, else ``"p1"``, ``"p2"``.
    optimum : (float, float), optional
        Point marked as the optimum (e.g. an update result); default the grid minimum.
    markers : dict of str to (float, float), optional
        More labelled points (e.g. ``{"truth": (0.1, 0.0)}``).
    log : bool, optional
        Contour ``log10(cost)`` (default when the cost is positive and spans more than
        two decades).
    levels : int
        Number of contour levels.
    cost_label : str
        Colour-bar label.

    Returns
    -------
    matplotlib.figure.Figure
        ``fig.axes[0]`` holds the map (contour sets, optimum and markers as lines with
        their labels in the legend), then the colour bar.
    """
    if y is None and cost is None and hasattr(x, "cost"):
        xlabel = x.xlabel if xlabel is None else xlabel
        ylabel = x.ylabel if ylabel is None else ylabel
        if cost_label == "cost":
            cost_label = "logLS cost"
        x, y, cost = x.x, x.y, x.cost
    if y is None or cost is None:
        raise TypeError("cost_map needs x, y and cost arrays, or a CostMap as its first argument")
    xlabel = "p1" if xlabel is None else xlabel
    ylabel = "p2" if ylabel is None else ylabel
    X = as_array(x, "x", ndim=1)
    Y = as_array(y, "y", ndim=1)
    C = as_array(cost, "cost", ndim=2, finite=False)
    if C.shape != (X.size, Y.size):
        raise ValueError(f"cost must have shape (len(x), len(y)) = {(X.size, Y.size)}, "
                         f"got {C.shape}")
    if X.size < 2 or Y.size < 2:
        raise ValueError("x and y must each hold at least 2 values")
    ok = np.isfinite(C)
    if not ok.any() or np.isinf(C).any():
        raise ValueError("cost must contain finite values (NaN marks missing points, no inf)")
    levels = check_int(levels, "levels", minimum=2, maximum=1000)
    pos = bool(np.all(C[ok] > 0))
    if log is None:
        log = pos and C[ok].max() > 100 * C[ok].min()
    if log and not pos:
        raise ValueError("log=True needs a positive cost")
    Z = np.log10(C) if log else C
    i, j = np.unravel_index(np.nanargmin(C), C.shape)
    opt = (X[i], Y[j]) if optimum is None else tuple(as_array(optimum, "optimum", shape=(2,)))
    fig = figure(7.0, 5.5)
    ax = fig.add_subplot(1, 1, 1)
    cs = ax.contourf(X, Y, np.ma.masked_invalid(Z).T, levels=int(levels), cmap="viridis_r")
    ax.contour(X, Y, np.ma.masked_invalid(Z).T, levels=cs.levels, colors="k", linewidths=0.3)
    fig.colorbar(cs, ax=ax, label=f"log10 {cost_label}" if log else cost_label)
    ax.plot(*opt, "*", color="red", ms=14, mec="white",
            label=f"optimum ({opt[0]:.4g}, {opt[1]:.4g})")
    for (name, pt), m in zip((markers or {}).items(), "oDs^vP"):
        ax.plot(float(pt[0]), float(pt[1]), m, ms=8, mfc="none", mec="white", mew=1.5,
                label=str(name))
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.legend(loc="best", fontsize=8, framealpha=0.85)
    return finish(fig, path, title or f"{cost_label} map")
