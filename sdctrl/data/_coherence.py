"""Whether an FRF's coherence measures its noise.

One rule for every step that reads a noise level from the coherence (identification's
point variance and quality floor, the FE update's error level and statistics): a coherence
that is one up to round-off at every line is no measurement of noise.
"""
from __future__ import annotations

import numpy as np

__all__ = ["EXACT_COHERENCE", "measured_coherence"]

#: ``1 - coherence`` at or below which a coherence is one up to round-off (a signal-to-noise
#: ratio of 100 dB at every line, beyond any measurement; noise-free simulations: 1e-16)
EXACT_COHERENCE = 1e-10


def measured_coherence(data):
    """``data.coherence`` when it measures the noise, else None: without a coherence, or when
    every line's is one up to round-off (``1 - coherence <=`` :data:`EXACT_COHERENCE`: one
    record, or a noise-free simulation through :func:`~sdctrl.impact_frf`, 1e-16 to 1e-15
    below one).  A coherence of round-off made the point variance round-off too: the
    significance test found no mode in noise-free surveys (ladder: "no mode found") and the
    FE update reported its parameters exact to 1e-8 of their value."""
    coh = data.coherence
    if coh is None or not np.any(coh < 1.0 - EXACT_COHERENCE):
        return None
    return coh
