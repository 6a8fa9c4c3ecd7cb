"""The passive out-of-band term placed after the automatic selection (issue 22;
``identification/_far_terms.py``): the passivity of residues and asymptotic terms at the
collocated pairs against known truth, the grid of places, and the term on a family member.

Known truth: a three-DOF chain with real modes, displacement FRF over 15-60 Hz that leaves
a mode far below (1 Hz), one just below (12 Hz) and one far above the band (600 Hz).  A real
mode's collocated displacement residue is ``phi_c^2 / (2 j w_d)``: ``Im R_cc < 0``; the tails
of the modes far outside the band leave ``F_cc > 0`` (below) and ``E_cc > 0`` (above).
"""

import warnings

import numpy as np

import sdctrl as sd
from sdctrl.identification._far_terms import (
    PASSIVE_SIGMA,
    CollocatedResidues,
    _beyond,
    oob_grid,
)
from sdctrl.identification._search import OUT_FACTOR, PoleProblem
from sdctrl.updating import logls

#: the chain: natural frequencies (Hz), damping, mode shapes (columns) at three DOFs
F0 = np.array([1.0, 12.0, 22.0, 31.0, 47.0, 600.0])
Z0 = np.array([0.01, 0.01, 0.01, 0.02, 0.015, 0.01])
PHI = np.array([[1.0, 0.6, 0.8, 0.0, 0.5, 0.7],
                [1.0, 0.9, -0.3, 0.9, -0.6, -0.8],
                [1.0, -0.7, -0.9, -0.7, 0.4, 0.5]])
BAND = (15.0, 60.0)
PAIRS = [(0, 0), (1, 1), (2, 2)]
#: the fitted poles: the three in-band modes and the 12 Hz mode (out of band, below)
FIT = [1, 2, 3, 4]
SIDE = np.array([-1, 0, 0, 0])


def _scores(noise, seed, sign=None, fit=FIT):
    """``passivity`` at the chain's exact poles ``fit`` (poles, then E and F; 3 pairs) on
    its FRF in the band with complex noise of ``noise`` times the largest ``|H|`` (each
    part) on every line; ``sign`` flips modes' contributions."""
    f = np.linspace(*BAND, 300)
    s = 2j * np.pi * f
    w = 2 * np.pi * F0
    sg = np.ones(F0.size) if sign is None else np.asarray(sign, float)
    H = np.einsum("fk,ik,jk->fij", sg / (s[:, None] ** 2 + 2 * Z0 * w * s[:, None] + w ** 2),
                  PHI, PHI)
    rng = np.random.default_rng(seed)
    H = H + noise * np.abs(H).max() * (rng.standard_normal(H.shape)
                                       + 1j * rng.standard_normal(H.shape))
    prob = PoleProblem(np.zeros((2 * f.size, 1)), s, 0, "complex", (True, True))
    col = CollocatedResidues(H.reshape(f.size, -1), 3, PAIRS, prob)
    return col.passivity(2 * np.pi * F0[fit], Z0[fit]), col


def test_real_modes_and_the_tails_outside_the_band_are_passive():
    t, _ = _scores(1e-6, 0)          # noise below the 600 Hz mode's tail in the band (E)
    # every fitted mode at every pair where it participates: Im R < 0 far beyond the noise
    part = np.abs(PHI[:, FIT].T) > 0.1                    # (poles, pairs)
    assert np.all(t[:4][part] < -30)
    # the mode at 1 Hz leaves F_cc > 0, the mode at 600 Hz E_cc > 0
    assert np.all(t[4] < -PASSIVE_SIGMA) and np.all(t[5] < -PASSIVE_SIGMA)


def test_an_active_mode_is_seen_by_its_sign():
    """The 31 Hz mode's contribution flipped (a non-passive residue): Im R > 0 at the pairs
    where it participates, by far more than its noise; the others stay passive."""
    t, _ = _scores(1e-4, 0, sign=[1, 1, 1, -1, 1, 1])
    assert np.all(t[2, 1:] > 30)                          # phi = 0.9, -0.7 at DOFs 1, 2
    others = [0, 1, 3]
    assert np.all(t[others][np.abs(PHI[:, np.array(FIT)[others]].T) > 0.1] < -30)


