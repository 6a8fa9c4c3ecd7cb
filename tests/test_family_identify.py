"""Identification over the whole family of test structures (issue 22).

Every member of :func:`sdctrl.testbeds.family` is identified from its simulated test (400
lines over its band, noise-free and with 1% multiplicative noise, seed 1) by the automatic
pole selection of :func:`sdctrl.identify`.  The identified in-band poles are compared with
the complex poles of the true damped FE model, and the identified model's FRF with the
exact, noise-free data (mean logLS, 3.12) and with the noisy data it was fitted to.

Each member's figures are locked just above what is reached (``LOCKS``: at most 1.5x the
measured figure, and at the issue's acceptance bound where it is met), so that no change
trades one structure for another.  Where the acceptance is not met yet, the lock is the
measured figure and the table says why.
"""

from __future__ import annotations

import functools
import warnings

import numpy as np
import pytest

import sdctrl as sd
from sdctrl.identification._pole_statistics import coefficient_variance, fit_statistics, pole_std
from sdctrl.updating import logls

NOISES = (0.0, 0.01)
#: issue 22: noise-free, mean logLS against the (exact) data <= 0.01
BOUND_EXACT = 0.01
#: issue 22: with noise, mean logLS against the data within 2x the noise floor
FLOOR_FACTOR = 2.0

#: (member, noise) -> (in-band FE modes found within 0.1% in frequency, largest mean logLS
#: against the exact data, whether the issue's acceptance is met); the measured figure
#: in the comment (main before issue 22 in brackets)
LOCKS = {
    ("truss", 0.0): (12, 0.0065, True),        # 0.0043 (0.0043)
    ("truss", 0.01): (12, 0.0084, False),      # 0.0056 (0.0056): 57x the floor
    ("truss_high", 0.0): (6, 1e-4, True),      # 2e-6 (0.242): six modes below the band
    ("truss_high", 0.01): (6, 0.0014, False),  # 0.0009 (0.239): 19x the floor
    ("ladder", 0.0): (12, 1e-4, True),         # 1e-6 (0.037): 8.0, 10.0 Hz below, 98 above
    ("ladder", 0.01): (12, 0.0017, False),     # 0.0011 (0.037)
    ("plate", 0.0): (5, 0.0011, True),         # 0.0007 (0.0007)
    ("plate", 0.01): (5, 0.0012, False),       # 0.0008 (0.10)
    # four blade modes within 1.4% (two 0.02 line apart), four modes at 69-75 Hz, 1.5x
    # above the band: the significance test takes the residual of the modes not yet
    # fitted for noise, and the close modes stay below it (not solved, see the report)
    ("cluster", 0.0): (2, 1.9, False),         # 1.27 (1.27): 10.217, 10.219 Hz found
    ("cluster", 0.01): (0, 2.5, False),        # 1.67 (1.67): only the local mode
}


