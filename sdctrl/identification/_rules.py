"""The rules of the automatic pole selection, chosen once from the data (thesis 3.2.1).

Two kinds of FRF call for different rules, and the data say which they are:

* noise independent from line to line (simulated or averaged tests, H1 estimates without
  an exponential window): out-of-band poles are searched on a grid of starting
  frequencies, several per side while each is significant against the noise field of
  second differences (the smooth tails of modes beyond the band are no noise), and kept
  at a damping bound (they carry a tail no line resolves); a rejected candidate is
  retried once the model has changed; close modes are looked for by the local rank of
  the data (3.20)-(3.22, :mod:`~sdctrl.identification._zoom`) and the last pole of a
  window where the data show modes is not removed as insignificant (a pole standing for
  several close modes meets their residual as noise); every test meets the lower,
  second-difference, noise field whenever the data show noise independent between
  lines (the residual of unfitted modes, smooth over the lines, is no noise); poles the
  last fit pushed to a bound are dropped at the end;
* an FRF measured through an exponential window (``frf.exponential_tau``) has noise
  correlated between lines (``c_k = 1/(1 + i pi k tau df)``, 0.8 between neighbours on a
  hammer survey), which second differences and a local rank take for signal (a simulated
  roving-hammer survey's band filled with poles, 20 for 6): there the residual scan
  meets the direct noise field only, one out-of-band pole per side is tried, started at
  the band edge and judged against the direct noise field (tried again once the pole set
  has changed: a side tried before the other side's mode was fitted meets that mode's tail;
  the plate survey's 18.76 Hz mode below its 20 Hz edge was left to ``F``, fit 0.89% ->
  0.072%), a pole at any bound or
  narrower than the lines out of band is rejected, every candidate is tried once, and
  the exact-fit floor is higher (``1e-11``); a pole's significance meets the lower of the
  direct field and that of second differences divided by their gain for the window's
  correlation (:func:`~sdctrl.identification._line_correlation.difference_gain`, 1.24
  instead of 6 for a window ending at 1%): a residual smooth over the lines is no noise.
  Against the direct field alone, the smooth misfit a removed pole leaves across the band
  raised the noise at the other poles, and the pruning cascaded (real hammer data,
  100-5000 Hz: 810 Hz at 9.4 times its threshold with 19 poles, 0.99 with 16, removed; 15
  poles, fit error 5.8%, 7.8 times the coherence's floor; now 22 poles, 1.08%).

Data that do not record a window may still have lines correlated: the residual of the
selection's start then decays over the record (:mod:`~sdctrl.identification.
_residual_decay`), and the identification starts again under the rules of windowed data
(:func:`correlated_rules`; a family survey with its window dropped: 88 in-band poles for 6
under the rules of independent lines, 6 under these).

:func:`selection_rules` makes the choice from the FRF; the record carries one field per
rule so that the selection code reads what it applies, not why.

Internal module: the functions trust their inputs (validated by ``identify``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from sdctrl.identification._line_correlation import (
    decay_correlation, difference_gain, line_correlation)

__all__ = ["SelectionRules", "correlated_rules", "selection_rules", "stop_message"]


@dataclass(frozen=True, eq=False)
class SelectionRules:
    """Rules of :class:`~sdctrl.identification._selection.AutoSelection` (module notes).

    Parameters
    ----------
    floor : float
        Cost (relative to the data's squared norm) below which a fit is numerically exact.
    oob_search : bool
        Out-of-band poles: several per side from a grid of starting frequencies, judged
        against the second-difference noise field and kept at a damping bound (True); or
        one per side from the band edge, the direct field, rejected at any bound or when
        narrower than the lines (False).
    retry_rejected : bool
        A rejected candidate frequency is tried again once the model has changed.
    close_modes : bool
        Look for close modes by the local rank of the data and a zoomed LSCF, and keep
        the last pole of a window where the data show modes.
    smooth_scan : bool
        Every test (significance, residual scan, zoom) meets the noise field of second
        differences (the lower of the two fields) when the data show noise independent
        between lines (:meth:`~sdctrl.identification._noise.NoiseTest.independent`: an
        FRF of windowed records may not record its window); else the direct field.
    final_prune : bool
        Drop, after the last fit, poles pushed to a bound.
    residual_decay : float or None
        For data without a recorded window whose starting residual decays over the record
        (:mod:`~sdctrl.identification._residual_decay`): the decay measured, which chose
        the rules of windowed data; None otherwise.
    significance_gain : float or None
        For noise correlated between lines: the gain of its second differences over one
        line (:func:`~sdctrl.identification._line_correlation.difference_gain`); a pole's
        significance then meets the lower of the direct field and that of the second
        differences divided by it.  None: the direct field (or, by ``smooth_scan``, the
        lower field of independent lines).
    """

    floor: float = 1e-13
    oob_search: bool = True
    retry_rejected: bool = True
    close_modes: bool = True
    smooth_scan: bool = True
    final_prune: bool = True
    residual_decay: float | None = None
    significance_gain: float | None = None


#: rules of data whose noise is independent between lines
INDEPENDENT = SelectionRules()
#: rules of data measured through an exponential window (noise correlated between lines)
WINDOWED = SelectionRules(floor=1e-11, oob_search=False, retry_rejected=False,
                          close_modes=False, smooth_scan=False, final_prune=False)


def selection_rules(frf) -> SelectionRules:
    """The rules for ``frf`` (module notes), from its record of an exponential window.

    Parameters
    ----------
    frf : FRF
        The data identified (``exponential_tau`` None or the window's time constant, s).

    Returns
    -------
    SelectionRules
    """
    if frf.exponential_tau is None:
        return INDEPENDENT
    rho = line_correlation(frf.freq, frf.exponential_tau)
    return WINDOWED if rho is None else replace(WINDOWED, significance_gain=difference_gain(rho))


def correlated_rules(decay: float) -> SelectionRules:
    """The rules of windowed data for data that do not record a window but whose starting
    residual decays over the record by ``decay`` (:mod:`~sdctrl.identification.
    _residual_decay`, :class:`~sdctrl.identification._residual_decay.CorrelatedLines`)."""
    return replace(WINDOWED, residual_decay=float(decay), significance_gain=_gain(decay))


def _gain(decay: float) -> float:
    """Gain of second differences over one line of noise decaying by ``decay`` over the
    record (``a = 2 T / tau``)."""
    return difference_gain(decay_correlation(float(decay), 3))


def stop_message(rounds: int, rules: SelectionRules) -> str:
    """What the selection says when it stops after ``rounds`` rounds still changing its poles,
    and what to try: a narrower band or ``poles=``; under the rules of independent lines,
    also the window of records taken through one that the FRF does not record (their
    correlated noise passes for modes, and the pruning never settles: the real hammer
    records of ``examples/data/impact_pyfrf`` without their window, 100-5000 Hz, 37 poles
    in 278 s)."""
    text = (f"automatic pole selection stopped after {rounds} rounds, still adding or removing "
            "poles: the model is its last fit; try band=(fmin, fmax) around the modes you "
            "need, or poles= for them")
    if rules.smooth_scan:
        text += ("; if the records were taken through an exponential window that the FRF "
                 "does not record, give it (sd.FRF(..., exponential_tau=tau)): noise "
                 "correlated between lines passes for modes under the rules of independent "
                 "lines")
    return text