def test_the_standard_deviation_is_that_of_the_noise():
    """Where a mode does not participate (the 31 Hz mode at DOF 0, phi = 0), the score is
    ``Im R / std``: over 200 noise draws its mean is 0 and its spread 1 (the noise, 1% of the
    largest response, is far above the model error of E and F)."""
    z = np.array([_scores(0.01, seed)[0][2, 0] for seed in range(200)])
    assert abs(z.mean()) < 0.25                           # 200 draws: 0 +- 0.07
    assert 0.85 < z.std() < 1.15                          # 1 +- 0.05


def test_the_term_is_judged_by_its_sign_alone():
    """The pole below the band (12 Hz, where a mode is) is passive; on data with that mode
    flipped it is not, whatever its noise."""
    for sign, passive in ((None, True), ([1, -1, 1, 1, 1, 1], False)):
        t, col = _scores(1e-4, 1, sign)
        bad = _beyond((2 * np.pi * F0[FIT], Z0[FIT], SIDE), col, new=0)
        assert (0 not in bad) == passive
        assert abs(t[0]).max() > 30


def test_grid_of_places():
    """From 3% outside the edge to 5% inside the far bound (a factor OUT_FACTOR), geometric."""
    lo = oob_grid((16.0, 62.0), -1)
    hi = oob_grid((16.0, 62.0), 1)
    assert lo.size == hi.size == 12
    assert np.isclose(lo[0], 0.97 * 16) and np.isclose(lo[-1], 0.97 * 16 / (0.95 * OUT_FACTOR))
    assert np.isclose(hi[0], 1.03 * 62) and np.isclose(hi[-1], 1.03 * 62 * 0.95 * OUT_FACTOR)
    assert np.allclose(np.diff(np.log(lo)), np.log(lo[1] / lo[0]))


def test_the_ladder_at_seed_2_gets_a_passive_term_above():
    """The ladder at 1%, seed 2: the selection leaves 10.0 and 99.5 Hz out of band; a term
    held at 216.8 Hz (damping: the band's median) is significant and passive, and the
    identified model against the exact response goes 0.0014 -> 0.00058 (normal-mode model
    against the data 0.0027 -> 0.0019; its state-space realisation against the exact response
    0.00370 -> 0.00369).  At seed 1 and 3 no term is kept (every figure of
    tests/test_family_identify.py unchanged)."""
    st = sd.testbeds.structure("ladder")
    frf = st.frf(n=400, noise=0.01, seed=2)
    cm = _identify(frf)
    term = ~cm.in_band & (cm.frequency > 150)
    assert term.sum() == 1                                 # the selection's: 10.1, 98.9 Hz
    j = int(np.flatnonzero(term)[0])
    assert abs(cm.frequency[j] - 216.8) < 1.0
    # held at the in-band median damping (before the in-band poles were refitted: 2e-5 off)
    assert np.isclose(cm.damping[j], np.median(cm.damping[cm.in_band]), rtol=1e-3)
    assert np.all([cm.residues[j, a, b].imag <= 0 for a, b in frf.collocated])
    # F stays a mass line (F_cc > 0); E_cc, 2e-6 before, is within its noise of 0 with the
    # term above carrying the first tail (measured -3e-8, -9e-7, -2.7e-6)
    assert np.all([cm.F[a, b] > 0 and cm.E[a, b] > -5e-6 for a, b in frf.collocated])
    err = logls(cm.frf(frf.freq, quantity=frf.quantity).H, st.frf(n=400))
    assert int(cm.in_band.sum()) == 12
    assert err <= 1.5 * 0.00058 + 1e-4                     # before the term: 0.0014


def test_without_collocated_pairs_no_term_is_tried():
    st = sd.testbeds.structure("ladder")
    frf = st.frf(n=400, noise=0.01, seed=2)
    frf = sd.FRF(frf.freq, frf.H, quantity=frf.quantity, sensors=frf.sensors,
                 actuators=frf.actuators, collocated=[])
    # the unweighted fit (weighting="none", the fit this was shown on): the two out-of-band
    # poles and no far term; the default keeps the level-weighted fit here, whose out-of-band
    # poles are 10, 103 and 161 Hz (a third pole for the tail above the band)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cm = sd.identify(frf, progress=False, weighting="none")
    assert np.sort(cm.frequency[~cm.in_band]).round(0).tolist() == [10.0, 100.0]


def _identify(frf):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return sd.identify(frf, progress=False)
