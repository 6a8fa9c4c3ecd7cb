"""Figure of a diagnosis (:func:`sdctrl.diagnose`): FRFs before/after at the worst channel and
the residual maps."""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

import numpy as np

from sdctrl.plot._figure import db, db_label, figure, finish

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["diagnosis"]


def _channel(result, channel, before):
    """(sensor index, actuator index) in the data of the channel to show."""
    frf = result.frf
    if channel is None:
        return before.worst_channel
    if (not isinstance(channel, tuple | list) or len(channel) != 2
            or not all(isinstance(c, str) for c in channel)):
        raise TypeError(f"channel must be a (sensor, actuator) pair of labels, got {channel!r}")
    s, a = channel
    if s not in frf.sensors or a not in frf.actuators:
        raise ValueError(f"channel {channel!r} is not a channel of the data")
    return frf.sensors.index(s), frf.actuators.index(a)


def _map(fig, ax, per_channel, sensors, actuators, title, vmax):
    im = ax.imshow(np.log10(np.maximum(per_channel, vmax * 1e-8)), aspect="auto",
                   cmap="viridis", vmin=np.log10(vmax) - 6, vmax=np.log10(vmax))
    ax.set_xticks(range(len(actuators)), actuators, rotation=90, fontsize=7)
    step = max(1, len(sensors) // 16)
    ax.set_yticks(range(0, len(sensors), step), sensors[::step], fontsize=7)
    ax.set_xlabel("actuator")
    ax.set_title(title, fontsize=9)
    return im


def diagnosis(result, path: str | os.PathLike | None = None, channel=None,
              title: str | None = None) -> Figure:
    """FRFs of the data, the input model and the corrected model at the worst channel, the
    residual per line, and the residual maps (mean ``|Log H_M - Log H_I|^2`` per channel,
    3.12) before and after the corrections.

    Parameters
    ----------
    result : Diagnosis
        A result of :func:`sdctrl.diagnose`.
    path : str or os.PathLike, optional
        Save the figure there and close it.
    channel : (str, str), optional
        ``(sensor, actuator)`` labels of the channel to show; default the channel with the
        largest residual of the input model.
    title : str, optional
        Figure title; default the effects found.

    Returns
    -------
    matplotlib.figure.Figure
        Axes: magnitude, phase, residual per line, then the two maps and the colour bar.
    """
    from sdctrl.diagnosis import Diagnosis

    if not isinstance(result, Diagnosis):
        raise TypeError(f"result must be a Diagnosis (sd.diagnose), got {type(result).__name__}")
    if result.frf is None or result.initial is None:
        raise ValueError("result holds no data or input model to draw")
    before, after = result.residual(after=False), result.residual(after=True)
    i, j = _channel(result, channel, before)
    frf = result.frf
    f, q = frf.freq, frf.quantity
    Hb = result.initial.frf(f, q).select([frf.sensors[i]], [frf.actuators[j]]).H[:, 0, 0]
    Ha = result.model.frf(f, q).select([frf.sensors[i]], [frf.actuators[j]]).H[:, 0, 0]
    Hd = frf.H[:, i, j]
    fig = figure(11.0, 9.0)
    gs = fig.add_gridspec(3, 2, height_ratios=[1.4, 0.8, 1.3])
    ax_m = fig.add_subplot(gs[0, :])
    ax_p = fig.add_subplot(gs[1, 0], sharex=ax_m)
    ax_r = fig.add_subplot(gs[1, 1], sharex=ax_m)
    for H, style, lab in ((Hd, "k-", "data"), (Hb, "C1--", "model before"),
                          (Ha, "C0:", "model after")):
        ax_m.plot(f, db(H), style, lw=1.2, label=lab)
        ax_p.plot(f, np.degrees(np.angle(H)), style, lw=1.0)
    ax_m.set_ylabel(db_label(q))
    ax_m.set_title(f"{frf.sensors[i]} / {frf.actuators[j]}", fontsize=9)
    ax_m.legend(fontsize=8)
    ax_p.set_ylabel("phase (deg)")
    ax_p.set_xlabel("frequency (Hz)")
    ax_r.semilogy(f, np.maximum(before.per_line, 1e-300), "C1-", lw=1, label="before")
    ax_r.semilogy(f, np.maximum(after.per_line, 1e-300), "C0-", lw=1, label="after")
    ax_r.set_ylabel("residual per line")
    ax_r.set_xlabel("frequency (Hz)")
    ax_r.legend(fontsize=8)
    vmax = max(float(before.per_channel.max()), 1e-300)
    _map(fig, fig.add_subplot(gs[2, 0]), before.per_channel, frf.sensors, frf.actuators,
         f"residual map before (cost {before.cost:.3g})", vmax)
    im = _map(fig, fig.add_subplot(gs[2, 1]), after.per_channel, frf.sensors, frf.actuators,
              f"residual map after (cost {after.cost:.3g})", vmax)
    fig.colorbar(im, ax=fig.axes[-2:], label="log10 mean |residual|^2")
    if title is None:
        kinds = ", ".join(e.kind for e in result.effects) or "no effect"
        title = f"Diagnosis: {kinds}"
    return finish(fig, path, title)
