"""Hybrid models over the family of test structures (issue 22), noise-free and 1% noise: the
nominal hybrid against the identified normal-mode model at the tested I/O, and its
predictions (a D-strut, a broken strut, an untested shaker, the closed-loop band RMS of the
D-strut design) against the truth and the deliberately wrong FE model
(:mod:`family_struts`).  Each member's figures are locked (measured / 1.5 for the ratios,
x1.5 for the errors), so that no change trades one structure for another; the issue's
targets (nominal no worse than the normal-mode model, >= 12x, >= 3x, RMS within 2%) are
asserted where the member reaches them and the gap is stated where it does not.  Both
treatments of the tested I/O are locked: the default (``residual="identified"``: FE modes
and fitted residual terms) and ``residual="tested"`` (the test's own residual dynamics, E
and F kept there).
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
#: poles as residual dynamics; FE/test pairing within a factor 2 in frequency)
MEASURED = {
    ('truss', 0.0): (0.01133, 0.0076, 128.58, 7.81, 24.94, 0.0190, 0.0473),
    ('truss', 0.01): (0.0166, 0.01354, 106.61, 7.77, 23.79, 0.0188, 0.0473),
    ('truss_high', 0.0): (0.02616, 0.00276, 56.61, 5.33, 20.19, 0.0295, 0.1147),
    ('truss_high', 0.01): (0.0282, 0.00405, 54.69, 5.29, 19.44, 0.0293, 0.1147),
    ('ladder', 0.0): (0.01606, 0.01135, 96.89, 30.96, 43.51, 0.0001, 0.0443),
    ('ladder', 0.01): (0.0173, 0.01248, 89.83, 30.30, 27.18, 0.0002, 0.0443),
    ('plate', 0.0): (0.02964, 0.00476, 33.94, 9.33, 34.48, 0.0006, 0.0255),
    ('plate', 0.01): (0.03113, 0.00459, 31.80, 9.17, 33.46, 0.0009, 0.0255),
    # the cluster since identification finds its close blade modes (before: noise-free
    # 0.533, 1.017, 0.40, 0.41, 0.07, 0.0007; 1%: 0.491, 1.665, 0.43, 0.45, 0.10, 0.468)
    ('cluster', 0.0): (0.02231, 0.01062, 9.53, 7.55, 0.08, 0.0002, 0.1113),
    ('cluster', 0.01): (0.9181, 0.84857, 0.23, 0.24, 0.10, 0.0030, 0.1113),
}
#: the same figures with ``residual="tested"`` (the test's residual dynamics, E and F kept
#: at the tested I/O, :mod:`sdctrl.hybrids._tested_io`)
MEASURED_TESTED = {
    ('truss', 0.0): (0.00755, 0.0076, 127.75, 7.41, 24.94, 0.0163, 0.0473),
    ('truss', 0.01): (0.0135, 0.01354, 112.05, 7.34, 23.79, 0.0162, 0.0473),
    ('truss_high', 0.0): (0.00276, 0.00276, 130.64, 5.34, 20.19, 0.0252, 0.1147),
    ('truss_high', 0.01): (0.0041, 0.00405, 123.38, 5.31, 19.44, 0.0251, 0.1147),
    ('ladder', 0.0): (0.01122, 0.01135, 138.58, 34.24, 43.51, 0.0000, 0.0443),
    ('ladder', 0.01): (0.01248, 0.01248, 124.60, 33.70, 27.18, 0.0002, 0.0443),
    ('plate', 0.0): (0.00481, 0.00476, 202.35, 12.52, 34.48, 0.0001, 0.0255),
    ('plate', 0.01): (0.00463, 0.00459, 210.39, 12.48, 33.46, 0.0001, 0.0255),
    ('cluster', 0.0): (0.00932, 0.01062, 22.86, 21.59, 0.08, 0.0003, 0.1113),
    ('cluster', 0.01): (0.8485, 0.84857, 0.25, 0.26, 0.10, 0.0026, 0.1113),
}
#: where each member stands against the issue's targets (asserted where met; the gaps, locked
#: above, are the open part of issue 22).  Default hybrid: the nominal hybrid is above the
#: normal-mode model on every member but the cluster (1.4x-10x: its FE modes stand in for
#: the out-of-band poles the normal-mode model keeps as identified residual dynamics);
#: truss_high's RMS error (2.9%) short of 2%.  Since the FE/test pairing stays within a
#: factor 2 in frequency, the ladder's D-strut went from 9.4x to 96.9x and its shaker from
#: 4.8x to 43.5x (its 48.3 Hz test mode had been paired with a 246 Hz FE mode, MAC 0.63,
#: leaving its own FE mode appended in band).  The cluster: since identification finds its
#: close blade modes, noise-free D-strut 0.40x -> 9.5x, broken 0.41x -> 7.6x, RMS error
#: 0.07% -> 0.02%; at 1% it still misses one blade mode (10.151 Hz): RMS error 47% -> 0.3%
#: but D-strut 0.43x -> 0.23x, nominal 0.49 -> 0.92 -- locked as they come; the untested
#: shaker 0.08x/0.10x either way
TARGETS = {
    "dstrut": {"truss", "truss_high", "ladder", "plate"},
    "broken": {"truss", "truss_high", "ladder", "plate"},
    "shaker": {"truss", "truss_high", "ladder", "plate"},
    "rms": {"truss", "ladder", "plate"},
}
#: ``residual="tested"``: the nominal hybrid within 2% of the normal-mode model's logLS
#: (the test's E carried by a term 30x above the band: <= 0.8% of E) where the targets
#: above hold, truss_high's RMS error 2.5% (the strut's added damping of the 52.9 Hz mode
#: over-predicted: 0.0090 against 0.0082, the expanded shape's strain at the bar)
NOMINAL = {"truss", "truss_high", "ladder", "plate"}


def _build(name, noise):
    st = sd.testbeds.structure(name)
    SH, SE = list(st.shakers), list(st.sensors)
    frf = st.frf(n=400, noise=noise, seed=1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        nm = sd.normal_modes(sd.identify(frf, progress=False), std=False)
        nm_minus = sd.normal_modes(sd.identify(frf.select(actuators=SH[:-1]), progress=False),
                                   std=False)
        pairs = {res: (sd.hybrid(st.wrong(), nm, SE, SH, residual=res),
                       sd.hybrid(st.wrong(), nm_minus, SE, SH[:-1], residual=res))
                 for res in ("identified", "tested")}
    return st, nm, pairs


def _check(got, ref, name, targets):
    if name in targets["dstrut"]:
        assert got.dstrut >= 12
    if name in targets["broken"]:
        assert got.broken >= 3
    if name in targets["shaker"]:
        assert got.shaker >= 12
    if name in targets["rms"]:
        assert got.rms_hybrid <= 0.02 and got.rms_fe > got.rms_hybrid
    assert got.nominal <= 1.5 * ref[0] + 1e-4
    assert got.dstrut >= ref[2] / 1.5 and got.broken >= ref[3] / 1.5
    assert got.shaker >= ref[4] / 1.5
    assert got.rms_hybrid <= 1.5 * ref[5] + 1e-3


@pytest.mark.parametrize("noise", [0.0, 0.01])
@pytest.mark.parametrize("name", sd.testbeds.family())
def test_hybrid_predictions_locked_per_member(name, noise):
    st, nm, pairs = _build(name, noise)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        got = figures(st, nm, *pairs["identified"])
        tested = figures(st, nm, *pairs["tested"])
    print(f"\n{name} {noise}: {got}\n  tested: {tested}")
    _check(got, MEASURED[(name, noise)], name, TARGETS)
    _check(tested, MEASURED_TESTED[(name, noise)], name, TARGETS)
    if name in NOMINAL:                              # no worse than the normal-mode model
        # 1e-4: the floor of the E term carried 30x above the band (the nominal hybrid was
        # 1.3e-4 below the normal-mode model on the ladder, 0.01122 against 0.01135); with the
        # improper parts kept in nm.residual (issue 22) nm reaches 3e-11 / 0.0018 (ladder)
        # and 0.0014 (plate 1%), the hybrid 3.6e-5 / 0.0019 and 0.0015
        assert tested.nominal <= 1.02 * tested.nm + 1e-4
        assert got.nominal > tested.nominal           # the default's gap, stated above
    h = pairs["tested"][0]
    # the tested I/O keeps the test: nm's residual dynamics bit for bit, E, F
    if nm.residual is not None:
        m = nm.residual.m
        assert np.array_equal(h.residual.poles[:m], nm.residual.poles)
        assert np.array_equal(h.residual.residues[:m], nm.residual.residues)
    assert (h.F is None) == (nm.F is None) and h.E is None
    assert np.all(h.cphi[:, ~h.measured] == 0)
