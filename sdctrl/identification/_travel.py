"""Heavily damped in-band modes in the automatic pole selection (3.2.1).

Two rules of :class:`~sdctrl.identification._selection.AutoSelection` that a lightly damped
testbed never meets, and a structure with a damper does (a mode at 10% damping, as a
D-strut makes them):

- **travel**: an in-band pole is searched near its guess (the thesis's "only allowing
  solutions near the guess", within a few half-power bandwidths, :func:`_search._bounds`).
  When the fit pushes it to that neighbourhood's bound, it is standing for something
  farther away -- typically a broad mode nobody proposed (no peak in the indicator
  functions), which then pulls the nearest lightly damped pole off its own peak.  Instead
  of dropping the pole, it is searched alone (the others fixed) from where it was pushed,
  each hop with the neighbourhood of its new position, at most :data:`HOPS` times; if it
  settles inside its bounds, the whole set is refitted from there (the mode it left is
  proposed again by the residual scan once the broad one is fitted).  Each place is tried
  once;
- **the strongest candidate alone**: the residual scan proposes its candidates together
  (:mod:`~sdctrl.identification._missed_scan`); the broad residual of a heavily damped mode
  nobody fitted yields several broad candidates, which, fitted together, pull one another
  to their bounds, and the batch is rejected.  When the strongest candidate is at the
  scan's damping cap (:data:`~sdctrl.identification._missed_scan.ZETA_CAP`: the residual
  is broader than any trial), it is fitted alone, once per place (to the line spacing)
  over the selection.  On a held-out structure's 2-shaker test at 1% noise, a 10% mode at
  33.65 Hz was missed at seeds 1 and 3 (logLS against the exact response 0.25 / 0.26),
  found alone (33.50 Hz 11.0%, 33.70 Hz 10.3%; 0.12 / 0.043); every family member's
  identification unchanged.  Without the cap condition, the cluster tested by one shaker
  (seed 3) had a narrower candidate fitted alone: a fifth pole of 1.4% damping between two
  of its close modes, logLS 0.041 -> 0.048.  The pole kept alone must have its resonance
  ``f (1 +- 2 zeta)`` inside the band (a broad mode of the band, as for heavily damped
  modes below): a lone broad pole straddling the band edge stands for a misfit, not a mode
  (a single-mode FRF that no real system gives, ``1j H``, gained one at 7.2 Hz, 19%);
- **heavily damped modes are not fillers**: an in-band pole with a damping above
  ``zeta_max`` is a filler (it soaks up the tails of modes outside the band) unless its
  resonance lies inside the band, ``f (1 +- 2 zeta)`` within the band edges, with a
  damping up to :data:`HEAVY_MAX`.
- **no scan twice from one pole set** (:func:`scanned`): a residual-scan pole kept and then
  pruned again (it converged to the band edge, the far bound of its search) brings the
  selection back to the pole set it started from, where the scan would propose it again
  (its rejection is forgotten when a pole is kept: the model changed).  From a pole set
  already scanned, the search ends: the scan would propose what it proposed there, and
  the close-mode search ran there when the scan had nothing (once per set of in-band
  poles).  On the truss at 1% noise, line-weighted (seed 1), a residual peak at the 60 Hz
  edge was added and removed ten times until the 20-round cap warned.  Running the
  close-mode search on such a return instead added 14 spurious in-band poles (101-143 Hz,
  30 poles for 16 modes) to the unweighted fit of a held-out roving-hammer survey read
  from a UFF file (its exponential window not recorded), which had ended at the 16 modes.

Internal module: the functions trust their inputs.
"""

from __future__ import annotations

import numpy as np

from sdctrl.identification._missed_scan import ZETA_CAP

__all__ = ["HEAVY_MAX", "HOPS", "alone", "filler", "scanned", "travel"]

#: most hops of a pole searched alone from the bound it was pushed to
HOPS = 3
#: largest damping ratio of an in-band mode whose resonance lies inside the band
HEAVY_MAX = 0.3


