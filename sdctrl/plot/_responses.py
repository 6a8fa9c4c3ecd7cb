"""Frequency-response figures: Bode overlays and uncertainty envelopes."""

from __future__ import annotations

import os
import warnings
from typing import TYPE_CHECKING

import numpy as np

from sdctrl._lib.validate import as_array, check_int, check_seed
from sdctrl.data._frf import FRF
from sdctrl.plot import _channels as ch
from sdctrl.plot._figure import (
    FREQ_LABEL,
    PHASE_LABEL,
    STYLES,
    channel_grid,
    db,
    db_label,
    finish,
    log_x_if_wide,
)

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["bode", "envelope", "phase_display"]

#: a sample's phase is coherent when the median |phase step| around it is below this (deg)
PHASE_STEP_TOL = 25.0
#: ... over this many steps (centred window)
PHASE_WINDOW = 12
#: coherent runs shorter than this many samples (chance in noise) count as noise
PHASE_MIN_RUN = 6
#: ... and, when the FRF carries a coherence, when the coherence reaches this value
COHERENCE_MIN = 0.5


def phase_display(h, coherence=None, unwrap: bool = True,
                  reference=None) -> tuple[np.ndarray, np.ndarray]:
    """Phase of one channel split into a coherent line and scattered noisy points (degrees).

    A sample is *coherent* when the median of the absolute wrapped phase steps in a window
    of :data:`PHASE_WINDOW` steps centred on it is below :data:`PHASE_STEP_TOL` degrees
    (a clean response turns slowly between lines except for isolated jumps at lightly damped
    poles and zeros, which the median ignores; noise makes the steps random, median ~90 deg)
    and, if ``coherence`` is given, when it reaches :data:`COHERENCE_MIN`; a run of coherent
    samples loses the end samples it reaches by a step above the tolerance (noise next to
    clean data, let through by the window), and runs of fewer than :data:`PHASE_MIN_RUN`
    samples (chance in noise) do not count.

    Coherent samples are unwrapped among themselves, so noisy samples never shift them by
    360 deg.  Across a noisy gap the turn count is unknowable (a lightly damped zero or pole
    inside the gap turns the phase by about 180 deg either way); with a ``reference`` each
    coherent run is moved by the multiple of 360 deg that puts it closest to the reference
    (median difference), so that a noisy test overlays its model.  The other samples are
    wrapped into the 360 deg window centred on the last coherent value (the first one before
    any; (-180, 180] when ``unwrap`` is False), to be drawn as points rather than as a line
    that fills the axes with vertical strokes.

    Parameters
    ----------
    h : array_like, shape (nf,)
        Complex response of one channel.
    coherence : array_like, shape (nf,), optional
        Coherence of the channel in [0, 1].
    unwrap : bool
        Unwrap the coherent samples; False keeps every value in (-180, 180].
    reference : array_like, shape (nf,), optional
        Unwrapped phase (deg) of a cleaner overlay on the same lines (NaN where unknown).

    Returns
    -------
    line : ndarray, shape (nf,)
        Phase (deg) at coherent samples, NaN elsewhere.
    points : ndarray, shape (nf,)
        Phase (deg) at the other samples, NaN at coherent ones.
    """
    h = as_array(h, "h", ndim=1, dtype=complex)
    n = h.size
    if coherence is not None:
        coherence = as_array(coherence, "coherence", shape=(n,))
        if np.any(coherence < 0) or np.any(coherence > 1):
            raise ValueError("coherence must lie in [0, 1]")
    if reference is not None:
        reference = as_array(reference, "reference", shape=(n,), finite=False)
        if np.any(np.isinf(reference)):
            raise ValueError("reference must hold finite phases (deg) or NaN where unknown")
    ph = np.degrees(np.angle(h))
    coherent = _coherent(h, coherence)
    line = np.full(n, np.nan)
    points = np.full(n, np.nan)
    idx = np.flatnonzero(coherent)
    ref = np.zeros(n)
    if idx.size and not unwrap:
        line[idx] = ph[idx]
    elif idx.size:
        line[idx] = np.unwrap(ph[idx], period=360.0)
        if reference is not None:
            _align_runs(line, coherent, np.asarray(reference, float))
        # reference of each noisy sample: the last coherent value before it (else the first)
        last = np.maximum.accumulate(np.where(coherent, np.arange(n), -1))
        ref = line[np.where(last >= 0, last, idx[0])]
    noisy = ~coherent
    points[noisy] = ref[noisy] + (ph[noisy] - ref[noisy] + 180.0) % 360.0 - 180.0
    return line, points


