"""Mode shapes: complex residues in the plane (Figure 3.5) and shapes on the FE geometry."""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

import numpy as np

from sdctrl._lib.validate import as_array, check_finite_result, check_scalar
from sdctrl.plot._figure import figure, finish, grid_shape

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["complex_residues", "mode_shapes", "phase_dispersion"]

#: sensor labels are written next to the residues up to this many sensors
LABEL_MAX = 40
_SET_MARKERS = ("+", "o", "x", "s", "^", "D")


def _principal_angle(r: np.ndarray) -> float:
    """Angle of the line through 0 that best fits the points ``r`` (least squares, rad)."""
    return 0.5 * float(np.angle(np.sum(r**2))) if np.any(r) else 0.0


def phase_dispersion(r, rel: float = 0.1) -> float:
    """Spread (deg) of complex residues about their best real line through the origin.

    A proportionally damped (real) mode has all residues of one actuator on one line
    through the origin (in or out of phase); the phase dispersion measures how far an
    identified complex mode is from that (thesis 3.3.4: above 30 deg for the strongly
    damping-coupled mode 6 of the interferometer testbed, 4 deg for a separated mode).

    Parameters
    ----------
    r : array_like, shape (ns,)
        Complex residues (or modal observabilities) of one mode at all sensors.
    rel : float
        Residues smaller than ``rel * max |r|`` are ignored (their phase is noise).

    Returns
    -------
    float
        ``max - min`` of the angles (deg, in (-90, 90]) between each retained residue and
        the principal line ``theta = arg(sum r^2) / 2``; 0 for collinear residues.
    """
    z = as_array(r, "r", ndim=1, dtype=complex)
    rel = check_scalar(rel, "rel")
    if not 0 <= rel < 1:
        raise ValueError(f"rel must lie in [0, 1), got {rel}")
    if not np.any(z):
        return 0.0
    z = z[np.abs(z) >= rel * np.abs(z).max()]
    rot = z * np.exp(-1j * _principal_angle(z))
    dev = 0.5 * np.angle(rot**2)                      # folded into (-90, 90] deg
    return float(np.degrees(dev.max() - dev.min()))


def _index(sel, labels, name: str) -> int:
    if isinstance(sel, str):
        if labels is None or sel not in labels:
            raise ValueError(f"{name}: unknown label {sel!r}")
        return list(labels).index(sel)
    if isinstance(sel, bool) or not isinstance(sel, int | np.integer):
        raise TypeError(f"{name} must be a label or an integer index, got {sel!r}")
    return int(sel)


def _residue_set(x, mode: int, actuator, scaled: bool, name: str):
    """``(r (ns,), sensor labels or None, frequency or None)`` of one input set."""
    if getattr(x, "residues", None) is not None and getattr(x, "poles", None) is not None:
        n = len(x.poles)
        if not -n <= mode < n:
            raise ValueError(f"mode {mode} out of range for {name} with {n} modes")
        R = np.asarray(x.residues)[mode]                          # (ns, na)
        if actuator is None:
            col = list(getattr(x, "collocated", ()) or ())
            a = col[0][1] if col else int(np.argmax(np.linalg.norm(R, axis=0)))
        else:
            a = _index(actuator, getattr(x, "actuators", None), "actuator")
        if not -R.shape[1] <= a < R.shape[1]:
            raise ValueError(f"actuator index {a} out of range for {R.shape[1]} actuators")
        r = x.scaled()[0][:, mode] if scaled else R[:, a]
        return np.asarray(r, complex), getattr(x, "sensors", None), float(x.frequency[mode])
    arr = as_array(x, name, ndim=(1, 2), dtype=complex)
    if arr.ndim == 2:
        if not -arr.shape[1] <= mode < arr.shape[1]:
            raise ValueError(f"mode {mode} out of range for {name} with {arr.shape[1]} columns")
        arr = arr[:, mode]
    return arr, None, None


