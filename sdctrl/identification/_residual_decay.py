"""Noise correlated between lines, seen from the data when no window is recorded: the decay
of the starting fit's residual over the record (thesis 3.2.1, 3.4).

An FRF of records taken through an exponential window ``exp(-t/tau)`` has noise correlated
between lines (:func:`~sdctrl.identification._line_correlation.line_correlation`), and the
automatic selection must then follow the rules of windowed data
(:mod:`~sdctrl.identification._rules`): with the rules of independent lines, the residual
scan and the close-mode search take the correlated noise for modes.  When the FRF does not
record its window (a UFF written by another tool, a survey assembled by hand), the data
show it: the noise of line ``k`` is the transform of the windowed noise record, so the
residual's inverse transform over the lines of the band -- a record of the band's period
``T = 1/df``, ``nf`` samples -- has power ``exp(-2 t/tau)``: it falls by
``exp(2 T/tau)`` over the record (``2 ln 100 = 9.2`` for a window ending at 1%).  Noise
independent between lines has a flat profile, and the model's error at a start -- a pole
a little off, the tails of modes outside the band -- is smooth over the lines, so its
transform lives at the first samples (a mode whose half-power band spans ``b`` lines decays
as ``exp(-pi b t/T)``): the profile is measured from ``0.2 T`` to ``0.9 T`` (the end of
the record holds the acausal part of the smooth error).

The measure is the slope ``a`` of ``ln P(t)`` against ``t/T`` over that span, ``P`` the
median over the data columns of each column's power (normalised by its mean), once the
model's error is taken out: the record's directions across the ``k`` columns whose
singular value exceeds :data:`STRUCTURE` times the median are removed (noise spreads
evenly over the directions, within 1.5 times the median for as many lines as a band has;
a mode the start missed or misplaced is one direction, common to the columns, decaying at
its own rate: noise-free data read up to 12.5 without this, the start's error of lightly
damped modes).  The residual is not noise, and there is no measure, when more than half
its directions are above, or when the remaining singular values span more than
:data:`SPREAD` = 30 (noise: 3.1-19.5 on the windowed surveys below, 3.8-9.6 with
independent lines; the error of a noise-free start spans decades: 57 and 64 on the
single-reference ten-mode data of ``tests/test_identify.py``, which read 12.5 and 10.8,
2e8 on the same data compressed to 20 columns, which read 3.7).
With fewer than :data:`MIN_COLUMNS` columns there is no measure either (one channel
cannot tell a missed lightly damped mode from windowed noise: the real impact records of
``examples/data/impact_pyfrf`` without an exponential window read 4.8-12 on their single
channel, their start missing two strong modes at 4163 and 4167 Hz).  The rules of
windowed data are taken when ``a`` exceeds :data:`DECAY_LIMIT` = 2 (noise power falling
7.4 times over the record, a window ending at 37% of its start; the geometric mean of the
extremes below, 0.79 and 4.95).  Measured on the
starting fit (LSCF and peak poles, residues by least squares) of:

* 102 FRFs without windowed noise: the testbed at 0, 0.1% and 1% noise over three bands,
  acceleration and displacement, 150 and 1000 lines; the family's five members at 0, 0.1%
  and 1%, both quantities, 150 and 600 lines; a simulated hammer survey with coherence;
  the noise-free data of ``tests/test_identify_initial.py`` and
  ``tests/test_identify_to_normal.py``: ``a`` from -2.0 to 0.79 with noise (7 of 65
  without a measure), up to 0.17 noise-free, where 33 of the 37 starts have no measure
  (without the tests of noise: up to 3.7, and 12.5 without the directions removed);
* roving-hammer surveys through a window ending at 1% (``a = 9.2``) whose window is not
  recorded: the family's five members (seeds 1, 2: 7.4 to 8.8; 20 hit points and 400
  lines: 6.7 to 8.3) and a held-out aircraft survey in seven variants (5.0 and 5.2 with
  frequencies drifting between hit points, 8.3 to 8.8 otherwise).

The measure saturates near 8-9 for windows ending below 1% (the band's edges leak the
record's start into its end, a floor near 1e-4 of its power): it tells a window from none
and sizes a weak one, and the statistics take the window of that decay
(:mod:`~sdctrl.identification._pole_statistics`).  Only the rules and the statistics
follow: the damping is not corrected (the decay is the noise's, not necessarily a
window's), and the report says how to give the window.

Internal module: the functions trust their inputs.
"""

from __future__ import annotations

import numpy as np

from sdctrl.identification._trial_correlation import uniform_grid