def fe_poles(fe, band):
    """Complex poles (rad/s, Im > 0) of the damped FE model in ``band`` (Hz), by the
    first-order form of ``M q'' + C q' + K q`` (non-proportional damping included)."""
    M, K, C = (np.asarray(x.todense()) if hasattr(x, "todense") else np.asarray(x)
               for x in (fe.M, fe.K, fe.C))
    n = M.shape[0]
    A = np.block([[np.zeros((n, n)), np.eye(n)],
                  [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    lam = np.linalg.eigvals(A)
    lam = lam[lam.imag > 0]
    f = np.abs(lam) / (2 * np.pi)
    lam = lam[(f >= band[0]) & (f <= band[1])]
    return lam[np.argsort(np.abs(lam))]


@functools.lru_cache(maxsize=None)
def identified(name, noise):
    """(structure, exact FRF, tested FRF, identified model) of one member and noise."""
    s = sd.testbeds.structure(name)
    frf = s.frf(n=400, noise=noise, seed=1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cm = sd.identify(frf, progress=False)
    return s, s.frf(n=400), frf, cm


def found_modes(cm, ref, tol=1e-3):
    """Relative frequency error of the nearest identified in-band pole for each FE pole
    ``ref`` and whether it is within ``tol``, each identified pole used once."""
    fi = list(cm.frequency[cm.in_band])
    err = np.full(ref.size, np.inf)
    for k, f in enumerate(np.abs(ref) / (2 * np.pi)):
        if fi:
            j = int(np.argmin(np.abs(np.array(fi) - f)))
            err[k] = abs(fi[j] - f) / f
            if err[k] < tol:
                fi.pop(j)
    return err, err < tol


@pytest.mark.parametrize("noise", NOISES)
@pytest.mark.parametrize("name", sd.testbeds.family())
def test_identified_model_of_every_member_is_locked(name, noise):
    """In-band modes found (frequency within 0.1% of the FE model's damped poles, no
    spurious in-band pole where all are found) and the mean logLS of the identified
    model against the exact data, per member and noise level."""
    s, exact, frf, cm = identified(name, noise)
    n_found, lock, meets = LOCKS[(name, noise)]
    ref = fe_poles(s.fe(), s.band)
    err, ok = found_modes(cm, ref)
    assert int(np.sum(ok)) >= n_found, (name, noise, np.round(err * 100, 3))
    assert np.all(err[ok] < 3e-4), (name, noise, np.round(err * 100, 4))
    if n_found == ref.size:
        assert cm.in_band.sum() == ref.size                  # nothing spurious in band
    cost = logls(cm.frf(frf.freq, quantity=frf.quantity).H, exact.H)
    assert cost <= lock, (name, noise, cost)
    if meets:
        assert noise == 0.0 and cost <= BOUND_EXACT


@pytest.mark.parametrize("name", ["truss_high", "ladder", "plate"])
def test_modes_outside_the_band_reach_the_noise_free_goal(name):
    """Modes just outside the band (six below truss_high's, 8.0/10.0 and 98 Hz around the
    ladder's, 18.8 and 64.6 Hz around the plate's): noise-free within the issue's 0.01;
    with 1% noise the fit against the noisy data is measured against the floor (logLS of
    the noisy data against the exact ones, about 5e-5 for 1% complex noise) and locked
    at 40x it (measured 17-23x: the issue's 2x is not reached)."""
    _, exact, _, cm0 = identified(name, 0.0)
    _, _, frf, cm1 = identified(name, 0.01)
    assert logls(cm0.frf(exact.freq, quantity=exact.quantity).H, exact.H) <= BOUND_EXACT
    floor = logls(frf.H, exact.H)
    assert 4e-5 < floor < 6e-5                   # E |ln|1 + 0.01 e||^2 = 0.01^2 / 2
    e_data = logls(cm1.frf(frf.freq, quantity=frf.quantity).H, frf.H)
    assert e_data < 40 * floor, (name, e_data / floor)


@pytest.mark.parametrize("noise", NOISES)
@pytest.mark.parametrize("name", sd.testbeds.family())
def test_out_of_band_poles_are_outside_and_marked(name, noise):
    """Poles added to absorb modes beyond the band lie outside it, within a factor 4 of
    its edges (the search bounds), and are marked ``in_band=False``; in-band poles lie in
    the band."""
    s, _, _, cm = identified(name, noise)
    lo, hi = s.band
    f = cm.frequency
    assert np.all((f[cm.in_band] >= lo) & (f[cm.in_band] <= hi))
    out = f[~cm.in_band]
    assert np.all(((out < lo) & (out >= lo / 4)) | ((out > hi) & (out <= 4 * hi)))


def test_statistics_of_determined_poles_when_others_are_not():
    """Two all but identical, heavily damped poles far above the band (their parameters
    are not determined: the poles' Jacobian is singular, as for the survey's pair above
    its band) leave the statistics of the in-band poles finite, of the order of those of
    the fit without the pair, and NaN for the pair and its residues (API.md: NaN where
    the data do not determine it); before issue 22 there were no statistics at all."""
    f = np.linspace(20.0, 60.0, 300)
    s = 2j * np.pi * f
    fr, zr = np.array([31.0, 47.0]), np.array([0.01, 0.02])
    lam = -zr * 2 * np.pi * fr + 2j * np.pi * fr * np.sqrt(1 - zr**2)
    rng = np.random.default_rng(5)
    R = rng.standard_normal((2, 3, 2)) + 0.2j * rng.standard_normal((2, 3, 2))
    H = sum(R[j] / (s[:, None, None] - lam[j]) + R[j].conj() / (s[:, None, None] - lam[j].conj())
            for j in range(2))
    H = H * (1 + 0.01 * (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape)))
    frf = sd.FRF(f, H)
    far = 2 * np.pi * 200.0 * (-0.6 + 1j)            # two heavily damped poles, 1e-4 apart
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ref = sd.identify(frf, poles=lam, progress=False)
        cm = sd.identify(frf, poles=np.r_[lam, far, far * 1.0001], in_band=[True, True, False, False],
                         optimizer="none", progress=False)
    stats = fit_statistics(cm, frf)                  # the poles as if fitted (3.56)
    fstd, zstd = pole_std(stats, cm.poles)
    inb = cm.in_band
    assert np.all(np.isnan(fstd[~inb])) and np.all(np.isnan(zstd[~inb]))
    # of the order of the fit without the pair (which shares part of the data's
    # information): measured 6% and 19% above
    np.testing.assert_allclose(fstd[inb], ref.frequency_std, rtol=0.3)
    np.testing.assert_allclose(zstd[inb], ref.damping_std, rtol=0.5)
    var = coefficient_variance(stats)                # NaN: the pair's residues only
    assert np.all(np.isnan(var[4:8])) and np.all(np.isfinite(var[:4])) and np.all(var[:4] > 0)
    assert np.all(np.isfinite(var[8:]))              # E, F


def test_several_modes_below_the_band_closed_form():
    """Four modes below the band and two in it (sum of single modes, noise-free): the two
    in-band poles are exact and the fit reproduces the data, whatever lies below."""
    f = np.linspace(20.0, 60.0, 400)
    s = 2j * np.pi * f
    fr = np.array([9.0, 12.0, 15.5, 18.5, 31.0, 47.0])
    zr = np.array([0.01, 0.008, 0.012, 0.01, 0.005, 0.006])
    lam = -zr * 2 * np.pi * fr + 2j * np.pi * fr * np.sqrt(1 - zr**2)
    rng = np.random.default_rng(3)
    R = rng.standard_normal((fr.size, 3, 2)) + 0.1j * rng.standard_normal((fr.size, 3, 2))
    H = sum(R[j] / (s[:, None, None] - lam[j]) + R[j].conj() / (s[:, None, None] - lam[j].conj())
            for j in range(fr.size))
    frf = sd.FRF(f, H)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cm = sd.identify(frf, progress=False)
    p = cm.poles[cm.in_band]
    assert p.size == 2
    assert np.max(np.abs(p / lam[4:] - 1)) < 1e-6
    assert logls(cm.frf(f).H, H) < 1e-6
