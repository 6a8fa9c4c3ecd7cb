"""What the automatic selection says when it stops still changing its poles (thesis 3.2.1):
the model is its last fit, and what to try -- a narrower band, ``poles=``, and, under the
rules of independent lines, the window of records taken through one the FRF does not
record (the real hammer records of ``examples/data/impact_pyfrf`` without their window,
100-5000 Hz: 37 poles in 278 s, stopped after 20 rounds).  The stop is forced here by
allowing the loop one round."""

import warnings

import pytest

import sdctrl as sd
from sdctrl.identification import IdentificationWarning
from sdctrl.identification._selection import AutoSelection


@pytest.fixture
def one_round(monkeypatch):
    bar, rounds, pending = AutoSelection.run.__defaults__
    monkeypatch.setattr(AutoSelection.run, "__defaults__", (bar, 1, pending))


def _messages(frf):
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        sd.identify(frf, band=(8.0, 60.0), progress=False)
    return " ".join(str(w.message) for w in rec if issubclass(w.category, IdentificationWarning))


@pytest.mark.usefixtures("one_round")
def test_a_stopped_selection_says_what_to_try():
    frf = sd.testbed_frf(noise=0.01, seed=0, n=400)
    text = _messages(frf)
    assert "stopped after 1 rounds, still adding or removing poles" in text
    assert "band=(fmin, fmax)" in text and "poles=" in text
    assert "exponential_tau=tau" in text                      # independent lines' rules
    windowed = sd.FRF(frf.freq, frf.H, quantity=frf.quantity, sensors=frf.sensors,
                      actuators=frf.actuators, exponential_tau=1.0)
    text = _messages(windowed)
    assert "stopped after 1 rounds" in text and "poles=" in text
    assert "exponential_tau" not in text                       # its window is recorded


def test_the_default_loop_settles_on_the_testbed():
    """The same data with the default 20 rounds: the loop settles, nothing is said."""
    assert "stopped after" not in _messages(sd.testbed_frf(noise=0.01, seed=0, n=400))
