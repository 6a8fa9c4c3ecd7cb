"""Hybrid models over the family of test structures (issue 22), noise-free and 1% noise: the
nominal hybrid against the identified normal-mode model at the tested I/O, and its
predictions (a D-strut, a broken strut, an untested shaker, the closed-loop band RMS of the
D-strut design) against the truth and the deliberately wrong FE model
(:mod:`family_struts`).  Each member's figures are locked (measured / 1.5 for the ratios,
x1.5 for the errors), so that no change trades one structure for another; the issue's
targets (nominal no worse than the normal-mode model, >= 12x, >= 3x, RMS within 2%) are
asserted where the member reaches them and the gap is stated where it does not.
"""

import warnings

import numpy as np
import pytest

import sdctrl as sd
from family_struts import figures

#: measured figures per (member, noise): logLS of the nominal hybrid and of the identified
#: normal-mode model at the tested I/O; wrong-FE/hybrid logLS ratios of a D-strut, a broken
#: strut and an untested shaker; relative error of the D-strut design's closed-loop band RMS
#: by the hybrid and by the wrong FE (seed 1, 400 lines; normal modes keep the out-of-band
#: poles as residual dynamics)
MEASURED = {
    ('truss', 0.0): (0.01133, 0.0076, 128.57656, 7.81307, 24.94447, 0.01902, 0.0473),
    ('truss', 0.01): (0.0166, 0.01354, 106.61014, 7.76822, 23.78858, 0.01884, 0.0473),
    ('truss_high', 0.0): (0.02616, 0.00276, 56.60995, 5.32691, 20.18824, 0.02952, 0.11467),
    ('truss_high', 0.01): (0.0282, 0.00405, 54.68706, 5.28571, 19.43794, 0.02933, 0.11467),
    ('ladder', 0.0): (0.1648, 0.01135, 9.4335, 7.65944, 4.76665, 0.00851, 0.04428),
    ('ladder', 0.01): (0.1692, 0.01248, 9.18804, 7.52409, 4.8667, 0.00904, 0.04428),
    ('plate', 0.0): (0.02964, 0.00476, 33.93653, 9.33186, 34.48008, 0.00062, 0.02547),
    ('plate', 0.01): (0.03113, 0.00459, 31.80485, 9.16996, 33.46086, 0.00087, 0.02547),
    ('cluster', 0.0): (0.53273, 1.01652, 0.39805, 0.41418, 0.06656, 0.00067, 0.11131),
    ('cluster', 0.01): (0.4907, 1.66461, 0.43176, 0.45138, 0.10395, 0.46818, 0.11131),
}
#: where each member stands against the issue's targets (asserted where met; the gaps, locked
#: above, are the open part of issue 22): the nominal hybrid is above the normal-mode model
#: on every member but the cluster (its FE modes stand in for the out-of-band poles the
#: normal-mode model keeps as identified residual dynamics); the D-strut is short of 12x on
#: the ladder (9.4x), the untested shaker on the ladder (4.8x), truss_high's RMS error (2.9%)
#: short of 2%; the cluster's identification misses blade modes (400 lines, 0.1 Hz apart for
#: modes 0.04-0.06 Hz apart).  Since identification adds out-of-band poles while they are
#: significant, truss_high's D-strut went from 9.1x to 56.6x (nominal 0.265 -> 0.026)
TARGETS = {
    "dstrut": {"truss", "truss_high", "plate"},
    "broken": {"truss", "truss_high", "ladder", "plate"},
    "shaker": {"truss", "truss_high", "plate"},
    "rms": {"truss", "ladder", "plate"},
}


def _build(name, noise):
    st = sd.testbeds.structure(name)
    SH, SE = list(st.shakers), list(st.sensors)
    frf = st.frf(n=400, noise=noise, seed=1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        nm = sd.normal_modes(sd.identify(frf, progress=False), std=False)
        nm_minus = sd.normal_modes(sd.identify(frf.select(actuators=SH[:-1]), progress=False),
                                   std=False)
        h = sd.hybrid(st.wrong(), nm, SE, SH)
        h_minus = sd.hybrid(st.wrong(), nm_minus, SE, SH[:-1])
    return st, nm, h, h_minus


@pytest.mark.parametrize("noise", [0.0, 0.01])
@pytest.mark.parametrize("name", sd.testbeds.family())
def test_hybrid_predictions_locked_per_member(name, noise):
    st, nm, h, h_minus = _build(name, noise)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        got = figures(st, nm, h, h_minus)
    print(f"\n{name} {noise}: {got}")
    ref = MEASURED[(name, noise)]
    if name in TARGETS["dstrut"]:
        assert got.dstrut >= 12
    if name in TARGETS["broken"]:
        assert got.broken >= 3
    if name in TARGETS["shaker"]:
        assert got.shaker >= 12
    if name in TARGETS["rms"]:
        assert got.rms_hybrid <= 0.02 and got.rms_fe > got.rms_hybrid
    assert got.nominal <= 1.5 * ref[0] + 1e-4
    assert got.dstrut >= ref[2] / 1.5 and got.broken >= ref[3] / 1.5
    assert got.shaker >= ref[4] / 1.5
    assert got.rms_hybrid <= 1.5 * ref[5] + 1e-3
