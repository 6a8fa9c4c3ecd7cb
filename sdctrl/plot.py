"""Matplotlib figures (imported lazily; uses the non-interactive Agg backend when headless)."""

from __future__ import annotations

import numpy as np

__all__ = ["bode"]


def _pyplot():
    import matplotlib

    if matplotlib.get_backend().lower() not in ("agg", "module://matplotlib_inline.backend_inline"):
        import os

        if not os.environ.get("DISPLAY"):
            matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def bode(frfs, labels=None, channels=None, path=None, title=None):
    """Bode plot (magnitude in dB, phase in degrees) of one or several FRFs.

    Parameters
    ----------
    frfs : FRF or sequence of FRF
        Data to overlay (same sensors/actuators).
    labels : sequence of str, optional
        Legend entries, one per FRF.
    channels : sequence of (int, int), optional
        ``(sensor, actuator)`` pairs to show; default the collocated pairs, else (0, 0).
    path : str or os.PathLike, optional
        Save the figure there (PNG) and close it.
    title : str, optional
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from sdctrl.frf import FRF

    if isinstance(frfs, FRF):
        frfs = [frfs]
    frfs = list(frfs)
    if not frfs or not all(isinstance(f, FRF) for f in frfs):
        raise TypeError("frfs must be an FRF or a sequence of FRF")
    if labels is None:
        labels = [f"FRF {i}" for i in range(len(frfs))]
    if channels is None:
        channels = list(frfs[0].collocated) or [(0, 0)]
    plt = _pyplot()
    fig, axes = plt.subplots(2, len(channels), figsize=(4.5 * len(channels), 5.5),
                             squeeze=False, sharex="col")
    styles = ["-", "--", ":", "-."]
    for k, (s, a) in enumerate(channels):
        for i, (frf, lab) in enumerate(zip(frfs, labels)):
            h = frf.H[:, s, a]
            axes[0, k].plot(frf.freq, 20 * np.log10(np.abs(h) + 1e-300), styles[i % 4],
                            label=lab)
            axes[1, k].plot(frf.freq, np.degrees(np.angle(h)), styles[i % 4])
        axes[0, k].set_title(f"{frfs[0].sensors[s]} / {frfs[0].actuators[a]}")
        axes[0, k].set_ylabel(f"|H| dB ({frfs[0].quantity})")
        axes[1, k].set_ylabel("phase (deg)")
        axes[1, k].set_xlabel("frequency (Hz)")
        axes[1, k].set_ylim(-185, 185)
        for ax in axes[:, k]:
            if frfs[0].freq[-1] / frfs[0].freq[0] > 100:
                ax.set_xscale("log")
            ax.grid(True, which="both", alpha=0.3)
    axes[0, 0].legend(loc="best", fontsize=8)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=110)
        plt.close(fig)
    return fig
