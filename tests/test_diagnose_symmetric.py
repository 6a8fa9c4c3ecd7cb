"""A missing in-band mode of a symmetric structure, whose tests have nearly null channels (a
sensor on the plane of symmetry, an actuator that excites only the antisymmetric modes): the
free mode's residue is fitted in the cost's own metric (``_weighted_rank_one.rank_one``).

Measured before (the plain SVD of the per-channel residues): on a held-out symmetric lab
aircraft (33 x 3 at 600 lines) each of three removed in-band modes was found noise-free, but
at 1% noise the SVD's truncation error in the near-null channels dominated the cost: one mode
not found at all (error 1.01 left), one at twice its damping (2.4e-3 left), one 40 std off
(0.06 left).  The synthetic model below (asymmetry 1e-7) fails the same way: 9 of its 14
cases failed before.
"""

from __future__ import annotations

import numpy as np
import pytest

import sdctrl as sd
from sdctrl.diagnosis._weighted_rank_one import rank_one
from sdctrl.testbeds._measurement_noise import relative_noise

#: modes (Hz), alternately symmetric and antisymmetric; damping ratios
FREQS = (12.0, 17.0, 23.0, 31.0, 38.0, 46.0, 55.0, 90.0, 140.0)
ZETA = (0.004, 0.006, 0.002, 0.005, 0.003, 0.008, 0.004, 0.01, 0.01)
#: the asymmetry that leaves the null channels not exactly null
EPS = 1e-7
LINES = np.linspace(10.0, 60.0, 600)


def _model():
    """Pairs of sensors/actuators at mirror points, a sensor and an actuator on the plane of
    symmetry (seeing, driving only the symmetric modes) and a torsion actuator (only the
    antisymmetric ones)."""
    rng = np.random.default_rng(3)
    n = len(FREQS)
    sym = np.arange(n) % 2 == 0
    half = rng.uniform(0.3, 1.0, (4, n)) * rng.choice([-1, 1], (4, n))
    mirror = np.where(sym, 1.0, -1.0)
    cphi = np.vstack([half, half * mirror, np.where(sym, 1.0, EPS)[None] * rng.uniform(
        0.5, 1.0, n)])                                                # (9, n)
    phib = np.vstack([half[:2], np.where(sym, 1.0, EPS) * 0.8,
                      np.where(sym, EPS, 1.0) * 0.7]).T                # (n, 4)
    w = 2 * np.pi * np.asarray(FREQS)
    sensors = [f"S{i}" for i in range(9)]
    actuators = ["A0", "A1", "Amid", "Atwist"]
    return sd.NormalModeModel(np.diag(w**2), np.diag(2 * np.asarray(ZETA) * w), cphi, phib,
                              sensors=sensors, actuators=actuators)


def _without(nm, j):
    keep = np.arange(nm.n) != j
    return nm.replace(Omega=nm.Omega[np.ix_(keep, keep)], Gamma=nm.Gamma[np.ix_(keep, keep)],
                      cphi=nm.cphi[:, keep], phib=nm.phib[keep])


def test_the_channels_are_nearly_null():
    H = np.abs(_model().frf(LINES, "displacement").H)
    assert H[:, 8, 3].max() < 1e-4 * H.max()


@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize("j", range(7))
def test_missing_mode_with_near_null_channels(j, seed):
    """Mode ``j`` (each in-band one) removed from the model: found at 1% noise (frequency
    within 0.5%, damping 20%, the truth within 3 std), the error left the noise level (as
    issue 23 asks).  Before the weighted rank-one fit, 9 of these 14 failed (a mode not
    found, found at 1.6-9.5 times its damping, or 70% off in frequency; errors left up to
    2.0)."""
    full = _model()
    data = full.frf(LINES, "acceleration")
    data = sd.FRF(LINES, relative_noise(data.H, 0.01, seed), quantity="acceleration",
                  sensors=data.sensors, actuators=data.actuators)
    d = sd.diagnose(_without(full, j), data, max_effects=1, progress=False)
    e = d.effects[0]
    assert e.kind == "missing_mode"
    f, z = FREQS[j], ZETA[j]
    assert e.parameters["frequency"] == pytest.approx(f, rel=0.005)
    assert e.parameters["damping"] == pytest.approx(z, rel=0.2)
    assert abs(e.parameters["frequency"] - f) <= 3 * e.std["frequency"]
    assert abs(e.parameters["damping"] - z) <= 3 * e.std["damping"]
    assert d.error_after <= 1.1e-4


def test_rank_one_in_the_weighted_metric():
    """``rank_one`` returns the exact rank-one matrix when there is one, whatever the
    weights; with weights spanning 20 decades it fits the heavy channels as they are."""
    rng = np.random.default_rng(0)
    c, b = rng.standard_normal(7), rng.standard_normal(3)
    b[2] = 1e-9
    X = np.outer(c, b)
    W = 10.0 ** rng.uniform(0, 20, X.shape)
    assert np.allclose(rank_one(X, W), X, rtol=1e-9, atol=0)
    Xn = X * (1 + 1e-3 * rng.standard_normal(X.shape))
    X1 = rank_one(Xn, W)
    assert np.max(np.abs(X1 - X) / np.abs(X)) < 1e-2


@pytest.mark.parametrize("transpose", [False, True])
@pytest.mark.parametrize("seed", range(3))
def test_rank_one_keeps_a_small_factor_small(seed, transpose):
    """A residue whose last actuator factor is 1e-7 of the others; the per-channel fits known
    to 1e-3 (absolute: that actuator's column is noise), except the channel of the last
    sensor and actuator, known to 1e-3 of its own tiny value (weight 1e14: a near-null
    channel of the data).  The fit: every large entry within 1%, the tiny one within 1%.
    The plain SVD misses the tiny entry by a factor 2,000-5,000; alternating updates from
    it with the sensor factor first lock that sensor's factor to zero (its large entries
    100% off).  The same transposed (a small sensor factor, the other order locking)."""
    rng = np.random.default_rng(seed)
    c, b = rng.uniform(0.5, 1.0, 8), np.r_[rng.uniform(0.5, 1.0, 3), 1e-7]
    X = np.outer(c, b)
    W = np.ones_like(X)
    W[-1, -1] = 1e14
    Xn = X + 1e-3 * rng.standard_normal(X.shape)
    Xn[-1, -1] = X[-1, -1] * (1 + 1e-3 * rng.standard_normal())
    if transpose:
        X, Xn, W = X.T, Xn.T, W.T
    X1 = rank_one(Xn, W)
    big = np.abs(X) > 1e-3
    assert np.max(np.abs(X1 / X - 1)[big]) < 1e-2
    assert X1[-1, -1] == pytest.approx(X[-1, -1], rel=1e-2)
