"""Identification on data with the traits of a real roving-hammer survey.

3 reference accelerometers x 75 hammer points on a plate-like structure, 0.125 Hz lines
over 15-135 Hz, 15 modes in the band with 0.1-0.5% damping, two close pairs about 1%
apart (40.0/40.4 Hz, 97/98 Hz), modes just outside the band (9 Hz, 150 Hz), small mode
complexity, sign flips between hammer columns (reversed impact directions), and noise of
2% of |H| plus a floor of 0.2% of each channel's peak, so that the relative noise rises
at antiresonances where the coherence drops below one.
"""

import numpy as np
import pytest

import sdctrl as sd
from sdctrl.identification._complex_modes import frf_array

F_MODES = np.array([9.0, 18.5, 26.0, 33.5, 40.0, 40.4, 52.0, 61.5, 70.0, 78.5, 88.0,
                    97.0, 98.0, 109.0, 118.0, 127.0, 150.0])
Z_MODES = np.array([0.005, 0.005, 0.004, 0.004, 0.003, 0.0045, 0.003, 0.0025, 0.002, 0.002,
                    0.0015, 0.0012, 0.002, 0.001, 0.001, 0.001, 0.002])
BAND = (15.0, 135.0)


def hammer_survey(seed=0, noise=0.02, floor=0.002):
    rng = np.random.default_rng(seed)
    n = F_MODES.size
    w = 2 * np.pi * F_MODES
    lam = -Z_MODES * w + 1j * w * np.sqrt(1 - Z_MODES**2)
    gx, gy = np.meshgrid(np.linspace(0.03, 0.97, 15), np.linspace(0.1, 0.9, 5))
    pts = np.column_stack([gx.ravel(), gy.ravel()])              # 75 hammer points
    refs = np.array([[0.21, 0.33], [0.55, 0.71], [0.83, 0.18]])  # 3 accelerometers
    mx = np.array([1, 2, 1, 3, 2, 4, 1, 3, 5, 4, 2, 6, 1, 5, 3, 7, 6])
    my = np.array([1, 1, 2, 1, 2, 1, 3, 2, 1, 2, 3, 1, 4, 2, 3, 1, 3])

    def shape(p, j):
        return np.sin(mx[j] * np.pi * p[:, 0]) * np.sin(my[j] * np.pi * p[:, 1])

    ph = rng.uniform(-0.08, 0.08, (n, 1))                      # mode complexity
    cpsi = np.stack([shape(refs, j) for j in range(n)]) * np.exp(1j * ph)
    psib = np.stack([shape(pts, j) for j in range(n)]) * np.exp(1j * ph)
    flips = np.where(rng.random(75) < 0.3, -1.0, 1.0)           # sign flips between columns
    R = np.einsum("js,ja->jsa", cpsi, psib * flips) / (2j * lam.imag)[:, None, None]
    freq = np.arange(BAND[0], BAND[1] + 1e-9, 0.125)
    s = 2j * np.pi * freq
    Ha = frf_array(lam, R, np.zeros((3, 75)), np.zeros((3, 75)), s) * (s**2)[:, None, None]
    sig = np.sqrt((noise * np.abs(Ha)) ** 2 + (floor * np.abs(Ha).max(axis=0)) ** 2)
    e = (rng.standard_normal(Ha.shape) + 1j * rng.standard_normal(Ha.shape)) / np.sqrt(2)
    coh = np.abs(Ha) ** 2 / (np.abs(Ha) ** 2 + sig**2)
    frf = sd.FRF(freq, Ha + sig * e, quantity="acceleration",
                 sensors=["A1.z", "A2.z", "A3.z"], actuators=[f"P{i}.z" for i in range(75)],
                 coherence=coh)
    return frf, lam, R, Ha


@pytest.fixture(scope="module")
def survey():
    frf, lam, R, Ha = hammer_survey()
    cm = sd.identify(frf, band=BAND, progress=False)
    return frf, lam, R, Ha, cm


def test_hammer_survey_separates_close_pairs(survey):
    frf, _, _, _, cm = survey
    assert frf.coherence.min() < 0.5                  # antiresonances are noisy
    inb = (F_MODES > BAND[0]) & (F_MODES < BAND[1])
    assert cm.in_band.sum() == inb.sum()              # 15 in-band modes, none spurious
    f = cm.frequency[cm.in_band]
    idx = [int(np.argmin(np.abs(f - ft))) for ft in F_MODES[inb]]
    assert len(set(idx)) == inb.sum()                 # close pairs are two poles each
    # measured: frequency errors <= 2.2e-5, damping errors <= 0.6%
    np.testing.assert_allclose(f[idx], F_MODES[inb], rtol=1e-4)
    np.testing.assert_allclose(cm.damping[cm.in_band][idx], Z_MODES[inb], rtol=0.03)


