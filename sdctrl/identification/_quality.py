"""How well an identified model reproduces its data, said where it matters (thesis 3.4).

A fit error above :data:`FIT_WARN` (relative quadratic error, 3.11) is reported with where it
comes from -- the frequency lines and the channels that carry most of it -- and what to try,
so that a user never takes a model that misses a third of the data for a good one.
"""

from __future__ import annotations

import numpy as np

__all__ = ["FIT_WARN", "fit_quality"]

#: relative quadratic fit error (3.11) above which :func:`sdctrl.identify` warns
FIT_WARN = 0.10


def _concentration(err: np.ndarray, share: float = 0.8) -> np.ndarray:
    """Indices of the fewest entries of ``err`` (>= 0) carrying ``share`` of its sum."""
    order = np.argsort(err)[::-1]
    cum = np.cumsum(err[order])
    k = int(np.searchsorted(cum, share * cum[-1])) + 1
    return np.sort(order[:k])


def fit_quality(cm, data) -> list[str]:
    """Warnings about the fit of ``cm`` to ``data`` (empty when the error is below FIT_WARN).

    Parameters
    ----------
    cm : ComplexModeModel
        The identified model.
    data : FRF
        The lines it was fitted to.

    Returns
    -------
    list of str
        One message naming the fit error, the frequency range and the channels that carry
        most of it, and what to try.
    """
    if not np.isfinite(cm.cost) or cm.cost <= FIT_WARN:
        return []
    R = np.abs(data.H - cm.frf(data.freq, quantity=data.quantity).H) ** 2
    total = float(R.sum())
    if not total > 0:
        return []
    per = R.sum(axis=(1, 2))
    lines = _concentration(per)
    runs = np.split(lines, np.flatnonzero(np.diff(lines) > 1) + 1)
    runs = sorted(runs, key=lambda r: -per[r].sum())[:3]
    where = ", ".join(f"{data.freq[r[0]]:.4g}-{data.freq[r[-1]]:.4g} Hz" for r in
                      sorted(runs, key=lambda r: r[0]))
    share = float(sum(per[r].sum() for r in runs) / total)
    chan = R.sum(axis=0).ravel()
    worst = np.argsort(chan)[::-1][:3]
    na = data.H.shape[2]
    names = ", ".join(f"{data.sensors[i // na]}/{data.actuators[i % na]} "
                      f"({chan[i] / total:.0%})" for i in worst)
    return [f"identify: the model leaves a relative fit error of {cm.cost:.1%} (above "
            f"{FIT_WARN:.0%}); {share:.0%} of it lies in {where}; the largest channels "
            f"(sensor/actuator) are {names}. Try band=(fmin, fmax) around the modes you need (lines with no "
            "mode, e.g. below the first resonance of a roving-hammer test, cannot be fitted), "
            "check the quantity and units of the data, or give poles= for modes the "
            "automatic selection missed."]