def complex_residues(data, mode: int = 0, path: str | os.PathLike | None = None,
                     title: str | None = None, *, actuator=None, scaled: bool = False, labels=None,
                     sensors=None, rel: float = 0.1) -> Figure:
    """Residues of one mode at all sensors in the complex plane (thesis Figure 3.5).

    Shows how far an identified complex mode is from a real (proportionally damped)
    one: real modes put every residue on one line through the origin.  The best such line
    of the first set is drawn dashed and the title gives the :func:`phase_dispersion`.
    Several sets (e.g. identified complex mode, its proper normal-mode approximation and
    a proportional model) are overlaid with dotted links between corresponding sensors.

    Parameters
    ----------
    data : ComplexModeModel, array_like, or a list of them
        A model with ``poles`` and ``residues`` (n, ns, na), or complex residues /
        observabilities ``(ns,)`` or ``(ns, n)`` (``mode`` picks the column).
    mode : int
        Mode index (0-based) in each set.
    path : str or os.PathLike, optional
        Save the figure there and close it.
    title : str, optional
        Figure title (default: mode, frequency and phase dispersion).
    actuator : str or int, optional
        Residue column of a model (default: the actuator of its first collocated pair, else
        the actuator that excites the mode most).
    scaled : bool
        For models, plot the scaled observabilities ``c psi_j`` (3.24) instead of a
        residue column.
    labels : sequence of str, optional
        Legend entry per set.
    sensors : sequence of str, optional
        Sensor labels written next to the points of the first set that reach ``rel`` of
        its largest residue (default the model's labels, if any), largest first; a label
        that would overlap one already written is left out.
    rel : float
        Threshold of :func:`phase_dispersion`.

    Returns
    -------
    matplotlib.figure.Figure
        One axes (equal scales); the markers of set ``k`` are the line with ``gid``
        ``"set{k}"`` (x: real parts, y: imaginary parts).
    """
    rel = check_scalar(rel, "rel")
    if not 0 <= rel < 1:
        raise ValueError(f"rel must lie in [0, 1), got {rel}")
    sets = data if isinstance(data, list | tuple) else [data]
    if not sets:
        raise ValueError("data must hold at least one set of residues")
    if actuator is not None and not any(getattr(x, "residues", None) is not None
                                        for x in sets):
        raise ValueError("actuator selects a column of a model's residues, but data holds no "
                         "model (arrays are residues at one actuator already)")
    if isinstance(mode, bool) or not isinstance(mode, int | np.integer):
        raise TypeError(f"mode must be an integer index, got {mode!r}")
    got = [_residue_set(x, int(mode), actuator, scaled, f"data[{k}]")
           for k, x in enumerate(sets)]
    ns = got[0][0].size
    if any(g[0].size != ns for g in got):
        raise ValueError("data sets must have the same number of sensors")
    names = [str(v) for v in labels] if labels is not None else (
        [type(s).__name__ if g[2] is not None else f"set {k}"
         for k, (s, g) in enumerate(zip(sets, got))] if len(sets) > 1 else [None])
    if len(names) != len(sets):
        raise ValueError(f"labels must have one entry per set ({len(sets)}), got {len(names)}")
    sens = sensors if sensors is not None else got[0][1]
    fig = figure(6.0, 6.0)
    ax = fig.add_subplot(1, 1, 1)
    r0 = got[0][0]
    for k, (r, _, _) in enumerate(got):
        ax.plot(r.real, r.imag, _SET_MARKERS[k % len(_SET_MARKERS)], ls="none",
                mfc="none", ms=7, label=names[k], gid=f"set{k}")
        if k:
            for a, b in zip(r0, r):
                ax.plot([a.real, b.real], [a.imag, b.imag], ":", color="0.5", lw=0.8)
    big = max(float(np.abs(g[0]).max()) for g in got) or 1.0
    th = _principal_angle(r0)
    ax.plot([-big * np.cos(th), big * np.cos(th)], [-big * np.sin(th), big * np.sin(th)],
            "--", color="0.5", lw=0.8)
    ax.axhline(0, color="k", lw=0.5)
    ax.axvline(0, color="k", lw=0.5)
    ax.set_aspect("equal", adjustable="datalim")
    ax.ticklabel_format(style="sci", scilimits=(-3, 4))
    ax.locator_params(nbins=6)
    ax.set_xlabel("real part")
    ax.set_ylabel("imaginary part")
    ax.grid(True, alpha=0.3)
    if names[0] is not None:
        ax.legend(loc="best", fontsize=8)
    f0 = got[0][2]
    where = f" ({f0:.4g} Hz)" if f0 is not None else ""
    default = (f"mode {int(mode) + 1}{where}: phase dispersion "
               f"{phase_dispersion(r0, rel):.1f} deg")
    fig.suptitle(title or default)                  # the final layout, before the labels
    if sens is not None and ns <= LABEL_MAX:
        shown = np.flatnonzero(np.abs(r0) >= rel * np.abs(r0).max())   # no pile at 0
        _place_labels(fig, ax, [str(sens[i]) for i in shown], r0[shown])
    return finish(fig, path, title or default)


#: label positions tried around a point (offset in points, horizontal alignment)
_LABEL_SPOTS = ((3, 3, "left"), (3, -9, "left"), (-3, 3, "right"), (-3, -9, "right"),
                (3, 12, "left"), (-3, 12, "right"), (3, -18, "left"), (-3, -18, "right"))


