"""Identification over the family of test structures (issue 22), locked per member and noise
level so that no change trades one structure for another: the number of in-band modes found
against the true structure's, and the mean logLS of the identified model against the exact
(noise-free) response.  The issue's targets (within 2x the noise floor; noise-free <= 0.01)
are asserted where met; the gap is the open identification part of issue 22 (the cluster's
weakest blade mode at 1% noise).
"""

import warnings

import numpy as np
import pytest

import sdctrl as sd
from sdctrl.updating import logls

#: (in-band modes found, logLS vs the exact data) measured (seed 1, 400 lines): out-of-band
#: poles are added while significant against the noise of the data (second differences,
#: corrected for the lines' correlation when the FRF was windowed).  Before that change:
#: truss_high 0.2422 / 0.2392, ladder 0.0371 / 0.0371, plate at 1% 0.1015 (one pole per side).
#: The cluster's close modes are found by the local rank of the data and a zoomed LSCF
#: (identification/_zoom.py); before: 3 modes / 1.2651 noise-free, 1 / 1.6672 at 1%
MEASURED = {
    ("truss", 0.0): (12, 0.0043), ("truss", 0.01): (12, 0.0056),
    ("truss_high", 0.0): (6, 2e-5), ("truss_high", 0.01): (6, 0.0009),
    ("ladder", 0.0): (12, 2e-5), ("ladder", 0.01): (12, 0.0011),
    ("plate", 0.0): (5, 0.0007), ("plate", 0.01): (5, 0.0008),
    ("cluster", 0.0): (5, 0.0001), ("cluster", 0.01): (4, 0.3025),
}
#: members meeting the noise-free target (<= 0.01)
NOISE_FREE_OK = {"truss", "truss_high", "ladder", "plate", "cluster"}


def _true_in_band(st) -> int:
    f, _ = st.fe().modes(40)
    return int(np.sum((f > st.band[0]) & (f < st.band[1])))


@pytest.mark.parametrize("name,noise", sorted(MEASURED))
def test_identification_locked_per_member(name, noise):
    st = sd.testbeds.structure(name)
    exact = st.frf(n=400)
    frf = st.frf(n=400, noise=noise, seed=1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cm = sd.identify(frf, progress=False)
    err = logls(cm.frf(frf.freq, quantity=frf.quantity).H, exact)
    found, ref = MEASURED[name, noise]
    print(f"\n{name} {noise}: {int(cm.in_band.sum())} in-band modes (true "
          f"{_true_in_band(st)}), logLS {err:.4g}")
    assert int(cm.in_band.sum()) >= found
    assert int(cm.in_band.sum()) <= _true_in_band(st)          # no spurious in-band mode
    assert err <= 1.5 * ref + 1e-4
    if noise == 0.0 and name in NOISE_FREE_OK:
        assert err <= 0.01
