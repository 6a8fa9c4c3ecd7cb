"""Statistics of identified models (issue 24): calibrated against many noise draws with a
known truth (thesis 3.4, (3.56)-(3.59))."""

import warnings

import numpy as np
import pytest

import sdctrl as sd

LABELS = ("N1.x", "N2.x", "N3.x", "N4.x")


def chain_matrices(n=4):
    """A spring-mass chain fixed at one end, non-proportional damping (a dashpot on mass 1)."""
    M = np.diag(np.linspace(1.0, 1.6, n))
    k = 1e4 * np.linspace(1.0, 1.5, n)
    K = np.zeros((n, n))
    for i in range(n):
        K[i, i] += k[i]
        if i + 1 < n:
            K[i, i] += k[i + 1]
            K[i, i + 1] -= k[i + 1]
            K[i + 1, i] -= k[i + 1]
    C = 2e-4 * K + 0.3 * M
    C[0, 0] += 0.5
    return M, K, C


def chain_poles(M, K, C):
    n = M.shape[0]
    A = np.block([[np.zeros((n, n)), np.eye(n)],
                  [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    lam = np.linalg.eigvals(A)
    lam = lam[lam.imag > 0]
    return lam[np.argsort(lam.imag)]


def chain_frf(M, K, C, freq, actuators=(0,)):
    """Exact displacement FRF of every mass to forces on ``actuators``."""
    s = 2j * np.pi * freq
    Z = M[None] * (s**2)[:, None, None] + C[None] * s[:, None, None] + K[None]
    return np.linalg.inv(Z)[:, :, list(actuators)]


def noisy(freq, H0, noise, rng, **labels):
    """FRF with complex Gaussian noise proportional to |H| on every line."""
    e = (rng.standard_normal(H0.shape) + 1j * rng.standard_normal(H0.shape)) / np.sqrt(2)
    return sd.FRF(freq, H0 * (1 + noise * e), **labels)


def draws(freq, H0, poles0, noise, n_draws, seed, **labels):
    """Frequencies, damping and their predicted std over ``n_draws`` noise draws."""
    rng = np.random.default_rng(seed)
    out = {k: [] for k in ("f", "z", "fs", "zs")}
    for _ in range(n_draws):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            cm = sd.identify(noisy(freq, H0, noise, rng, **labels), poles=poles0,
                             progress=False)
        out["f"].append(cm.frequency)
        out["z"].append(cm.damping)
        out["fs"].append(cm.frequency_std)
        out["zs"].append(cm.damping_std)
    return {k: np.array(v) for k, v in out.items()}, cm.in_band


def check_calibration(d, f_true, z_true, in_band):
    for key, truth in (("f", f_true), ("z", z_true)):
        pred = np.median(d[key + "s"], axis=0)[in_band]
        emp = np.std(d[key], axis=0, ddof=1)[in_band]
        ratio = emp / pred
        assert np.all((ratio > 0.67) & (ratio < 1.5)), (key, ratio)
        cover = np.mean(np.abs(d[key] - truth) <= 1.96 * d[key + "s"], axis=0)[in_band]
        assert np.all(cover >= 0.9), (key, cover)


@pytest.mark.parametrize("noise", [0.01, 0.05])
def test_pole_std_calibrated_on_a_chain(noise):
    M, K, C = chain_matrices()
    lam = chain_poles(M, K, C)
    freq = np.linspace(2.0, 40.0, 300)
    H0 = chain_frf(M, K, C, freq)
    d, in_band = draws(freq, H0, lam, noise, 50, seed=int(noise * 1000),
                       sensors=LABELS, actuators=LABELS[:1])
    assert in_band.all() and d["fs"].shape == (50, 4)
    check_calibration(d, np.abs(lam) / (2 * np.pi), -lam.real / np.abs(lam), in_band)


@pytest.mark.parametrize("noise", [0.01, 0.05])
def test_pole_std_calibrated_on_the_testbed(noise):
    """Two modes of the built-in truss, four sensors, one shaker; the truth is the fit of
    the exact data (the scatter of the estimate around its noiseless value)."""
    band = (8.0, 14.0)
    exact = sd.testbed_frf(band=band, n=600)
    sub = dict(sensors=exact.sensors[:4], actuators=exact.actuators[:1])
    H0 = exact.H[:, :4, :1]
    ref = sd.identify(sd.FRF(exact.freq, H0, quantity=exact.quantity, **sub), progress=False)
    d, in_band = draws(exact.freq, H0, ref.poles, noise, 50, seed=7 + int(noise * 1000),
                       quantity=exact.quantity, **sub)
    assert in_band.sum() >= 2
    check_calibration(d, ref.frequency, ref.damping, in_band)


def test_pole_std_calibrated_from_the_coherence():
    """With a coherence the point variance is ``|H|^2 (1 - coherence)`` (3.59)."""
    noise = 0.05
    M, K, C = chain_matrices()
    lam = chain_poles(M, K, C)
    freq = np.linspace(2.0, 40.0, 300)
    H0 = chain_frf(M, K, C, freq)
    coh = np.full(H0.shape, 1 - noise**2)
    d, in_band = draws(freq, H0, lam, noise, 50, seed=3, sensors=LABELS,
                       actuators=LABELS[:1], coherence=coh)
    check_calibration(d, np.abs(lam) / (2 * np.pi), -lam.real / np.abs(lam), in_band)


def test_statistics_absent_saved_and_residue_parts(tmp_path):
    M, K, C = chain_matrices()
    lam = chain_poles(M, K, C)
    freq = np.linspace(2.0, 40.0, 300)
    H0 = chain_frf(M, K, C, freq)
    frf = noisy(freq, H0, 0.02, np.random.default_rng(1), sensors=LABELS,
                actuators=LABELS[:1])
    cm = sd.identify(frf, poles=lam, progress=False)
    assert np.all(np.isfinite(cm.frequency_std)) and np.all(cm.frequency_std > 0)
    # a model built by hand has no statistics: NaN, and residue_std NaN too
    bare = sd.ComplexModeModel(cm.poles, cm.residues)
    assert np.all(np.isnan(bare.frequency_std)) and np.all(np.isnan(bare.damping_std))
    assert np.all(np.isnan(bare.residue_std()))
    # both parts of (3.58): the part through the poles matters, and the total matches the
    # scatter of the residues over noise draws
    total, direct = cm.residue_std(), cm.residue_std(direct_only=True)
    assert np.any(np.abs(total - direct) > 0.05 * direct)
    rng = np.random.default_rng(5)
    est = []
    for _ in range(40):
        est.append(sd.identify(noisy(freq, H0, 0.02, rng, sensors=LABELS,
                                     actuators=LABELS[:1]), poles=lam, progress=False).residues)
    est = np.array(est)
    emp = np.sqrt(np.var(est.real, axis=0) + np.var(est.imag, axis=0))
    assert 0.75 < np.median(emp / total) < 1.33
    # the residue error is of the order of the noise (2%) relative to the residue
    assert 0.002 < np.median(total / np.abs(cm.residues)) < 0.05
    path = tmp_path / "cm.npz"
    sd.save(cm, path)
    back = sd.load(path)
    assert np.array_equal(back.frequency_std, cm.frequency_std)
    assert np.array_equal(back.residue_std(), total)
