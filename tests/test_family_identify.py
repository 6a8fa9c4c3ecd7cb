"""Identification over the family of test structures (issue 22), locked per member and noise
level so that no change trades one structure for another: the number of in-band modes found
against the true structure's, and the mean logLS of the identified model against the exact
(noise-free) response.  The issue's targets (within 2x the noise floor; noise-free <= 0.01)
are asserted where met; the gap is the open identification part of issue 22 (the cluster's
weakest blade mode at 1% noise).

The noise floor: no figure of this file is the data's own floor, logLS(exact, noisy) = 5e-5
at 1% (``E ln^2|1 + 0.01 e| = 0.01^2/2``, every member); the floor of the estimator is the
logLS (against the exact response) of the least-squares residues fitted to the noisy data
at the exact poles within a factor 4 of the band edges, seeds 1/2/3: truss 0.0024/0.0014/
0.0014, truss_high 0.0007/0.0004/0.0005, ladder 0.0011/0.0014/0.0016, plate 0.0003/0.0003/
0.0002, cluster 0.017/0.019/0.018 (identified: 0.5-4.7x that floor; the cluster 17x).
The cluster at 1% (0.30): without the 10.151 Hz blade mode the exact-pole fit gives 0.10,
with the identified in-band poles and the exact out-of-band ones 0.12, both 0.03: the weak
mode and the out-of-band modes above the band (68-75 Hz, found noise-free) are missed.
Both are far above the noise on their own channels (the blade mode 600x at its peak,
damping 0.00263 +- 0.00068 at the exact poles) but not in the unweighted cost the
significance test measures: held at its exact pole it lowers the cost by 60% and scores
0.06x its threshold, whose noise is that of the loudest channels at the cluster's peak.
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
#: (identification/_zoom.py); before: 3 modes / 1.2651 noise-free, 1 / 1.6672 at 1%.  Seeds 2
#: and 3 at 1% (not locked here): 4 modes, 0.33 / 0.31 since the last pole of a window with
#: modes is held and the scan meets the second-difference field (before: 1 mode, 1.69 / 1.67)
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