def filler(f: float, z: float, fband, zeta_max: float) -> bool:
    """Whether an in-band pole ``(f Hz, z)`` is a filler: damping above ``zeta_max`` and
    its resonance ``f (1 +- 2 z)`` not inside ``fband``, or damping above
    :data:`HEAVY_MAX`."""
    if z <= zeta_max:
        return False
    return not (_inside(f, z, fband) and z <= HEAVY_MAX)


def _inside(f: float, z: float, fband) -> bool:
    """Whether the resonance ``f (1 +- 2 z)`` of a pole ``(f Hz, z)`` lies inside ``fband``."""
    return f * (1 - 2 * z) >= fband[0] and f * (1 + 2 * z) <= fband[1]


def travel(sel, state):
    """The state after the in-band poles pushed to a bound were searched alone from there
    (module notes), or None when none moved inside its bounds.

    Parameters
    ----------
    sel : AutoSelection
        The selection (its ``fit``, ``_first_fit``, ``log`` and ``travelled`` places).
    state : tuple
        ``(w, z, side, ev, info)`` of the last fit.

    Returns
    -------
    tuple or None
    """
    w, z, side, _ev, info = state
    at = np.asarray(info.get("at_bound", np.zeros(w.size, bool)), bool) & (side == 0) & \
        (z <= HEAVY_MAX)                      # heavier: a filler wherever it goes
    todo = [j for j in np.flatnonzero(at) if _place(sel, w[j]) not in sel.travelled]
    if not todo:
        return None
    w2, z2, moved = w.copy(), z.copy(), False
    for j in todo:
        sel.travelled.add(_place(sel, w[j]))
        for _ in range(HOPS):
            w2, z2, _e, pinfo = sel.fit(w2, z2, side, only=[j])
            if not pinfo["at_bound"][j]:
                break
        settled = not pinfo["at_bound"][j]
        sel.log.append(("travelled", float(w[j] / (2 * np.pi)), float(z[j]),
                        float(w2[j] / (2 * np.pi)), float(z2[j]), settled))
        if not settled:                       # back where the full fit left it
            w2[j], z2[j] = w[j], z[j]
        moved = moved or settled
    return sel._first_fit(w2, z2, side) if moved else None


def alone(sel, state, cand):
    """The state after the residual scan's candidates ``cand`` (strongest first) were
    fitted together, or else the strongest alone when at the scan's damping cap (module
    notes); None when none is kept.

    Parameters
    ----------
    sel : AutoSelection
        The selection (its ``_add_missed``, ``df`` and ``alone`` places).
    state : tuple
        ``(w, z, side, ev, info)`` of the last fit.
    cand : list of (float, float)
        ``(frequency Hz, damping)`` of the candidates.

    Returns
    -------
    tuple or None
    """
    if not cand:
        return None
    new = sel._add_missed(state, cand)
    place = int(round(cand[0][0] / sel.df))
    broad = cand[0][1] >= ZETA_CAP * (1 - 1e-9)
    if new is None and len(cand) > 1 and broad and place not in sel.alone:
        sel.alone.add(place)
        new = sel._add_missed(state, cand[:1], "residual peak (alone)")
        _, f, z, _why = sel.log[-1] if new is not None else (None,) * 4
        if new is not None and not _inside(f, z, sel.fband):     # a broad mode of the band
            sel.log.append(("removed", f, z, "alone: its resonance is not inside the band"))
            new = None
    return new


def _place(sel, w: float) -> int:
    """A pole's place, to the line spacing."""
    return int(round(w / (2 * np.pi) / sel.df))


def scanned(sel, state, cand):
    """The state after the residual scan's candidates (:func:`alone`) or, failing them,
    the close modes (``sel._close_modes``); None when nothing is kept, or when the
    selection stood at this pole set before (module notes)."""
    key = tuple(sorted(zip(np.round(state[0] / (2 * np.pi) / sel.df, 1).tolist(),
                           state[2].tolist())))
    if key in sel.scanned_from:
        return None
    sel.scanned_from.add(key)
    return alone(sel, state, cand) or sel._close_modes(state)
