"""A mode seen on a few quiet channels (issue 22: the testbed family's cluster, whose
weakest blade mode shows on its own blade's channels only): the pole search divides each
channel by its noise level (``_compression.channel_weights``), so the loud channels' noise
neither steers the poles nor hides the mode from the significance test.  Known truth: two
modes 0.3 Hz apart on 40 channels with 1% relative noise, the weak one on one channel
only, with a residue 1000 times below the loud one's (absent on that channel).
"""

import warnings

import numpy as np
import pytest

import sdctrl as sd
from sdctrl.identification._compression import MAX_WEIGHT, channel_weights

F = np.linspace(8.0, 12.0, 400)
S = 2j * np.pi * F
POLES = 2 * np.pi * np.array([10.0, 10.3]) * (-0.005 + 1j * np.sqrt(1 - 0.005**2))


def _modes(weak: float = 0.001, seed: int = 0):
    """(400, 40) FRF: a loud mode at 10 Hz on channels 1-39 (random residues), a mode at
    10.3 Hz with residue ``weak`` on channel 0 only."""
    rng = np.random.default_rng(seed)
    R = np.zeros((2, 40))
    R[0, 1:] = rng.uniform(0.5, 1.5, 39) * rng.choice([-1, 1], 39)
    R[1, 0] = weak
    return sum(R[j][None, :] / (S - POLES[j])[:, None]
               + R[j][None, :] / (S - POLES[j].conj())[:, None] for j in range(2))


def _noisy(H, noise, seed):
    """``H (1 + noise e)``, ``e`` unit complex normal noise."""
    rng = np.random.default_rng(seed)
    e = (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape)) / np.sqrt(2)
    return H * (1 + noise * e)


def _identify(H):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return sd.identify(sd.FRF(F, H[:, :, None]), progress=False)


@pytest.mark.parametrize("noise,seed", [(0.0, 0), (0.01, 1), (0.01, 2), (0.01, 3)])
def test_identify_finds_the_quiet_channel_mode(noise, seed):
    """Both modes at their frequencies and damping, no other in-band pole (before the
    channel weights, at 1%, seeds 1-3: the 10 Hz mode only)."""
    cm = _identify(_noisy(_modes(), noise, seed))
    f = cm.frequency[cm.in_band]
    order = np.argsort(f)
    assert f.size == 2, f
    np.testing.assert_allclose(f[order], [10.0, 10.3], atol=2e-3)
    np.testing.assert_allclose(cm.damping[cm.in_band][order], 0.005, rtol=0.05)
    # the weak mode's residue on its channel: 1% noise gives its residue to a few %
    j = np.argmin(np.abs(cm.frequency - 10.3))
    r = cm.residues[j, 0, 0]
    lam = POLES[1]
    np.testing.assert_allclose(abs(r), 0.001, rtol=0.05)
    assert abs(cm.poles[j] - lam) / abs(lam) < 2e-4


@pytest.mark.parametrize("seed", [1, 2])
def test_pure_noise_channels_add_no_mode(seed):
    """A quiet channel of pure noise (no mode on it) weighs as much as the others and
    brings no pole: only the loud mode is found."""
    H = _modes(weak=0.0)
    rng = np.random.default_rng(seed)
    H[:, 0] = 1e-4 * (rng.standard_normal(F.size) + 1j * rng.standard_normal(F.size))
    cm = _identify(_noisy(H, 0.01, seed))
    f = cm.frequency[cm.in_band]
    assert f.size == 1
    assert abs(f[0] - 10.0) < 1e-3


def test_weights_are_the_inverse_noise_levels():
    """White noise of level ``sigma_c`` on smooth responses: the weights are
    ``1/sigma_c`` to the scatter of a median of 398 lines (a few %), normalised to a
    geometric mean of one, and quiet channels held within MAX_WEIGHT of the median."""
    rng = np.random.default_rng(4)
    sig = np.geomspace(1e-4, 1e-1, 12)
    smooth = (1.0 / (S[:, None] - (-1 + 2j * np.pi * 30))) * np.ones(12)
    e = (rng.standard_normal((F.size, 12)) + 1j * rng.standard_normal((F.size, 12)))
    w = channel_weights(smooth + sig * e / np.sqrt(2))
    expect = (1 / sig) / np.exp(np.mean(np.log(1 / sig)))
    np.testing.assert_allclose(w, expect, rtol=0.1)
    assert abs(np.mean(np.log(w))) < 1e-12
    H = np.ones((50, 3), complex) * np.arange(50)[:, None]   # straight: no 2nd difference
    H[:, 1] += 1e-3 * rng.standard_normal(50)
    H[:, 2] += 1.0 * rng.standard_normal(50)
    w = channel_weights(H)
    np.testing.assert_allclose(w[0] / np.median(w), MAX_WEIGHT, rtol=1e-9)   # held
    np.testing.assert_allclose(w[1] / w[2], 1e3, rtol=0.3)
    np.testing.assert_array_equal(channel_weights(H[:4]), np.ones(3))
    # the input is not modified
    H0 = H.copy()
    channel_weights(H)
    np.testing.assert_array_equal(H, H0)


def test_no_weights_without_measurable_noise():
    """Noise-free data: second differences are the response's curvature, the fourth far
    below them (median ratio 0.001 on the testbed family): every weight is one; the same
    data at 1% relative noise are weighted (the weak mode's channel, whose response is
    1000x below the others', weighs about 1000x more)."""
    H = _modes()
    np.testing.assert_array_equal(channel_weights(H), np.ones(40))
    w = channel_weights(_noisy(H, 0.01, 1))
    assert w[0] / np.median(w[1:]) > 100