def _place_labels(fig, ax, labels, points) -> int:
    """Write each label next to its point where it overlaps no other label and no other
    labelled point's marker (largest points first; a label with no free spot is left out).
    Returns the number written."""
    from matplotlib.transforms import Bbox

    fig.canvas.draw()                               # final limits (equal aspect) and layout
    renderer = fig.canvas.get_renderer()
    xy = ax.transData.transform(np.column_stack([points.real, points.imag]))
    half = 3.5 * fig.dpi / 72                       # half the marker size (ms=7 points)
    markers = [Bbox([[x - half, y - half], [x + half, y + half]]) for x, y in xy]
    taken = []
    for k in np.argsort(-np.abs(points), kind="stable"):
        z = points[k]
        for dx, dy, ha in _LABEL_SPOTS:
            t = ax.annotate(labels[k], (z.real, z.imag), fontsize=6, xytext=(dx, dy),
                            textcoords="offset points", ha=ha, gid="sensor label")
            t.set_in_layout(False)                  # labels never move the axes
            box = t.get_window_extent(renderer)
            if not any(box.overlaps(b) for b in taken) and not any(
                    box.overlaps(m) for i, m in enumerate(markers) if i != k):
                taken.append(box)
                break
            t.remove()
    return len(taken)


_AXES = {"x": 0, "y": 1, "z": 2}


def _node_motion(fe, v: np.ndarray, dofs) -> tuple[list[str], np.ndarray, np.ndarray]:
    """Node names, coordinates (nn, 3) and translations (nn, 3) of a real DOF vector."""
    names = list(fe.nodes)
    pos = {n: i for i, n in enumerate(names)}
    xyz = np.array([fe.nodes[n] for n in names], float)
    d = np.zeros_like(xyz)
    for lab, val in zip(dofs, v):
        node, _, comp = str(lab).rpartition(".")
        if node in pos and comp in _AXES:
            d[pos[node], _AXES[comp]] = val
    return names, xyz, d


def _shape_source(fe, shapes, modes, dofs):
    """``(phi (N, n), dofs, frequencies or None)`` for the requested modes."""
    need = max(modes) + 1
    if shapes is None:
        f, phi = fe.modes(need)
        return np.asarray(phi), fe.dofs, np.asarray(f)
    if getattr(shapes, "shapes", None) is not None or hasattr(shapes, "Omega"):
        if getattr(shapes, "shapes", None) is None:
            raise ValueError("shapes: the model carries no shapes on physical DOFs "
                             "(.shapes is None); pass an FE-derived or hybrid model")
        d = getattr(shapes, "dofs", None) or dofs or fe.dofs
        return np.asarray(shapes.shapes), d, np.asarray(shapes.frequency)
    phi = as_array(shapes, "shapes", ndim=(1, 2), dtype=complex)
    if phi.ndim == 1:
        phi = phi[:, None]
    return phi, (dofs if dofs is not None else fe.dofs), None