def test_hammer_survey_frf_error(survey):
    frf, lam, R, Ha, cm = survey
    fit = cm.frf(frf.freq, "acceleration")
    err = sd.updating.relative_error(fit, frf)
    # measured: 3.1% against the noisy data (the noise itself), 1.0% against the truth
    assert err < 0.05
    assert np.linalg.norm(fit.H - Ha) / np.linalg.norm(Ha) < 0.02
    assert abs(cm.cost - err) < 1e-9
    # residues describe displacement even though accelerations were measured
    inb = (F_MODES > BAND[0]) & (F_MODES < BAND[1])
    i = [int(np.argmin(np.abs(cm.poles - p))) for p in lam[inb]]
    rel = np.linalg.norm(cm.residues[i] - R[inb], axis=(1, 2)) / np.linalg.norm(R[inb],
                                                                                 axis=(1, 2))
    assert np.median(rel) < 0.02
    # the sign flips between hammer columns are carried by the residues
    # (in band: the poles fitted outside the band, issue 22, stand for the 9 and 150 Hz
    # modes and the tails of the rest, not dyadic)
    inb = cm.in_band
    assert inb.sum() == 15 and np.all(cm.singular_value_ratios()[inb, 1] < 0.15)
    std = cm.residue_std(frf)
    assert std.shape == cm.residues.shape and np.all(std[inb] > 0)
    assert np.all(np.isfinite(cm.frequency_std[inb]) & (cm.frequency_std[inb] > 0))
    sys = cm.to_statespace()
    assert sys.ninputs == 75 and sys.noutputs == 3
    assert np.abs(sd.FRF.from_system(sys, frf.freq).H - cm.frf(frf.freq).H).max() < \
        1e-8 * np.abs(cm.frf(frf.freq).H).max()


def test_hammer_survey_fit_is_orientation_free(survey):
    """The fit of the survey and of its transpose (reciprocity, 75 outputs x 3 inputs) is
    one fit (common poles, full residue matrices): ``identify`` needs no transposition."""
    frf, _lam, _R, _Ha, cm = survey
    ct = sd.identify(frf.transpose(), band=BAND, progress=False)
    # 15 in band; two heavily damped poles above it (issue 22) carry the 150 Hz mode's
    # tail, their parameters not determined by the data (statistics NaN)
    assert ct.n == cm.n and cm.in_band.sum() == 15
    np.testing.assert_array_equal(ct.in_band, cm.in_band)
    inb = cm.in_band
    np.testing.assert_allclose(ct.poles[inb], cm.poles[inb], rtol=1e-9)   # measured 1e-16
    np.testing.assert_allclose(ct.poles, cm.poles, rtol=1e-8)             # measured 2.2e-9
    np.testing.assert_allclose(ct.residues[inb], np.swapaxes(cm.residues[inb], 1, 2),
                               rtol=1e-6, atol=1e-9 * np.abs(cm.residues).max())
    np.testing.assert_allclose(ct.residues, np.swapaxes(cm.residues, 1, 2),   # 3.4e-5
                               rtol=0, atol=2e-4 * np.abs(cm.residues).max())
    assert np.all(np.isnan(cm.frequency_std[~inb]))
    assert np.all(np.isfinite(cm.frequency_std[inb]) & (cm.frequency_std[inb] > 0))
    assert ct.cost == pytest.approx(cm.cost, rel=1e-9)
    # weighting="auto" on data with a coherence: the misfit over the point variance (3.59)
    # chose the unweighted fit (measured 1.817 / 1.864; logLS against the exact response
    # 0.0204 / 0.0258).  The mean logLS against the data chose the weighted one (0.0954 /
    # 0.0931): the noise floor at antiresonances counted as misfit, and the weighted fit,
    # 16 poles with one at 381 Hz and zeta 0.6 (frequency std 137 Hz), was kept
    assert cm.search.weighting == ct.search.weighting == "none"
    v = cm.search.weighting_variance
    assert v is not None and v[0] < v[1] and v == pytest.approx(ct.search.weighting_variance)
