"""The automatic selection coming back to a pole set it already scanned ends there
(:func:`sdctrl.identification._travel.scanned`, module notes of ``_travel``).

Found on a held-out roving-hammer survey read from UFF (3 x 73 channels, 16 true modes in
10-150 Hz, its exponential window not recorded): a residual-scan pole kept, then pruned,
brought the selection back to a pole set it had scanned; running the close-mode search on
that return (the behaviour since the scan stopped repeating itself) added 28 candidates
and kept 14 spurious in-band poles in the unweighted fit, 30 in-band poles for 16 modes;
ending the search there gives the 16 modes, as the fit did before that change.  The
survey is outside the repository; these tests state the rule on a stand-in selection.
"""

from types import SimpleNamespace

import numpy as np

from sdctrl.identification._travel import scanned


def _selection():
    """A stand-in for :class:`~sdctrl.identification._selection.AutoSelection`: what
    :func:`scanned` reads and calls, with a record of the calls."""
    calls = []
    sel = SimpleNamespace(df=0.1, scanned_from=set(), alone=set(), log=[], calls=calls)
    sel._add_missed = lambda state, cand, reason="residual peak": calls.append(
        ("scan", reason)) or None
    sel._close_modes = lambda state: calls.append(("close modes",)) or ("closer", state)
    return sel


def _state(freqs_hz, sides):
    w = 2 * np.pi * np.asarray(freqs_hz, float)
    return (w, np.full(w.size, 0.01), np.asarray(sides, int), {}, {})


def test_first_visit_scans_then_looks_for_close_modes():
    sel = _selection()
    state = _state([10.0, 20.0, 200.0], [0, 0, 1])
    out = scanned(sel, state, [(15.0, 0.01)])
    assert sel.calls == [("scan", "residual peak"), ("close modes",)]
    assert out[0] == "closer"


def test_a_return_to_a_scanned_pole_set_ends_the_search():
    """The same in-band and out-of-band poles (to the line spacing): no scan, no close-mode
    search, None (the selection loop then ends)."""
    sel = _selection()
    scanned(sel, _state([10.0, 20.0, 200.0], [0, 0, 1]), [(15.0, 0.01)])
    sel.calls.clear()
    again = _state([10.004, 20.0, 200.0], [0, 0, 1])          # within a tenth of a line
    assert scanned(sel, again, [(15.0, 0.01)]) is None
    assert sel.calls == []


def test_another_pole_set_is_scanned_again():
    """A pole set that differs (a pole added, or the same frequency on the other side of
    the band) is new: scanned, and the close modes searched when the scan keeps nothing."""
    sel = _selection()
    scanned(sel, _state([10.0, 20.0], [0, 0]), [])
    for state in (_state([10.0, 20.0, 30.0], [0, 0, 0]), _state([10.0, 20.0], [0, 1])):
        sel.calls.clear()
        assert scanned(sel, state, [(15.0, 0.01)]) is not None
        assert sel.calls == [("scan", "residual peak"), ("close modes",)]
