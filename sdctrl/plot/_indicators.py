"""Identification figures: indicator function (CMIF) and stabilisation diagram (chapter III),
the identified model's modes drawn on the diagram with their intervals (3.4, issue 24)."""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

import numpy as np

from sdctrl._lib.validate import as_array, check_band, check_int, check_scalar
from sdctrl.plot import _channels as ch
from sdctrl.plot._figure import FREQ_LABEL, db, db_label, figure, finish, log_x_if_wide
from sdctrl.plot._statistics_plot import level_quantile

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["cmif", "stabilisation", "stabilisation_flags"]

#: marker, colour and legend of each stability class (index = flag)
_CLASSES = (
    ("o", "0.55", "new pole"),
    ("x", "tab:blue", "stable in frequency"),
    ("+", "tab:orange", "stable in frequency and damping"),
    ("s", "tab:green", "stable in frequency, damping and shape"),
)


def _singular_values(H: np.ndarray) -> np.ndarray:
    """Singular values of ``H[f]`` at every line, descending, shape (nf, min(ns, na))."""
    return np.linalg.svd(H, compute_uv=False)


def _pole_array(p, name: str) -> np.ndarray:
    p = getattr(p, "poles", p)
    try:
        arr = as_array(p, name, ndim=(0, 1), dtype=complex, finite=False).ravel()
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} must hold complex poles (rad/s) or models with .poles "
                        f"({exc})") from None
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must contain finite poles")
    return arr


def _mark_poles(ax, poles, lo, hi):
    f = np.abs(poles[poles.imag > 0]) / (2 * np.pi)
    for fj in f[(f >= lo) & (f <= hi)]:
        ax.axvline(fj, color="0.4", lw=0.7, ls=":", zorder=0)


def cmif(data, freq=None, path: str | os.PathLike | None = None, title: str | None = None, *,
         quantity: str | None = None, n_sv: int | None = None, poles=None) -> Figure:
    """Complex mode indicator function: the singular values of ``H(f)`` per frequency (dB).

    Peaks of the first singular value locate the modes; a second singular value peaking at
    the same frequency reveals a double (or closely spaced) mode (thesis 3.2.3).

    Parameters
    ----------
    data : FRF, model or control.StateSpace
        Response to analyse (models are evaluated on ``freq``).
    freq : array_like, optional
        Frequencies (Hz) for models and StateSpace objects.
    path : str or os.PathLike, optional
        Save the figure there and close it.
    title : str, optional
        Figure title.
    quantity : {"displacement", "velocity", "acceleration"}, optional
        Quantity plotted (default that of the FRF, else displacement).
    n_sv : int, optional
        Number of singular values drawn (default all, ``min(ns, na)``).
    poles : array_like or model with ``.poles``, optional
        Complex poles (rad/s) marked by dotted vertical lines at ``|p| / 2 pi``.

    Returns
    -------
    matplotlib.figure.Figure
        One axes; line ``k`` carries ``20 log10 sigma_{k+1}``.
    """
    frf = ch.to_frfs(ch.as_list(data, "data"), freq, quantity, "data")[0][0]
    sv = _singular_values(frf.H)
    r = sv.shape[1] if n_sv is None else check_int(n_sv, "n_sv")
    if not 1 <= r <= sv.shape[1]:
        raise ValueError(f"n_sv must lie in [1, {sv.shape[1]}], got {n_sv!r}")
    fig = figure(8.0, 4.2)
    ax = fig.add_subplot(1, 1, 1)
    for k in range(r):
        ax.plot(frf.freq, db(sv[:, k]), lw=1.4 if k == 0 else 0.9, label=f"sigma {k + 1}")
    if poles is not None:
        _mark_poles(ax, _pole_array(poles, "poles"), frf.freq[0], frf.freq[-1])
    ax.set_xlabel(FREQ_LABEL)
    ax.set_ylabel(f"singular values, {db_label(frf.quantity)[4:-1]}")
    ax.set_xlim(frf.freq[0], frf.freq[-1])
    log_x_if_wide(ax, frf.freq)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="best", fontsize=8, ncol=2 if r > 4 else 1)
    return finish(fig, path, title or "CMIF (singular values of H)")


