"""Close modes closer than the line spacing (issue 22, the cluster): the local rank of the
multi-channel data (3.20)-(3.22) counts the modes of a window against its noise, and a
zoomed LSCF proposes the poles the fitted ones do not explain
(sdctrl/identification/_zoom.py).  Checked against closed forms (Marchenko-Pastur), a
synthetic cluster of known modes (not a testbed) and the invariance of the count to the
scale of the channels.
"""

import warnings

import numpy as np
import pytest

import sdctrl as sd
from sdctrl.identification._zoom import local_rank, mp_median, sole_poles
from sdctrl.updating import logls

#: four modes within 0.14 Hz (0.04-0.06 Hz apart) sampled every 0.098 Hz, a separate
#: mode at 37 Hz and one above the band
F_MODES = np.array([10.15, 10.19, 10.25, 10.29, 37.0, 60.0])
Z_MODES = np.array([0.003, 0.003, 0.003, 0.003, 0.002, 0.004])


def _cluster_frf(noise, seed=3, ns=8, na=2):
    rng = np.random.default_rng(seed)
    phi = rng.standard_normal((ns, F_MODES.size))
    phib = rng.standard_normal((F_MODES.size, na))
    f = np.linspace(6, 45, 400)
    w = 2 * np.pi * f
    H = np.zeros((f.size, ns, na), complex)
    for j, (fj, zj) in enumerate(zip(F_MODES, Z_MODES)):
        wj = 2 * np.pi * fj
        H += np.outer(phi[:, j], phib[j])[None] / (wj**2 - w**2 + 2j * zj * wj * w)[:, None,
                                                                                    None]
    e = (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape)) / np.sqrt(2)
    return f, H, H * (1 + noise * e)


@pytest.mark.parametrize("y", [0.1, 0.5, 1.0])
def test_mp_median_matches_simulated_noise(y):
    rng = np.random.default_rng(0)
    n = 400
    m = int(y * n)
    X = (rng.standard_normal((m, n)) + 1j * rng.standard_normal((m, n))) / np.sqrt(2)
    ev = np.linalg.eigvalsh(X @ X.conj().T / n)
    assert abs(mp_median(y) - np.median(ev)) < 0.03 * mp_median(y)
    assert (1 - np.sqrt(y)) ** 2 < mp_median(y) < (1 + np.sqrt(y)) ** 2


def test_local_rank_counts_dyads_above_noise():
    rng = np.random.default_rng(1)
    L, k, r = 41, 30, 4
    f = np.linspace(9, 11, L)
    poles = np.array([10.0, 10.04, 10.1, 10.15])
    A = 1.0 / (1j * (f[:, None] - poles[None, :]) + 0.02)            # (L, r) line shapes
    B = rng.standard_normal((r, k)) + 1j * rng.standard_normal((r, k))
    noise = 1e-3 * (rng.standard_normal((L, k)) + 1j * rng.standard_normal((L, k)))
    H = A @ B + noise
    Y = np.vstack([H.real, H.imag])
    sig2 = np.full((L, k), 2e-6)
    lines = np.arange(L)
    assert local_rank(Y, sig2, lines) == r
    # a diagonal scaling of the channels changes neither the rank nor the count
    D = np.geomspace(1e-3, 1e3, k)
    assert local_rank(Y * D, sig2 * D**2, lines) == r
    # the noise field's scale is not used: model error taken for noise does not hide modes
    assert local_rank(Y, 1e4 * sig2, lines) == r
    # pure noise has no mode
    Yn = np.vstack([noise.real, noise.imag])
    assert local_rank(Yn, sig2, lines) == 0


@pytest.mark.parametrize("noise,tol", [(0.0, 1e-6), (0.001, 1e-3)])
def test_identify_finds_modes_closer_than_a_line(noise, tol):
    f, H, Hn = _cluster_frf(noise)
    assert np.min(np.diff(F_MODES[:4])) < f[1] - f[0]                # closer than a line
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cm = sd.identify(sd.FRF(f, Hn), progress=False)
    fin = np.sort(cm.frequency[cm.in_band])
    assert fin.size == 5
    assert np.max(np.abs(fin - F_MODES[:5])) < 0.003                 # Hz, every mode
    zin = cm.damping[cm.in_band][np.argsort(cm.frequency[cm.in_band])]
    assert np.max(np.abs(zin - Z_MODES[:5]) / Z_MODES[:5]) < 0.05
    assert logls(cm.frf(f).H, H) < tol


def test_the_last_pole_of_a_window_with_modes_is_held():
    """A pole alone in a window where the data show modes is held (not removed as
    insignificant: it may stand for several close modes); a pole among others, a pole in
    pure noise and an unchecked pole are not."""
    f, H, Hn = _cluster_frf(0.01, ns=8, na=2)
    nf = f.size
    Hm = Hn.reshape(nf, -1)
    Y = np.vstack([Hm.real, Hm.imag])
    sig2 = 1e-4 * np.abs(H.reshape(nf, -1)) ** 2 + 1e-30      # the noise's own variance
    one = np.array([10.22, 37.0])                               # one pole for the cluster
    z = np.array([0.003, 0.002])
    inb = np.ones(2, bool)
    assert sole_poles(f, Y, sig2, one, z, inb, np.array([True, False])).tolist() == [
        True, False]
    assert not sole_poles(f, Y, sig2, one, z, ~inb, inb).any()  # out-of-band: not held
    two = np.array([10.17, 10.27, 37.0])                        # two poles in one window
    assert not sole_poles(f, Y, sig2, two, np.full(3, 0.003), np.ones(3, bool),
                          np.ones(3, bool))[:2].any()
    rng = np.random.default_rng(0)
    Yn = rng.standard_normal(Y.shape)                           # no mode: nothing held
    assert not sole_poles(f, Yn, np.ones_like(sig2), one, z, inb, inb).any()
