"""Out-of-band test poles that give an appended FE mode its measured frequency (issue 22,
:mod:`sdctrl.hybrids._out_of_band`).

The ladder tested over 20-70 Hz without its shaker R8.y: its mode at 70.69 Hz lies just
above the band, barely excited by the two remaining shakers (participation 0.029 and 0.013
against 0.057 at R8.y); the identified model holds it as an out-of-band pole at 70.71 Hz.
The wrong FE has it at 62.90 Hz, inside the band, and ``kappa`` is 1: the hybrid appended a
mode at 62.9 Hz that the test does not have, and the untested shaker R8.y was predicted
only 9.05x better than the wrong FE (noise-free; 8.75x at 1%).  Zeroing that one appended
mode's input gave 14.3x.  With the pole's measured frequency: 20.5x (18.8x at 1%).

An out-of-band pole can also stand for several modes (3.7): ``truss_high`` over 20-60 Hz
at 1% noise fits its five modes at 12.7-18.6 Hz with three poles, and the one at 17.40 Hz
pairs with an FE mode at MAC 0.91; given that frequency the untested shaker fell from 19.7x
to 10.7x.  The rule (fit at the tested I/O *and* held-out prediction both better) keeps the
first and refuses the second; the figures are asserted below and the family's in
tests/test_family_hybrid.py.
"""

import dataclasses
import functools
import warnings

import numpy as np
import pytest

import sdctrl as sd
from sdctrl.updating import logls


@functools.cache
def _hybrid(name, band, noise, residual="auto"):
    """The member over ``band``, its hybrid without the last shaker, the truth and the wrong
    FE's logLS for that shaker."""
    st = dataclasses.replace(sd.testbeds.structure(name), band=band)
    SH, SE = list(st.shakers), list(st.sensors)
    frf = st.frf(n=400, noise=noise, seed=1).select(actuators=SH[:-1])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        nm = sd.normal_modes(sd.identify(frf, progress=False), std=False)
        h = sd.hybrid(st.wrong(), nm, SE, SH[:-1], residual=residual)
    return st, nm, h


def _shaker_ratio(st, h):
    SH, SE = list(st.shakers), list(st.sensors)
    freq = np.linspace(*st.band, 300)
    ref = st.fe().frf(freq, SH[-1:], SE, "acceleration").H
    e_fe = logls(st.wrong().frf(freq, SH[-1:], SE, "acceleration").H, ref)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return e_fe / logls(h.with_io(b=SH[-1:]).frf(freq, "acceleration").H, ref)


def _hz(h):
    return np.sqrt(np.clip(np.diag(h.Omega), 0, None)) / (2 * np.pi)


def _check_rule(h):
    """Each trial's decision is the rule's, from the scores it records."""
    for t in h.construction.out_of_band:
        nominal_better = t.nominal[1] < t.nominal[0]
        if not nominal_better:
            assert t.held_out is None and not t.kept
        else:
            assert t.kept == (t.held_out[1] < t.held_out[0])


@pytest.mark.parametrize("noise, locked", [(0.0, 20.46), (0.01, 18.84)])
def test_a_mode_just_above_the_band_gives_the_fe_mode_its_frequency(noise, locked):
    st, nm, h = _hybrid("ladder", (20.0, 70.0), noise)
    _check_rule(h)
    (t,) = h.construction.out_of_band
    assert t.kept and abs(t.pole_hz - 70.69) < 0.05 and abs(t.fe_hz - 62.90) < 0.01
    # the fit at the tested I/O 0.126 -> 0.045, held-out 0.179 -> 0.084 (noise-free)
    assert t.nominal[1] < 0.5 * t.nominal[0] and t.held_out[1] < 0.6 * t.held_out[0]
    hz = _hz(h)
    assert np.min(np.abs(hz - 70.7)) < 0.05 and np.min(np.abs(hz - 62.90)) > 1.0
    assert _shaker_ratio(st, h) >= max(12.0, locked / 1.1)          # 9.05x / 8.75x before


def test_without_auto_the_fe_mode_keeps_kappa():
    st, nm, h = _hybrid("ladder", (20.0, 70.0), 0.0, "tested")
    assert h.construction.out_of_band == ()
    assert np.min(np.abs(_hz(h) - 62.90)) < 0.01
    assert _shaker_ratio(st, h) < 10                                 # 9.05x


def test_a_pole_standing_for_several_modes_is_refused():
    st, nm, h = _hybrid("truss_high", (20.0, 60.0), 0.01)
    _check_rule(h)
    trials = {round(t.pole_hz, 1): t for t in h.construction.out_of_band}
    bad, good = trials[17.4], trials[63.0]
    # below the band: five modes at 12.7-18.6 Hz, three poles; 17.40 Hz pairs at MAC >= 0.8
    true_hz = st.fe().modes(8)[0]
    assert np.min(np.abs(true_hz - 17.40)) > 0.5
    assert not bad.kept and bad.nominal[1] > 1.3 * bad.nominal[0]   # 0.0276 -> 0.0435
    assert good.kept and abs(good.pole_hz - 62.98) < 0.05
    assert _shaker_ratio(st, h) >= 19.69 / 1.1                       # 19.69x -> 20.9x