def _check_tol(x, name: str, hi: float = np.inf) -> float:
    x = check_scalar(x, name)
    if not 0 < x <= hi:
        raise ValueError(f"{name} must be a positive number{' <= 1' if hi == 1 else ''}, "
                         f"got {x!r}")
    return x


def _mac_pairs(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    num = np.abs(np.sum(a.conj() * b, axis=0)) ** 2
    den = np.sum(np.abs(a) ** 2, axis=0) * np.sum(np.abs(b) ** 2, axis=0)
    return np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0)


def stabilisation_flags(poles, shapes=None, freq_tol: float = 0.01, damping_tol: float = 0.05,
                        mac_min: float = 0.95) -> list[np.ndarray]:
    """Stability class of every pole against the previous model order (or iteration).

    A pole of order ``k`` is compared with the pole of order ``k - 1`` nearest in frequency
    (upper half-plane poles only): class 1 when the relative frequency change is within
    ``freq_tol``, 2 when the relative damping change is also within ``damping_tol``, 3 when
    the MAC of the two shapes is also at least ``mac_min`` (only when ``shapes`` are given).

    Parameters
    ----------
    poles : sequence of array_like
        Complex poles (rad/s) of each order, or models with ``.poles`` (ComplexModeModel:
        then the first left singular vector of each residue is its shape).
    shapes : sequence of array_like, optional
        Shapes of each order, ``(ns, n_k)`` with one column per pole of ``poles[k]``.
    freq_tol : float
        Relative frequency tolerance.
    damping_tol : float
        Relative damping-ratio tolerance.
    mac_min : float
        MAC above which two shapes count as the same, in (0, 1].

    Returns
    -------
    list of ndarray of int
        One array per order, aligned with ``poles[k]``: -1 for poles with ``Im <= 0`` (not
        drawn), 0 new, 1-3 as above (order 0 is all new).
    """
    freq_tol = _check_tol(freq_tol, "freq_tol")
    damping_tol = _check_tol(damping_tol, "damping_tol")
    mac_min = _check_tol(mac_min, "mac_min", 1.0)
    if isinstance(poles, np.ndarray) and poles.ndim == 1 or not hasattr(poles, "__len__"):
        raise TypeError("poles must be a sequence with one array of poles per model order")
    P = [_pole_array(p, f"poles[{k}]") for k, p in enumerate(poles)]
    S = _shapes(poles, shapes, P)
    flags, prev = [], None
    for k, p in enumerate(P):
        up = p.imag > 0
        flag = np.where(up, 0, -1)
        f, z = np.abs(p) / (2 * np.pi), -p.real / np.where(p == 0, 1, np.abs(p))
        if prev is not None and prev[0].size and up.any():
            fp, zp, sp_ = prev
            j = np.argmin(np.abs(f[up, None] - fp[None, :]), axis=1)
            ok_f = np.abs(f[up] - fp[j]) <= freq_tol * fp[j]
            ok_z = ok_f & (np.abs(z[up] - zp[j]) <= damping_tol * np.abs(zp[j]))
            cls = ok_f.astype(int) + ok_z
            if S is not None and sp_ is not None:
                ok_s = ok_z & (_mac_pairs(S[k][:, up], sp_[:, j]) >= mac_min)
                cls = cls + ok_s
            flag[up] = cls
        flags.append(flag)
        prev = (f[up], z[up], None if S is None else S[k][:, up])
    return flags


def _shapes(poles, shapes, P):
    """Shapes per order: given, from ComplexModeModel residues, or None."""
    if shapes is None:
        if all(getattr(p, "residues", None) is not None for p in poles):
            out = []
            for p in poles:
                R = np.asarray(p.residues)                      # (n, ns, na)
                U = np.linalg.svd(R)[0] if R.size else np.zeros((0, R.shape[1], 1))
                out.append(U[:, :, 0].T if R.shape[0] else np.zeros((R.shape[1], 0)))
            return out
        return None
    if len(shapes) != len(P):
        raise ValueError(f"shapes must have one array per order ({len(P)}), got {len(shapes)}")
    out = []
    for k, (s, p) in enumerate(zip(shapes, P)):
        a = np.asarray(s, dtype=complex)
        if a.ndim == 1 and p.size == 1:
            a = a[:, None]
        if a.ndim != 2 or a.shape[1] != p.size:
            raise ValueError(f"shapes[{k}] must have shape (ns, {p.size}) (one column per "
                             f"pole), got {a.shape}")
        out.append(a)
    if len({a.shape[0] for a in out}) > 1:
        raise ValueError("shapes must all have the same number of rows (sensors)")
    return out


