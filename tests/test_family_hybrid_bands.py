"""Hybrid predictions over bands the members are not built for (issue 22): the truss over
12-45 Hz, the ladder over 20-70 Hz, the plate over 25-58 Hz, ``truss_high`` over 30-70 Hz and
the cluster over 8-30 Hz, noise-free and 1% noise (seed 1, 400 lines, ``sd.identify`` and
``sd.hybrid`` defaults), with the figures of :mod:`family_struts` (D-strut, broken strut,
untested shaker, closed-loop band RMS) and the checks of tests/test_family_hybrid.py: the
issue's targets where the member reaches them, every figure locked (ratios at measured / 1.5,
errors at 1.5x measured + 1e-3).

The untested shakers of the ladder and of ``truss_high`` over these bands failed 12x before an
out-of-band test pole could give an appended FE mode its frequency
(:mod:`sdctrl.hybrids._out_of_band`): ladder 9.05 / 8.75x, ``truss_high`` 10.7 / 12.8x, plate
22.2 / 22.5x (noise-free / 1%).  The cluster's untested shaker stays far below 12x (0.06 /
0.10x): the blade modes' damping coupling that its test without the blade shaker cannot
measure (tests/test_family_hybrid.py, ``test_cluster_shaker_gap_what_carries_it``).
"""

import dataclasses
import functools
import warnings

import pytest

import sdctrl as sd
from family_struts import figures, identified_models

#: (member, band, noise): (nominal logLS, normal-mode model's, D-strut, broken strut,
#: untested shaker, RMS error of the hybrid), measured
MEASURED = {
    ("truss", (12.0, 45.0), 0.0): (0.00019, 0.000188, 518.3, 8.9, 14.48, 0.0131),
    ("truss", (12.0, 45.0), 0.01): (0.00462, 0.00455, 298.5, 9.4, 14.73, 0.0143),
    ("ladder", (20.0, 70.0), 0.0): (1.13e-05, 1.17e-05, 131370.4, 503.5, 20.46, 0.0),
    ("ladder", (20.0, 70.0), 0.01): (7.1e-05, 7.13e-05, 23946.1, 496.2, 18.84, 0.0001),
    ("plate", (25.0, 58.0), 0.0): (3.02e-05, 1.79e-05, 14589.2, 10.3, 48.87, 0.0),
    ("plate", (25.0, 58.0), 0.01): (4.32e-05, 4.54e-05, 12844.8, 10.2, 50.22, 0.0006),
    ("truss_high", (30.0, 70.0), 0.0): (0.000647, 0.00065, 145.1, 9.2, 13.66, 0.002),
    ("truss_high", (30.0, 70.0), 0.01): (0.00134, 0.00135, 145.8, 9.1, 17.49, 0.0019),
    ("cluster", (8.0, 30.0), 0.0): (0.000137, 0.000185, 1936.8, 35.2, 0.06, 0.0),
    ("cluster", (8.0, 30.0), 0.01): (2.76e-05, 1.69e-05, 8709.8, 47.9, 0.10, 0.0012),
}
#: where the untested shaker's 12x is not met (the open part of issue 22)
SHAKER_GAP = {"cluster"}


@functools.lru_cache(maxsize=None)
def _figures(name, band, noise):
    st = dataclasses.replace(sd.testbeds.structure(name), band=band)
    SH, SE = list(st.shakers), list(st.sensors)
    nm, nm_minus = identified_models(st, noise)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        h = sd.hybrid(st.wrong(), nm, SE, SH)
        h_minus = sd.hybrid(st.wrong(), nm_minus, SE, SH[:-1])
        return figures(st, nm, h, h_minus)


@pytest.mark.parametrize("name, band, noise", list(MEASURED))
def test_hybrid_predictions_on_other_bands(name, band, noise):
    got = _figures(name, band, noise)
    ref = MEASURED[(name, band, noise)]
    print(f"\n{name} {band} {noise}: {got}")
    assert got.nominal <= 1.02 * got.nm + 1e-4                 # no worse than nm
    assert got.dstrut >= 12 and got.broken >= 3
    assert got.rms_hybrid <= 0.02 and got.rms_hybrid < got.rms_fe
    if name not in SHAKER_GAP:
        assert got.shaker >= 12
    assert got.dstrut >= ref[2] / 1.5 and got.broken >= ref[3] / 1.5
    assert got.shaker >= ref[4] / 1.5
    assert got.rms_hybrid <= 1.5 * ref[5] + 1e-3