__all__ = ["DECAY_LIMIT", "MIN_COLUMNS", "MIN_LINES", "SPREAD", "STRUCTURE", "CorrelatedLines",
           "decay_message", "equivalent_tau", "residual_decay"]

#: slope of the residual's log power over the record above which the lines are correlated
DECAY_LIMIT = 2.0
#: fewest lines of a band for the measure (a shorter record has too few samples)
MIN_LINES = 64
#: fewest data columns for the measure
MIN_COLUMNS = 8
#: singular value (of the residual's record across the columns) over the median above
#: which a direction is the model's error, removed before the measure
STRUCTURE = 2.0
#: largest ratio of the remaining singular values for the remainder to be noise
SPREAD = 30.0
#: part of the record the slope is measured over (fractions of ``T``)
SPAN = (0.2, 0.9)


class CorrelatedLines(Exception):
    """Raised by a pass under the rules of independent lines when its starting residual
    decays over the record (:func:`residual_decay` above :data:`DECAY_LIMIT`): the
    identification starts again under the rules of windowed data.

    Parameters
    ----------
    decay : float
        The slope ``a`` measured (module notes).
    """

    def __init__(self, decay: float):
        super().__init__(f"residual decays over the record: {decay:.3g}")
        self.decay = float(decay)


def residual_decay(r: np.ndarray, freq: np.ndarray) -> float | None:
    """Slope ``a`` of the log power of the residual over the record (module notes).

    Parameters
    ----------
    r : ndarray, shape (2 nf, k)
        Stacked ``[Re; Im]`` residual of a fit.
    freq : ndarray, shape (nf,)
        Its lines (Hz); the measure needs them evenly spaced.

    Returns
    -------
    float or None
        ``a`` (``2 T / tau`` for noise through a window ``exp(-t/tau)``, about 0 for noise
        independent between lines); None with fewer than :data:`MIN_LINES` lines or
        :data:`MIN_COLUMNS` columns, uneven lines, a zero residual, or one that is not
        noise (module notes).
    """
    nf = r.shape[0] // 2
    if nf < MIN_LINES:
        return None
    if uniform_grid(freq, rtol=5e-4) is None:   # the record needs evenly spaced lines
        return None
    k = r.shape[1]
    if k < MIN_COLUMNS:
        return None
    x = np.fft.ifft(r[:nf] + 1j * r[nf:], axis=0)
    u, sv, vh = np.linalg.svd(x, full_matrices=False)
    q = int(np.count_nonzero(sv > STRUCTURE * np.median(sv)))   # the model's error
    if q > k // 2 or not sv[q] <= SPREAD * sv[-1]:
        return None                             # not a residual of noise
    x = x - (u[:, :q] * sv[:q]) @ vh[:q]
    power = np.abs(x) ** 2
    mean = power.mean(axis=0)
    live = mean > 0
    if not np.any(live):
        return None
    profile = np.median(power[:, live] / mean[live], axis=1)
    t = np.arange(nf) / nf
    span = (t > SPAN[0]) & (t < SPAN[1]) & (profile > 0)
    if np.count_nonzero(span) < 8:
        return None
    return float(-np.polyfit(t[span], np.log(profile[span]), 1)[0])


def equivalent_tau(decay: float, freq: np.ndarray) -> float:
    """Time constant (s) of the exponential window whose noise decays by ``decay`` over the
    record of the lines ``freq``: ``tau = 2 T / a``, ``T = 1/df`` (module notes)."""
    return 2.0 / (float(decay) * float(np.median(np.diff(freq))))


def decay_message(decay: float, freq: np.ndarray) -> str:
    """The report of rules chosen from the decay ``decay`` of the residual over the record of
    the lines ``freq`` (module notes): what was seen, the time constant of the window of the
    same decay (:func:`equivalent_tau`), what was done, and how to give the window."""
    T = 1.0 / float(np.median(np.diff(freq)))
    return (f"the residual decays over the record (noise power down x{np.exp(decay):.3g} "
            f"over T = 1/df = {T:.4g} s, as through an exponential window exp(-t/tau) with "
            f"tau = {equivalent_tau(decay, freq):.3g} s): the noise is correlated between "
            "lines, and the data were fitted with the rules of windowed data (one unweighted "
            "fit, no close-mode search); the damping is not corrected for a window: if the "
            "records were windowed, give its time constant (sd.FRF(..., exponential_tau=tau), "
            "or sd.impact_frf(..., exponential=...) which records it); the noise of a hammer "
            "test without a window can decay with the response too")