def stabilisation(poles, frf=None, orders=None, path: str | os.PathLike | None = None,
                  title: str | None = None, *, shapes=None, freq_tol: float = 0.01,
                  damping_tol: float = 0.05, mac_min: float = 0.95, background: str = "cmif",
                  band=None, ylabel: str = "model order", model=None,
                  level: float = 0.95) -> Figure:
    """Stabilisation diagram: poles of each model order (or iteration) over the CMIF.

    Each pole is drawn at its frequency ``|p| / 2 pi`` (Hz) and its order, with a marker
    telling whether it is new or stable in frequency / damping / shape against the
    previous order (:func:`stabilisation_flags`).  Columns of stable markers point at
    physical modes; scattered new poles at computational ones.

    Parameters
    ----------
    poles : sequence of array_like or of models with ``.poles``
        Complex poles (rad/s) of each order or identification iteration.
    frf : FRF, optional
        Measured response drawn in the background (right axis, dB).
    orders : array_like, optional
        Vertical position of each entry of ``poles`` (default 1, 2, ...).
    path : str or os.PathLike, optional
        Save the figure there and close it.
    title : str, optional
        Figure title.
    shapes : sequence of array_like, optional
        Shapes ``(ns, n_k)`` per order for the shape test (see
        :func:`stabilisation_flags`; ComplexModeModel entries supply their own).
    freq_tol : float
        Relative frequency tolerance.
    damping_tol : float
        Relative damping tolerance.
    mac_min : float
        MAC threshold of the shape test.
    background : {"cmif", "sum"}
        Background curve: the first three singular values of ``H`` or ``sum |H|``.
    band : (float, float), optional
        Frequency range shown (Hz); default the FRF's, else the poles' range.
    ylabel : str
        Label of the order axis (e.g. ``"iteration"``).
    model : ComplexModeModel, optional
        The identified model: its modes (Im > 0, in the band shown) are drawn on a row above
        the last order, each with its frequency interval ``f +- z sigma_f`` as a horizontal
        error bar and its damping ``zeta +- z sigma_zeta`` (%) written over it
        (``frequency_std``, ``damping_std``, (3.56)-(3.59); "n/a" where the data do not
        determine them).
    level : float
        Probability of those intervals, in (0, 1): ``z`` is the normal quantile
        (1.96 at 0.95).

    Returns
    -------
    matplotlib.figure.Figure
        Two axes sharing the frequency axis: the background (``fig.axes[0]``, right
        ticks) and the poles (``fig.axes[1]``, one marker collection per class present).
        With ``model``: ``fig.axes[1].containers[0]`` is the modes' error bar (label
        ``"identified (95% interval)"``), and one text per mode holds its damping.
    """
    flags = stabilisation_flags(poles, shapes, freq_tol, damping_tol, mac_min)
    z = None if model is None else _model_level(model, level)
    P = [_pole_array(p, f"poles[{k}]") for k, p in enumerate(poles)]
    y = (np.arange(1, len(P) + 1, dtype=float) if orders is None
         else as_array(orders, "orders", ndim=1))
    if y.shape != (len(P),):
        raise ValueError(f"orders must have one value per entry of poles ({len(P)}), "
                         f"got shape {y.shape}")
    if background not in ("cmif", "sum"):
        raise ValueError(f"background must be 'cmif' or 'sum', got {background!r}")
    if frf is not None and not hasattr(frf, "H"):
        raise TypeError(f"frf must be an FRF, got {type(frf).__name__}")
    f_all = np.concatenate([np.abs(p[fl >= 0]) / (2 * np.pi) for p, fl in zip(P, flags)])
    if band is not None:
        lo, hi = check_band(band, "band")
    elif frf is not None:
        lo, hi = frf.freq[0], frf.freq[-1]
    elif f_all.size:
        lo, hi = f_all.min() * 0.95, f_all.max() * 1.05
    else:
        lo, hi = 0.0, 1.0
    fig = figure(9.0, 5.0)
    ax_bg = fig.add_subplot(1, 1, 1)
    ax = ax_bg.twinx()
    _background(ax_bg, frf, background)
    for c, (marker, color, label) in enumerate(_CLASSES):
        xs = [np.abs(p[fl == c]) / (2 * np.pi) for p, fl in zip(P, flags)]
        ys = [np.full(x.size, yk) for x, yk in zip(xs, y)]
        x, yy = np.concatenate(xs), np.concatenate(ys)
        if x.size:
            kw = ({"facecolors": "none", "edgecolors": color} if marker == "o"
                  else {"color": color})
            ax.scatter(x, yy, marker=marker, s=22, linewidths=1.0, label=label, **kw)
    ax_bg.yaxis.tick_right()
    ax_bg.yaxis.set_label_position("right")
    ax.yaxis.tick_left()
    ax.yaxis.set_label_position("left")
    ax.set_ylabel(ylabel)
    ax_bg.set_xlabel(FREQ_LABEL)
    ax_bg.set_xlim(lo, hi)
    if y.size:
        pad = 0.5 * (np.ptp(y) / max(len(y) - 1, 1) if len(y) > 1 else 1.0)
        top = y.max() + pad
        if z is not None:
            top = _mark_model(ax, model, (z, level), y.max() + 2 * pad, (lo, hi)) + pad
        ax.set_ylim(y.min() - pad, top)
    ax_bg.grid(True, axis="x", alpha=0.3)
    if ax.collections or ax.containers:
        fig.legend(*ax.get_legend_handles_labels(), loc="outside lower center", ncol=4,
                   fontsize=8, frameon=False)
    return finish(fig, path, title or "stabilisation diagram")