def _coherent(h: np.ndarray, coherence) -> np.ndarray:
    """Samples whose phase is signal, not noise (rule in :func:`phase_display`)."""
    n = h.size
    coherent = np.ones(n, bool)
    if n > 1:
        step = np.abs(np.angle(h[1:] * np.conj(h[:-1])))            # (n-1,) wrapped steps
        w = PHASE_WINDOW // 2
        pad = np.concatenate([np.full(w, np.nan), step, np.full(w, np.nan)])
        win = np.lib.stride_tricks.sliding_window_view(pad, 2 * w)   # (n, 2w) around sample
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)          # all-NaN window (n < 3)
            med = np.nanmedian(win, axis=1)
        coherent = med <= np.radians(PHASE_STEP_TOL)
    coherent &= np.abs(h) > 0
    if coherence is not None:
        coherent &= np.asarray(coherence, float) >= COHERENCE_MIN
    if n > 1:
        _trim_run_ends(coherent, step > np.radians(PHASE_STEP_TOL), PHASE_WINDOW // 2)
    starts, stops = _runs(coherent)
    keep = np.zeros(n + 1, np.int8)
    long = stops - starts >= min(PHASE_MIN_RUN, n)
    np.add.at(keep, starts[long], 1)
    np.add.at(keep, stops[long], -1)
    return np.cumsum(keep[:-1]) > 0


def _trim_run_ends(mask: np.ndarray, big: np.ndarray, most: int) -> None:
    """Cut (in place) each run of ``mask`` at the big steps among its first and last ``most``.

    The window median lets a few noise samples next to clean data pass; a noise sample is
    reached by random steps, so a big step close to a run's end marks where noise begins.
    """
    for a, b in zip(*_runs(mask)):                     # a loop over runs, not frequencies
        lo, hi = a, b
        tail = np.flatnonzero(big[max(a, b - 1 - most):b - 1])   # steps j -> j + 1
        if tail.size:
            hi = max(a, b - 1 - most) + tail[0] + 1
        head = np.flatnonzero(big[a:min(a + most, hi - 1)])
        if head.size:
            lo = a + head[-1] + 1
        mask[a:lo] = False
        mask[max(hi, lo):b] = False


def _runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start and stop (exclusive) indices of the runs of True in ``mask``."""
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)


def _align_runs(line: np.ndarray, coherent: np.ndarray, reference: np.ndarray) -> None:
    """Shift each coherent run of ``line`` (deg, in place) by 360 k towards ``reference``."""
    for a, b in zip(*_runs(coherent)):                 # a loop over runs, not frequencies
        d = line[a:b] - reference[a:b]
        d = d[np.isfinite(d)]
        if d.size:
            line[a:b] -= 360.0 * np.round(np.median(d) / 360.0)


def _default_labels(items) -> list[str]:
    if len(items) == 1:
        return [""]
    return [("FRF" if isinstance(it, FRF) else type(it).__name__) + f" {i}"
            for i, it in enumerate(items)]


def _broken(x, y, jump: float = 180.0):
    """``x, y`` with NaN inserted where ``y`` jumps by more than ``jump`` (a wrap)."""
    brk = np.flatnonzero(np.abs(np.diff(y)) > jump) + 1
    if not brk.size:
        return x, y
    return np.insert(x.astype(float), brk, np.nan), np.insert(y, brk, np.nan)


def _channel_phases(frfs, where_k, unwrap):
    """Phase (line, points) of every system on one channel; the cleanest sets the turns."""
    first = [None if w is None else phase_display(
        f.H[:, w[0], w[1]], None if f.coherence is None else f.coherence[:, w[0], w[1]],
        unwrap) for f, w in zip(frfs, where_k)]
    score = [-1.0 if p is None else np.mean(np.isfinite(p[0])) for p in first]
    r = int(np.argmax(score))                                 # earliest of the cleanest
    if not unwrap or score[r] <= 0:
        return first
    ref_f, ref_line = frfs[r].freq, first[r][0]
    out = []
    for i, (f, w) in enumerate(zip(frfs, where_k)):
        if w is None or i == r:
            out.append(first[i])
            continue
        ref = np.interp(f.freq, ref_f, ref_line, left=np.nan, right=np.nan)
        coh = None if f.coherence is None else f.coherence[:, w[0], w[1]]
        out.append(phase_display(f.H[:, w[0], w[1]], coh, unwrap, reference=ref))
    return out


def _draw_channel(ax_m, ax_p, frf, s, a, style, color, label, phase):
    ax_m.plot(frf.freq, db(frf.H[:, s, a]), style, color=color, label=label)
    if ax_p is None:
        return
    line, points = phase
    ax_p.plot(*_broken(frf.freq, line), style, color=color)
    if np.any(np.isfinite(points)):
        ax_p.plot(frf.freq, points, ".", color=color, ms=2.5, alpha=0.6)


def bode(systems, labels=None, channels=None, path: str | os.PathLike | None = None,
         title: str | None = None, *, sensors=None, actuators=None, freq=None,
         quantity: str | None = None, phase: bool = True, unwrap: bool = True,
         max_cols: int = 3) -> Figure:
    """Bode overlay (magnitude in dB, phase in degrees) of FRFs, models and StateSpace objects.

    One panel pair (magnitude over phase) per channel, wrapping into rows of at most
    ``max_cols`` panels; the figure size is capped so that many channels shrink the panels
    rather than grow the page.  Phase is unwrapped per channel where it is coherent and
    drawn as scattered points where the data is noise (see :func:`phase_display`); the
    cleanest overlay of a channel fixes the 360-degree turn count of the others' coherent
    stretches, so a noisy test and its model are drawn on the same turn.

    Parameters
    ----------
    systems : FRF, model or control.StateSpace, or a sequence of them
        What to overlay.  Models with a ``frf(freq, quantity)`` method (complex-mode,
        normal-mode, hybrid) are evaluated in ``quantity``; a StateSpace (or
        TransferFunction) is taken to output ``quantity`` per unit input.
    labels : sequence of str, optional
        Legend entries, one per system (default: type and position).
    channels : (sensor, actuator) pair or sequence of pairs, optional
        Channels to draw, each element a label or an index of the first system.  Labels
        match FRF labels and StateSpace signal names alike (``"N42.y"`` is output
        ``N42_y`` and input ``N42_y_u``).  Default: the collocated pairs of the first
        system, else its pairs with one label on both sides (``"N42.y"`` / ``"N42.y"``),
        else all its channels (at most 12, with a warning).
    path : str or os.PathLike, optional
        Save the figure there (format from the extension) and close it.
    title : str, optional
        Figure title.
    sensors, actuators : label, index or sequence of them, optional
        Instead of ``channels``: draw every pair of these sensors and actuators (all of
        one side when only the other is given).
    freq : array_like, optional
        Frequencies (Hz) at which models and StateSpace objects are evaluated; default
        the grid of the first FRF given (required when no FRF is given).
    quantity : {"displacement", "velocity", "acceleration"}, optional
        Quantity plotted (FRFs are converted by powers of ``j w``); default that of the
        first FRF, else displacement.  Sets the unit of the magnitude axis.
    phase : bool
        Draw the phase panels (False: magnitude only, denser grids).
    unwrap : bool
        Unwrap the phase where coherent; False draws it wrapped in (-180, 180].
    max_cols : int
        Panels per row.

    Returns
    -------
    matplotlib.figure.Figure
        Axes in channel order: magnitude then phase of channel 0, then channel 1, ...;
        magnitude lines carry ``20 log10 |H|``, one per system that has the channel.

    Raises
    ------
    ValueError
        Unknown channel label or index (the message names the argument), no frequency grid
        for a model, a system with none of the chosen channels.

    Examples
    --------
    >>> import sdctrl as sd
    >>> frf = sd.testbed_frf(n=200)
    >>> fig = sd.plot.bode(frf, channels=[("N32.z", "N32.z")])
    >>> len(fig.axes)
    2
    """
    items = ch.as_list(systems, "systems")
    frfs, q = ch.to_frfs(items, freq, quantity, "systems")
    legend = ch.legend_labels(labels, len(items)) if labels is not None else _default_labels(items)
    if not isinstance(max_cols, int | np.integer) or max_cols < 1:
        raise ValueError(f"max_cols must be a positive integer, got {max_cols!r}")
    pairs = ch.select(frfs[0], channels, sensors, actuators)
    where = ch.locate(frfs, pairs, "systems")
    fig, axes = channel_grid(len(pairs), phase=phase, max_cols=int(max_cols))
    ref = frfs[0]
    cycle = _color_cycle()
    for k, (s, a) in enumerate(pairs):
        ax_m, ax_p = axes[k]
        where_k = [w[k] for w in where]
        phases = _channel_phases(frfs, where_k, unwrap) if phase else [None] * len(frfs)
        for i, frf in enumerate(frfs):
            if where_k[i] is not None:
                _draw_channel(ax_m, ax_p, frf, *where_k[i], STYLES[i % len(STYLES)],
                              cycle[i % len(cycle)], legend[i] or None, phases[i])
        ax_m.set_title(f"{ref.sensors[s]} / {ref.actuators[a]}", fontsize=10)
        ax_m.set_ylabel(db_label(q), fontsize=9)
        bottom = ax_m if ax_p is None else ax_p
        bottom.set_xlabel(FREQ_LABEL)
        if ax_p is not None:
            ax_p.set_ylabel(PHASE_LABEL, fontsize=9)
        for ax in (ax_m, ax_p):
            if ax is not None:
                log_x_if_wide(ax, ref.freq)
                ax.grid(True, which="both", alpha=0.3)
    if any(legend):
        axes[0][0].legend(loc="best", fontsize=8)
    return finish(fig, path, title)


def _color_cycle():
    import matplotlib as mpl

    return mpl.rcParams["axes.prop_cycle"].by_key().get("color", [None])


def _envelope_of_model(um, freq, nominal, quantity, draws, executor=None):
    """(nominal FRF, |H| min, |H| max) from an UncertainModel's ``frf_envelope``;
    ``draws`` is ``(n_samples, seed, max_vertices)``."""
    from sdctrl._lib.validate import QUANTITY_POWER, check_freq, check_quantity
    from sdctrl.data._frf import FRF

    nom_frf = None
    if nominal is not None:
        nom_frf = ch.to_frfs(ch.as_list(nominal, "nominal"), freq, quantity, "nominal")[0][0]
    if freq is None:
        if nom_frf is None:
            raise ValueError("freq must be given (Hz) to evaluate the uncertain model")
        freq = nom_frf.freq
    f = check_freq(freq, "freq")
    q = check_quantity(quantity or (nom_frf.quantity if nom_frf is not None else
                                    "displacement"), "quantity")
    extra = {} if executor is None else {"executor": executor}
    n_samples, seed, max_vertices = draws
    env = um.frf_envelope(f, n_samples=n_samples, seed=seed, max_vertices=max_vertices,
                          **extra)
    gain = (2 * np.pi * f[:, None, None]) ** QUANTITY_POWER[q]    # |(j w)^k|, displacement in
    model = getattr(um, "model", None)
    ns, na = env["nominal"].shape[1:]
    sens = getattr(model, "sensors", None) or (nom_frf.sensors if nom_frf is not None and
                                               nom_frf.H.shape[1] == ns else None)
    acts = getattr(model, "actuators", None) or (nom_frf.actuators if nom_frf is not None and
                                                 nom_frf.H.shape[2] == na else None)
    ref = FRF(f, env["nominal"], "displacement", sensors=sens, actuators=acts,
              collocated=getattr(model, "collocated", None) or None).to(q)
    return (nom_frf or ref), ref, env["mag_min"] * gain, env["mag_max"] * gain, q


def envelope(samples, freq=None, nominal=None, channels=None, path: str | os.PathLike | None = None,
             title: str | None = None, *, sensors=None, actuators=None, quantity: str | None = None,
             n_samples: int = 200, seed=0, max_cols: int = 3, executor=None,
             max_vertices: int = 256) -> Figure:
    """Uncertainty envelope: min/max band of ``|H|`` (dB) over samples, with the nominal.

    Parameters
    ----------
    samples : UncertainModel or sequence of FRF, model or control.StateSpace
        An object with a ``frf_envelope(freq, n_samples, seed)`` method (the
        :class:`~sdctrl.UncertainModel`: random samples plus box vertices of its
        normalised uncertainty, displacement outputs) or the sampled systems themselves
        (e.g. ``um.sample(50)`` or FRFs of repeated tests), all on one frequency grid.
    freq : array_like, optional
        Frequencies (Hz) at which models are evaluated; default the grid of an FRF
        ``nominal``, else of the first FRF among ``samples``.
    nominal : FRF, model or control.StateSpace, optional
        Drawn as a line over the band; for an uncertain model its own nominal by default.
    channels : (sensor, actuator) pair or sequence of pairs, optional
        Channels by label or index, as in :func:`bode` (same default).
    path : str or os.PathLike, optional
        Save the figure there and close it.
    title : str, optional
        Figure title.
    sensors, actuators : label, index or sequence of them, optional
        Instead of ``channels``: every pair of these.
    quantity : {"displacement", "velocity", "acceleration"}, optional
        Quantity plotted; default that of the first FRF, else displacement.
    n_samples : int
        Random samples drawn by ``frf_envelope`` (uncertain model only).
    seed : int, optional
        Seed of those samples.
    max_cols : int
        Panels per row.
    executor : concurrent.futures.Executor, optional
        Passed on to ``frf_envelope`` (uncertain model only): evaluates the draws on it.
    max_vertices : int
        Box vertices drawn by ``frf_envelope`` (uncertain model only): all ``2**nblocks``
        when not more, else that many random ones.

    Returns
    -------
    matplotlib.figure.Figure
        One magnitude axes per channel holding the band (a ``fill_between`` collection
        from ``20 log10 min|H|`` to ``20 log10 max|H|``) and the nominal line.
    """
    n_samples = check_int(n_samples, "n_samples", minimum=1, maximum=10**6)
    seed = check_seed(seed, "seed")
    max_cols = check_int(max_cols, "max_cols", minimum=1)
    if callable(getattr(samples, "frf_envelope", None)):
        nom, ref, lo, hi, q = _envelope_of_model(samples, freq, nominal, quantity,
                                                 (n_samples, seed, max_vertices), executor)
        what = "samples and vertices"
    else:
        if freq is None and isinstance(nominal, FRF):
            freq = nominal.freq
        frfs, q = ch.to_frfs(ch.as_list(samples, "samples"), freq, quantity, "samples")
        ref = frfs[0]
        if any(f.freq.shape != ref.freq.shape or np.any(f.freq != ref.freq) for f in frfs):
            raise ValueError("samples must share one frequency grid (pass freq= for models)")
        mags = []
        for i, f in enumerate(frfs):
            si, ai = ch.align(ref, f, f"samples[{i}]")
            mags.append(np.abs(f.H[:, si][:, :, ai]))
        lo, hi = np.min(mags, axis=0), np.max(mags, axis=0)
        nom = (ch.to_frfs(ch.as_list(nominal, "nominal"), ref.freq, q, "nominal")[0][0]
               if nominal is not None else None)
        what = f"{len(frfs)} samples"
    base = nom if nom is not None else ref
    pairs = ch.select(base, channels, sensors, actuators)
    in_ref = ch.locate([base, ref], pairs, "nominal")[1]
    fig, axes = channel_grid(len(pairs), phase=False, max_cols=int(max_cols))
    for k, (s, a) in enumerate(pairs):
        ax = axes[k][0]
        if in_ref[k] is not None:
            rs, ra = in_ref[k]
            ax.fill_between(ref.freq, db(lo[:, rs, ra]), db(hi[:, rs, ra]), alpha=0.35, lw=0,
                            label=f"envelope ({what})")
        if nom is not None:
            ax.plot(nom.freq, db(nom.H[:, s, a]), "k-", lw=1.2, label="nominal")
        ax.set_title(f"{base.sensors[s]} / {base.actuators[a]}", fontsize=10)
        ax.set_ylabel(db_label(q), fontsize=9)
        ax.set_xlabel(FREQ_LABEL)
        log_x_if_wide(ax, ref.freq)
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].legend(loc="best", fontsize=8)
    return finish(fig, path, title)
