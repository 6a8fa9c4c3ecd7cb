"""Identification over the family of test structures (issue 22), locked per member and noise
level so that no change trades one structure for another: the number of in-band modes found
against the true structure's, and the mean logLS of the identified model against the exact
(noise-free) response.  The issue's targets (within 2x the noise floor; noise-free <= 0.01)
are asserted where met (every member, noise-free and at 1%).

The noise floor: no figure of this file is the data's own floor, logLS(exact, noisy) = 5e-5
at 1% (``E ln^2|1 + 0.01 e| = 0.01^2/2``, every member); the floor of the estimator is the
logLS (against the exact response) of the least-squares residues fitted to the noisy data
at the exact poles within a factor 4 of the band edges, seeds 1/2/3: truss 0.0024/0.0014/
0.0014, truss_high 0.0007/0.0004/0.0005, ladder 0.0011/0.0014/0.0016, plate 0.0003/0.0003/
0.0002, cluster 0.017/0.019/0.018.  At seed 1 every member is within 2x its floor (the
truss since identify's default keeps its level-weighted fit: 2.4x -> 1.7x).
The cluster at 1% was 0.30 with 4 modes: its 10.151 Hz blade mode, seen on its own blade's
channels only, was lost three ways.  The pole search and the significance test summed the
channels unweighted (at its exact pole the mode scored 0.29x the pooled threshold, 156x on
its blade's channel), compression to 40 of the 44 channels mixed the loud channels' noise
into every column (there: 1.3x), and the direct noise field held the model's error (the
modes above the band not fitted yet): up to 10^4 times the noise on some channels, while
second differences measured it within 25%.  Each channel is now divided by its noise level
in the pole search (``identification._compression.channel_weights``) and in-band poles meet
the second-difference field when the noise is independent between lines.
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
#: modes is held and the scan meets the second-difference field (before: 1 mode, 1.69 / 1.67).
#: Since the pole search divides each channel by its noise level and in-band poles meet the
#: second-difference field when the noise is independent between lines: the cluster at 1%
#: finds its 5 modes, 0.0299 / 0.0295 / 0.0197 (seeds 1/2/3; before 4 modes, 0.30 / 0.33 /
#: 0.31); truss 1% 0.0056 -> 0.0057, truss_high 1% 0.0009 -> 0.0005, plate 1% 0.0008 ->
#: 0.0003; the ladder 1% 0.0011 -> 0.0019 (seeds 2/3: 0.0007 -> 0.0014, 0.0016 -> 0.0021,
#: within 1.0-1.7x its floor).  Noise-free data are not weighted (no measurable noise) and
#: keep their figures (weighted by their curvature, the ladder's went 2e-5 -> 0.0012).
#: Noise-free ladder 2e-5 -> 7.7e-4 (15 poles) since identification's own trust-region solver
#: and numpy QR (issue 27): an exact fit's pole pruning is decided by round-off, and main with
#: scipy's solver gave the same 15-pole figure on 11 of 24 copies perturbed by 1e-14 (this
#: code on 14 of 24); within the 0.01 asked.
#: Since a passive out-of-band term may be placed after the selection (one per side, held
#: where it fits best among the places where it is passive, identification/_far_terms.py):
#: every figure here unchanged (no term is kept on any member at seed 1); seeds 2/3 at 1%
#: unchanged but the ladder at seed 2, 0.0014 -> 0.00058 (tests/test_far_terms.py).  A
#: held-out structure with several modes below its band: 1% seeds 1/2/3 0.088 / 0.092 / 0.096
#: -> 0.088 / 0.044 / 0.040 (its floor 0.0127).  Terms searched freely (they settle at the
#: far bound with F or E cancelling them: negative residual mass at a collocated pair) gave
#: that structure 0.035 / 0.009 / 0.009 but lost on the realisation and in feedback loops
#: (tests/test_statistics_envelope.py), and were not kept.
#: Since a rejected batch of residual-scan candidates has its strongest fitted alone when at
#: the scan's damping cap (identification/_travel.py): every figure here unchanged, and at
#: 1% seeds 2/3 and with one actuator fewer (seeds 1-3) too; the held-out structure's
#: 2-shaker test at 1% finds its 10% mode at seeds 1/3, 0.25 / 0.26 -> 0.12 / 0.043.
#: Since identify's default is weighting="auto" (the unweighted and the level-weighted fits of
#: data with measurable noise, the one closer to the data by logLS kept; noise-free data
#: unweighted): at 1% the level-weighted fit is kept on the truss 0.0056 -> 0.0041 (now within
#: 2x its floor), truss_high 0.0005 -> 7.5e-5, the ladder 0.0019 -> 0.00043 and the cluster
#: 0.0299 -> 0.00032; the unweighted one on the plate (unchanged); seeds 2/3: truss 0.0041 /
#: 0.0041, truss_high 0.00062 / 0.00085, ladder 0.00058 / 3.0e-5, plate 0.00032 / 0.00037,
#: cluster 0.00022 / 0.0036 (4 modes of 5 at seed 3, as before the weighting).
MEASURED = {
    ("truss", 0.0): (12, 0.0043), ("truss", 0.01): (12, 0.00414),
    ("truss_high", 0.0): (6, 2e-5), ("truss_high", 0.01): (6, 7.5e-5),
    ("ladder", 0.0): (12, 7.7e-4), ("ladder", 0.01): (12, 0.00043),
    # the noise-free plate since identify's default zeta_max is 0.25 (was 0.1): 0.0007 -> 4.5e-12
    # (12 poles; tests/test_identify_damped_modes.py), every other figure unchanged
    ("plate", 0.0): (5, 4.5e-12), ("plate", 0.01): (5, 0.0003),
    ("cluster", 0.0): (5, 0.0001), ("cluster", 0.01): (5, 0.00032),
}
#: members meeting the noise-free target (<= 0.01)
NOISE_FREE_OK = {"truss", "truss_high", "ladder", "plate", "cluster"}
#: the estimator's noise floor at 1% (seed 1, module notes) of the members within 2x of it
FLOOR = {"truss": 0.0024, "truss_high": 0.0007, "ladder": 0.0011, "plate": 0.0003,
         "cluster": 0.017}


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
    # noise independent between lines: the start's residual does not decay over the record
    # (identification/_residual_decay.py: -1.4 to 0.9 here), the rules stay
    assert cm.search.residual_decay is None
    assert int(cm.in_band.sum()) <= _true_in_band(st)          # no spurious in-band mode
    assert err <= 1.5 * ref + 1e-4
    if noise == 0.0 and name in NOISE_FREE_OK:
        assert err <= 0.01
    if noise > 0.0 and name in FLOOR:
        assert err <= 2.0 * FLOOR[name]