def _background(ax_bg, frf, background):
    """The stabilisation diagram's background curve: CMIF or ``sum |H|`` (dB), none
    without an FRF."""
    if frf is None:
        ax_bg.set_yticks([])
    elif background == "cmif":
        sv = _singular_values(frf.H)[:, :3]
        for k in range(sv.shape[1]):
            ax_bg.plot(frf.freq, db(sv[:, k]), color="0.6", lw=1.0 if k == 0 else 0.6)
        ax_bg.set_ylabel(f"CMIF ({db_label(frf.quantity)[5:]}")
    else:
        ax_bg.plot(frf.freq, db(np.abs(frf.H).sum(axis=(1, 2))), color="0.6", lw=1.0)
        ax_bg.set_ylabel(f"sum |H|, {db_label(frf.quantity)[4:-1]}")


def _model_level(model, level) -> float:
    """Normal quantile of ``level`` after checking that ``model`` carries pole statistics."""
    if not all(hasattr(model, k) for k in ("poles", "frequency_std", "damping_std")):
        raise TypeError("model must be an identified ComplexModeModel (with frequency_std "
                        f"and damping_std), got {type(model).__name__}")
    return level_quantile(level)


def _mark_model(ax, model, level, y, band) -> float:
    """Draw ``model``'s modes in ``band`` (Hz) at height ``y``: frequency +- ``z`` std as a
    horizontal error bar, damping +- ``z`` std (%) written above; returns ``y``."""
    z, prob = level
    lam = np.asarray(model.poles)
    f, zeta = np.asarray(model.frequency), np.asarray(model.damping)
    sf, sz = np.asarray(model.frequency_std), np.asarray(model.damping_std)
    keep = (lam.imag > 0) & (f >= band[0]) & (f <= band[1])
    f, zeta, hf, hz = f[keep], zeta[keep], z * sf[keep], z * sz[keep]
    ax.errorbar(f, np.full(f.size, y), xerr=np.where(np.isfinite(hf), hf, 0.0), fmt="D",
                ms=4, color="tab:red", capsize=3, lw=1.2,
                label=f"identified ({prob:.0%} interval)")
    for fj, zj, hj in zip(f, zeta, hz):
        half = f"{100 * hj:.2g}" if np.isfinite(hj) else "n/a"
        ax.annotate(f"{100 * zj:.3g} +- {half} %", (fj, y), xytext=(0, 5),
                    textcoords="offset points", ha="center", va="bottom", fontsize=7,
                    rotation=90, color="tab:red")
    return y
