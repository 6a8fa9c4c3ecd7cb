"""Where a missing mode may lie: the band rules of :func:`sdctrl.diagnose` (issue 23).

A missing mode (a free extra mode, 3.7, or a resonator on a physical load path) is a mode
when its peak and half-power points lie inside the band (:func:`in_band`).  A heavily damped
one (above :data:`TREND_DAMPING`) that does not resonate inside the band is a broadband
trend of the model's error -- the tail of what lies outside the band, a residual the other
effects leave -- and is never proposed as a mode (:func:`trend`); the residual terms and the
physical effects carry what it stood for.  Lightly damped modes near a band edge are kept:
their peak is in the data.
"""

from __future__ import annotations

__all__ = ["TREND_DAMPING", "in_band", "trend"]

#: a missing mode damped above this must resonate inside the band (else a trend)
TREND_DAMPING = 0.1


def in_band(p, freq, action: str = "mode") -> bool:
    """Whether proposal ``p`` (of ``action``: a free mode by default) has its peak and
    half-power points ``f (1 +- zeta)`` inside the band ``freq[0] .. freq[-1]`` (Hz).

    Parameters
    ----------
    p : dict
        A proposal with ``"frequency"`` and ``"damping"`` parameters.
    freq : ndarray
        The data's lines (Hz).
    action : str
        The proposal action that counts.

    Returns
    -------
    bool
    """
    if p["action"] != action:
        return False
    f, z = p["parameters"]["frequency"], p["parameters"]["damping"]
    return bool(freq[0] <= f * (1 - z) and f * (1 + z) <= freq[-1])


def trend(p, freq) -> bool:
    """Whether proposal ``p`` is a missing mode (free or resonator) damped above
    :data:`TREND_DAMPING` whose resonance is not inside the band (module notes).

    Parameters
    ----------
    p : dict
        A proposal.
    freq : ndarray
        The data's lines (Hz).

    Returns
    -------
    bool
    """
    return (p["kind"] == "missing_mode" and p["parameters"]["damping"] > TREND_DAMPING
            and not in_band(p, freq, p["action"]))