def mode_shapes(fe, shapes=None, modes=0, path: str | os.PathLike | None = None,
                title: str | None = None, *, dofs=None, scale: float | None = None,
                max_cols: int = 3, names=None) -> Figure:
    """Mode shapes on the FE geometry: undeformed wireframe and deformed shape, 3-D axes.

    Parameters
    ----------
    fe : FEModel
        Model with node coordinates (``fe.nodes``) and element node pairs
        (``fe.elements``, drawn as lines; without them only the nodes are drawn).
    shapes : array_like (N,) or (N, n), or model with ``.shapes``, optional
        Shapes on the DOFs ``dofs`` (default ``fe.dofs``); a normal-mode model with
        ``.shapes`` (FE-derived, hybrid) brings its own DOF labels and frequencies.
        Default: the FE model's own normal modes (:meth:`FEModel.modes`).  Complex shapes
        are rotated to their best real line (:func:`phase_dispersion`) and the real part
        drawn.  Translations ``<node>.x|y|z`` move the nodes; rotations are not drawn.
    modes : int or sequence of int
        Mode indices (0-based columns of ``shapes``), one panel each.
    path : str or os.PathLike, optional
        Save the figure there and close it.
    title : str, optional
        Figure title.
    dofs : sequence of str, optional
        DOF labels of the rows of an array ``shapes`` (default ``fe.dofs``).
    scale : float, optional
        Displacement magnification (default: the largest translation drawn as 10% of the
        structure's size, per mode).
    max_cols : int
        Panels per row.
    names : sequence of str, optional
        Panel titles, one per mode (default ``"mode k: f Hz"`` with ``k`` the 1-based
        column of ``shapes``): give the numbering of the report's tables when the shapes'
        columns are numbered otherwise (e.g. FE modes below the test band).

    Returns
    -------
    matplotlib.figure.Figure
        One 3-D axes per mode; each holds two line collections, the undeformed wireframe
        (``gid="undeformed"``) then the deformed one (``gid="deformed"``).
    """
    if getattr(fe, "nodes", None) is None:
        raise ValueError("fe must have node coordinates (FEModel(..., nodes=...)) to draw "
                         "shapes on its geometry")
    if not isinstance(modes, int | np.integer | list | tuple | np.ndarray):
        raise TypeError(f"modes must be an index or a sequence of indices, got "
                        f"{type(modes).__name__}")
    idx = [modes] if isinstance(modes, int | np.integer) else list(np.ravel(modes))
    if not idx or any(isinstance(m, bool) or not isinstance(m, int | np.integer) or m < 0
                      for m in idx):
        raise ValueError(f"modes must be a non-negative index or a non-empty sequence of "
                         f"them, got {modes!r}")
    phi, labels, freq = _shape_source(fe, shapes, idx, dofs)
    if phi.shape[0] != len(labels):
        raise ValueError(f"shapes must have one row per DOF label ({len(labels)}), got "
                         f"{phi.shape[0]} rows")
    if max(idx) >= phi.shape[1]:
        raise ValueError(f"modes: index {max(idx)} out of range for {phi.shape[1]} shapes")
    scale = check_scalar(scale, "scale", positive=True, optional=True)
    if names is not None and (isinstance(names, str) or len(names) != len(idx)):
        raise ValueError(f"names must hold one title per mode ({len(idx)}), got {names!r}")
    rows, cols = grid_shape(len(idx), max_cols)
    fig = figure(4.8 * cols, 3.8 * rows + 0.4)
    for k, m in enumerate(idx):
        ax = fig.add_subplot(rows, cols, k + 1, projection="3d")
        v = phi[:, m]
        v = np.real(v * np.exp(-1j * _principal_angle(v)))
        _draw_shape(ax, fe, v, labels, scale)
        name = f"mode {m + 1}" + (f": {freq[m]:.4g} Hz" if freq is not None else "")
        ax.set_title(name if names is None else str(names[k]), fontsize=10)
    return finish(fig, path, title)


def _locator():
    from matplotlib.ticker import MaxNLocator

    return MaxNLocator(nbins=4)


def _draw_shape(ax, fe, v, labels, scale):
    from mpl_toolkits.mplot3d.art3d import Line3DCollection

    names, xyz, d = _node_motion(fe, v, labels)
    size = float(np.ptp(xyz, axis=0).max()) or 1.0
    dmax = float(np.abs(d).max())
    if scale is None:                 # largest translation drawn as 10% of the size
        moved = xyz + (0.1 * size) * (d / dmax) if dmax > 0 else xyz
    else:
        with np.errstate(over="ignore", invalid="ignore"):
            moved = xyz + scale * d
        check_finite_result(moved, "the deformed shape", "scale")
    pos = {n: i for i, n in enumerate(names)}
    pairs = [(pos[a], pos[b]) for a, b in (fe.elements or ())]
    if pairs:
        e = np.array(pairs)
        ax.add_collection3d(Line3DCollection(np.stack([xyz[e[:, 0]], xyz[e[:, 1]]], axis=1),
                                             colors="0.65", linewidths=0.7, linestyles=":",
                                             gid="undeformed"))
        ax.add_collection3d(Line3DCollection(np.stack([moved[e[:, 0]], moved[e[:, 1]]], axis=1),
                                             colors="tab:blue", linewidths=1.2, gid="deformed"))
    ax.scatter(*moved.T, s=4, color="tab:blue", depthshade=False)
    lo = np.minimum(xyz.min(axis=0), moved.min(axis=0))
    hi = np.maximum(xyz.max(axis=0), moved.max(axis=0))
    span = np.maximum(hi - lo, 0.05 * size)
    mid = (hi + lo) / 2
    ax.set_xlim(mid[0] - span[0] / 2, mid[0] + span[0] / 2)
    ax.set_ylim(mid[1] - span[1] / 2, mid[1] + span[1] / 2)
    ax.set_zlim(mid[2] - span[2] / 2, mid[2] + span[2] / 2)
    # true proportions, but no axis thinner than a quarter of the longest (readable boxes)
    ax.set_box_aspect(np.maximum(span, 0.25 * span.max()))
    for axis, name in zip((ax.xaxis, ax.yaxis, ax.zaxis), "xyz"):
        axis.set_major_locator(_locator())
        axis.set_label_text(f"{name} (m)", fontsize=8)
    ax.tick_params(labelsize=6)
