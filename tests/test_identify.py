"""Complex-mode identification (thesis 3.2, 3.4): initial poles, identify, ComplexModeModel.

The reference data set is a known 10-mode MIMO model (10 sensors x 3 actuators) in a
20-60 Hz band: a close pair 0.5% apart (33.0 Hz at 0.3% damping, 33.165 Hz at 1.2%), a
local mode at 44 Hz seen by two sensors 40 dB below the others, and modes just outside
the band on both sides (17 Hz and 66 Hz).
"""

import warnings

import numpy as np
import pytest

import sdctrl as sd
from sdctrl.identification import IdentificationWarning
from sdctrl.identification._complex_modes import ComplexModeModel, frf_array

F_TRUE = np.array([17.0, 24.0, 29.0, 33.0, 33.165, 38.0, 44.0, 50.0, 55.0, 66.0])
Z_TRUE = np.array([0.01, 0.008, 0.006, 0.003, 0.012, 0.01, 0.005, 0.007, 0.009, 0.01])
IN_BAND = (F_TRUE > 20) & (F_TRUE < 60)
BAND = (20.0, 60.0)


def _truth():
    rng = np.random.default_rng(123)
    w = 2 * np.pi * F_TRUE
    lam = -Z_TRUE * w + 1j * w * np.sqrt(1 - Z_TRUE**2)
    c = rng.standard_normal((10, 10)) + 0.15j * rng.standard_normal((10, 10))
    b = rng.standard_normal((10, 3)) + 0.15j * rng.standard_normal((10, 3))
    R = np.einsum("ji,jk->jik", c, b) / (2j * lam.imag)[:, None, None]
    # local mode: two sensors, 40 dB below the neighbouring modes
    R[6] = 0.0
    R[6, 3:5, :] = (np.mean(np.abs(R[[5, 7]])) * 0.01 * (1 + 0.2j)
                    * np.outer([1, -0.7], [1, 0.5, -0.8]))
    return lam, R


def ten_mode(noise=0.0, seed=1, df=0.05, quantity="displacement"):
    lam, R = _truth()
    freq = np.arange(BAND[0], BAND[1] + 1e-9, df)
    s = 2j * np.pi * freq
    H = frf_array(lam, R, np.zeros((10, 3)), np.zeros((10, 3)), s)
    if noise:
        g = np.random.default_rng(seed)
        H = H * (1 + noise * (g.standard_normal(H.shape) + 1j * g.standard_normal(H.shape))
                 / np.sqrt(2))
    frf = sd.FRF(freq, H, sensors=[f"N{i}.y" for i in range(10)],
                 actuators=["S1.y", "S2.y", "S3.y"], collocated=[(0, 0)])
    return (frf.to(quantity) if quantity != "displacement" else frf), lam, R


def _match(cm, lam):
    """Index in cm of the pole closest to each true pole (one to one)."""
    idx = [int(np.argmin(np.abs(cm.poles - p))) for p in lam]
    assert len(set(idx)) == len(idx), "two true poles matched the same identified pole"
    return np.array(idx)


def _errors(cm, lam, R):
    i = _match(cm, lam)
    fe = np.abs(cm.frequency[i] / (np.abs(lam) / 2 / np.pi) - 1)
    ze = np.abs(cm.damping[i] / (-lam.real / np.abs(lam)) - 1)
    re = np.array([np.linalg.norm(cm.residues[i[j]] - R[j]) / np.linalg.norm(R[j])
                   for j in range(lam.size)])
    return fe, ze, re


# --------------------------------------------------------------------------------------
# initial poles
# --------------------------------------------------------------------------------------
def test_initial_poles_propose_close_pair_and_cmif_mode():
    frf, _lam, _ = ten_mode()
    p0 = sd.initial_poles(frf)
    f0 = np.abs(p0) / 2 / np.pi
    assert np.all(p0.imag > 0) and np.all(p0.real < 0)
    np.testing.assert_allclose(-p0.real / np.abs(p0), 0.01, rtol=1e-12)    # 1% default
    for f in (24.0, 29.0, 33.0, 33.165, 38.0, 50.0, 55.0):                 # both of the pair
        assert np.min(np.abs(f0 - f)) < 0.06, f
    assert sd.initial_poles(frf, n=3).size == 3
    # a heavily damped mode beside a lightly damped one: only sigma_2 shows it
    freq = np.arange(10, 30, 0.02)
    s = 2j * np.pi * freq
    lamh = np.array([-0.002 * 2 * np.pi * 20 + 2j * np.pi * 20,
                     -0.02 * 2 * np.pi * 20.4 + 2j * np.pi * 20.4])
    R = np.zeros((2, 4, 2), complex)
    R[0] = np.outer([1, 1, 1, 1], [1, 1]) / 1j
    R[1] = np.outer([1, -1, 1, -1], [1, -1]) * 0.5 / 1j
    frf2 = sd.FRF(freq, frf_array(lamh, R, np.zeros((4, 2)), np.zeros((4, 2)), s))
    from scipy.signal import find_peaks

    from sdctrl.identification._peaks import indicator_functions
    summed = indicator_functions(frf2.H)[:, 0]
    assert find_peaks(summed)[0].size == 1              # the summed FRF misses it
    f2 = np.abs(sd.initial_poles(frf2)) / 2 / np.pi
    assert np.min(np.abs(f2 - 20.4)) < 0.05 and np.min(np.abs(f2 - 20.0)) < 0.03


# --------------------------------------------------------------------------------------
# noise-free identification with no poles given
# --------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def clean_fit():
    frf, lam, R = ten_mode()
    cm = sd.identify(frf, band=BAND, progress=False)
    return frf, lam, R, cm


def test_noise_free_every_pole_no_spurious(clean_fit):
    _frf, lam, R, cm = clean_fit
    assert cm.n == 10                                       # every pole, no spurious one
    fe, ze, re = _errors(cm, lam, R)
    # measured: freq 6e-14, damping 4e-11, residues 8e-12 relative (max over the 10 modes)
    assert fe.max() < 1e-5
    assert np.max(np.abs(cm.damping[_match(cm, lam)] - Z_TRUE)) < 1e-3
    assert ze.max() < 1e-3
    assert re.max() < 1e-4
    # out-of-band modes are returned and marked
    np.testing.assert_array_equal(cm.in_band[_match(cm, lam)], IN_BAND)
    assert cm.cost < 1e-6
    assert np.all(np.diff(cm.frequency) > 0)
    assert cm.band == BAND


@pytest.mark.parametrize("act", [0, 1, 2])
def test_noise_free_single_reference_out_of_band_poles(act):
    """One actuator of the 10-mode set (10 x 1, single reference), no poles given: the
    modes at 17 and 66 Hz are found as out-of-band poles.  Before: the out-of-band trials
    ran once, on the first fit, when two in-band modes were still missing; the trial pole
    was pulled to a bound by their residual, the side never retried, and the fit ended
    with 7 poles (actuator 0: no out-of-band pole, 38 Hz mode at 1.16% damping instead
    of 1.0%, cost 2.5e-2).  Measured now (actuators 0/1/2): 10 poles, damping errors
    <= 3e-9 absolute, frequency errors <= 1e-9 relative, residues <= 4e-8 relative, cost
    1.2e-8..1.5e-8, 0.5-1.8 s."""
    frf, lam, R = ten_mode()
    one = sd.FRF(frf.freq, frf.H[:, :, act:act + 1], sensors=frf.sensors,
                 actuators=[frf.actuators[act]])
    cm = sd.identify(one, band=BAND, progress=False)
    assert cm.n == 10                                       # every pole, no spurious one
    i = _match(cm, lam)
    np.testing.assert_array_equal(cm.in_band[i], IN_BAND)   # 17 and 66 Hz flagged
    assert np.max(np.abs(cm.frequency[i] / F_TRUE - 1)) < 1e-5
    assert np.max(np.abs(cm.damping[i] - Z_TRUE)) < 1e-5    # MIMO noise-free level
    Rj = R[:, :, act:act + 1]
    re = [np.linalg.norm(cm.residues[i[j]] - Rj[j]) / np.linalg.norm(Rj[j]) for j in range(10)]
    assert max(re) < 1e-4
    assert cm.cost < 1e-6


def test_statespace_reproduces_model(clean_fit):
    frf, _, _, cm = clean_fit
    sys = cm.to_statespace()
    H = sd.FRF.from_system(sys, frf.freq).H
    Hm = cm.frf(frf.freq).H
    assert np.abs(H - Hm).max() < 1e-8 * np.abs(Hm).max()
    assert np.isrealobj(sys.A) and np.isrealobj(sys.B) and np.isrealobj(sys.C)
    assert list(sys.output_labels) == [f"N{i}_y" for i in range(10)]
    assert list(sys.input_labels) == ["S1_y_u", "S2_y_u", "S3_y_u"]
    # the A matrix is block diagonal 2x2 with the identified poles
    ev = np.linalg.eigvals(sys.A)
    for p in cm.poles:
        assert np.min(np.abs(ev - p)) < 1e-8 * abs(p)


def test_statespace_all_quantities_and_asymptotic_terms():
    lam, R = _truth()
    rng = np.random.default_rng(0)
    cm = ComplexModeModel(lam, R, E=1e-6 * rng.standard_normal((10, 3)),
                          F=rng.standard_normal((10, 3)))
    f = np.linspace(20, 60, 300)
    sys = cm.to_statespace()                                   # E feedthrough, F/s^2 exact
    H0 = cm.frf(f).H
    assert np.abs(sd.FRF.from_system(sys, f).H - H0).max() < 1e-8 * np.abs(H0).max()
    cm0 = cm.replace(E=None)
    Hv = cm0.frf(f, "velocity").H                             # F/s by an integrator, exact
    sysv = cm0.to_statespace("velocity")
    assert np.abs(sd.FRF.from_system(sysv, f).H - Hv).max() < 1e-8 * np.abs(Hv).max()
    # acceleration: non-proper part through the correction filter, ~2 f/f_c accurate
    Ha = cm.frf(f, "acceleration").H
    sysa = cm.to_statespace("acceleration")
    assert np.abs(sd.FRF.from_system(sysa, f).H - Ha).max() < 0.05 * np.abs(Ha).max()
    with pytest.raises(ValueError, match="quantity"):
        cm.to_statespace("jerk")


# --------------------------------------------------------------------------------------
# noise: 50 draws, statistics of the estimates
# --------------------------------------------------------------------------------------
def test_noise_draws_errors_within_three_std():
    """1% proportional noise, 50 draws, 0.05 Hz lines, varpro started from the exact poles.

    Measured (in-band modes, 49 of 50 draws; in one draw the weak local mode is pushed to
    the edge of its search window and the fit reports it in ``warnings``):
    relative frequency std 6e-6 .. 7e-5 (local mode 5.7e-4), damping std 0.1% .. 0.6%
    relative (local mode 25%); 99.7% of the frequency and 99.2% of the damping errors lie
    within 3 std; the bias is below 3 standard errors except for the local mode (0.8 std).
    """
    lam, R = _truth()
    est_f, est_z, est_r = [], [], []
    flagged = 0
    for seed in range(50):
        frf, _, _ = ten_mode(noise=0.01, seed=seed)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", IdentificationWarning)
            cm = sd.identify(frf, poles=lam, band=BAND, progress=False)
        if cm.warnings:
            flagged += 1
            continue
        i = _match(cm, lam)
        est_f.append(cm.frequency[i])
        est_z.append(cm.damping[i])
        est_r.append(cm.residues[i])
    assert flagged <= 2
    est_f, est_z, est_r = map(np.array, (est_f, est_z, est_r))
    nd = est_f.shape[0]
    ib = IN_BAND
    for est, true in ((est_f[:, ib], F_TRUE[ib]), (est_z[:, ib], Z_TRUE[ib])):
        std = est.std(axis=0, ddof=1)
        err = est - true
        within = np.abs(err) <= 3 * std
        print("fraction within 3 std", within.mean(), "relative std", std / true)
        assert within.mean() >= 0.98                 # 99.7% for a normal distribution
        bias = np.abs(err.mean(axis=0))
        assert np.all(bias <= std)                   # bias well inside the spread
        strong = np.arange(10)[ib] != 6              # all but the local mode: unbiased
        assert np.all(bias[strong] <= 3 * std[strong] / np.sqrt(nd))
    assert np.max(est_f[:, ib].std(axis=0) / F_TRUE[ib]) < 2e-3
    # residues: RMS error within 3 std of the residue estimates
    rerr = np.linalg.norm(est_r - R[None], axis=(2, 3))
    rstd = np.sqrt(np.sum(est_r.var(axis=0), axis=(1, 2)))
    assert np.all(np.sqrt(np.mean(rerr[:, ib] ** 2, axis=0)) <= 3 * rstd[ib])


def test_noisy_auto_finds_in_band_modes():
    frf, lam, _R = ten_mode(noise=0.01, seed=0)
    cm = sd.identify(frf, band=BAND, progress=False)
    ib = cm.in_band
    assert ib.sum() == IN_BAND.sum()                   # 8 in-band modes, none spurious
    i = [int(np.argmin(np.abs(cm.poles[ib] - p))) for p in lam[IN_BAND]]
    assert len(set(i)) == 8
    fe = np.abs(cm.frequency[ib][i] / F_TRUE[IN_BAND] - 1)
    assert fe.max() < 2e-3
    assert cm.cost < 0.011                             # the noise level


# --------------------------------------------------------------------------------------
# automatic pole selection on noisy data: no spurious pole, weak real modes kept
# --------------------------------------------------------------------------------------
def _chain_model():
    """Three masses on springs with a dashpot between masses 1 and 2 (non-proportional
    damping): the data of the package's first demo."""
    from scipy.linalg import eigh

    m = np.array([1.0, 1.5, 0.8])
    k = np.array([4.0e4, 3.0e4, 2.5e4])          # N/m, ground-1, 1-2, 2-3
    M = np.diag(m)
    K = np.array([[k[0] + k[1], -k[1], 0], [-k[1], k[1] + k[2], -k[2]], [0, -k[2], k[2]]])
    C = 2e-5 * K + np.array([[0, 0, 0], [0, 6.0, -6.0], [0, -6.0, 6.0]])
    w2, phi = eigh(K, M)
    dofs = ["N1.x", "N2.x", "N3.x"]
    b = np.eye(3)[:, [0, 2]]
    return sd.NormalModeModel(np.diag(w2), phi.T @ C @ phi, phi, phi.T @ b, sensors=dofs,
                              actuators=["N1.x", "N3.x"], shapes=phi, dofs=dofs)


def _chain_demo(seed=0, noise=0.01, floor=1e-3):
    """The package's first demo data: 3-mode chain, accelerations 2-80 Hz, 1200 lines, 1%
    noise plus an additive floor of 1e-3 of each channel's peak (noise-dominated at low
    frequency, as real accelerometer tests)."""
    model = _chain_model()
    freq = np.linspace(2.0, 80.0, 1200)
    exact = model.frf(freq, "acceleration")
    rng = np.random.default_rng(seed)
    scale = noise * np.abs(exact.H) + floor * np.abs(exact.H).max(axis=0, keepdims=True)
    H = exact.H + scale * (rng.standard_normal(exact.H.shape)
                           + 1j * rng.standard_normal(exact.H.shape)) / np.sqrt(2)
    frf = sd.FRF(freq, H, "acceleration", sensors=exact.sensors, actuators=exact.actuators,
                 collocated=[(0, 0), (2, 1)])
    return frf, np.asarray(model.poles)


def test_noisy_demo_chain_three_poles_only():
    """Before the heteroscedastic significance test: 10 poles (7 noise poles at 7-66 Hz,
    0.1-0.5% damping) in 17 s.  Measured now (seed 0): 3 poles, frequency errors
    <= 2.8e-5, damping errors <= 0.5% relative (seeds 0-2: <= 9e-5 and <= 0.8%), 1.7 s;
    seeds 0-5 at 1% noise and at 3% noise with a
    3e-3 floor: 3 poles in all twelve, 0.5-7.5 s."""
    frf, lam = _chain_demo()
    cm = sd.identify(frf, progress=False)
    assert cm.in_band.sum() == 3 and cm.n == 3
    i = _match(cm, lam)
    f_true = np.abs(lam) / (2 * np.pi)
    z_true = -lam.real / np.abs(lam)
    np.testing.assert_allclose(cm.frequency[i], f_true, rtol=1e-3)
    np.testing.assert_allclose(cm.damping[i], z_true, rtol=0.1)


def test_noisy_ten_mode_no_spurious_pole():
    """1% proportional noise, no poles given, 12 noise draws.  Before: the local mode
    (40 dB down) found in 4 of seeds 0-5 and a spurious pole near 33 Hz in one.  Measured
    now: no spurious pole in any of seeds 0-13 at 1% (nor 0-3 at 3%); the local mode found
    in 12 of the 14 seeds at 1% (missed in seeds 6 and 12; at 3% noise it sits below the
    noise and is never found); 0.5-1.8 s per draw (before: 2-7 s)."""
    local = 0
    for seed in range(12):
        frf, _lam, _R = ten_mode(noise=0.01, seed=seed)
        cm = sd.identify(frf, band=BAND, progress=False)
        f = cm.frequency[cm.in_band]
        strong = F_TRUE[IN_BAND & (np.arange(10) != 6)]
        assert all(np.min(np.abs(f - ft)) / ft < 1e-3 for ft in strong), seed
        # every in-band pole is one of the true modes (the local one within 0.2%)
        spurious = [x for x in f if np.min(np.abs(F_TRUE[IN_BAND] - x)) / x > 2e-3]
        assert not spurious, (seed, spurious)
        local += bool(np.min(np.abs(f - 44.0)) / 44.0 < 2e-3)
    assert local >= 10                                 # measured 11 of 12


def test_noisy_testbed_twelve_modes():
    """Testbed FRF (31 sensors x 6 shakers, 1000 lines 8-60 Hz), 1% noise: the 12 in-band
    modes, the close pair 15.79/15.87 Hz separated, the mode near 63 Hz flagged out of
    band.  Measured (seeds 0-2 at 1% and 3%): 12 in-band poles in all six, 1.3-3.3 s
    (before: 3-9 s)."""
    from sdctrl.testbeds._truss import TESTBED_BAND

    f_true = np.array([9.518, 12.66, 15.786, 15.872, 18.135, 18.63, 27.60, 43.83, 48.42,
                       52.90, 54.73, 56.40])
    cm = sd.identify(sd.testbed_frf(noise=0.01, seed=2), band=TESTBED_BAND, progress=False)
    f = cm.frequency[cm.in_band]
    assert f.size == 12
    assert np.max(np.abs(np.sort(f) / f_true - 1)) < 1e-3
    assert np.all((cm.frequency[~cm.in_band] < TESTBED_BAND[0])
                  | (cm.frequency[~cm.in_band] > TESTBED_BAND[1]))


# --------------------------------------------------------------------------------------
# optimisers, parametrisations, quantities
# --------------------------------------------------------------------------------------
def test_gradient_and_varpro_reach_the_same_optimum():
    frf, lam, R = ten_mode(df=0.1)
    lam0 = np.abs(lam) * (1 + 1e-3) * np.exp(1j * np.angle(lam))       # 0.1% off
    lam0 = lam0.real * 1.3 + 1j * lam0.imag                            # 30% off in damping
    out = {}
    for opt in ("varpro", "gradient"):
        cm = sd.identify(frf, poles=lam0, band=BAND, optimizer=opt, progress=False)
        out[opt] = (cm,)
        fe, ze, re = _errors(cm, lam, R)
        assert fe[IN_BAND].max() < 1e-6 and ze[IN_BAND].max() < 1e-4, opt
        assert re[IN_BAND].max() < 1e-3 and fe.max() < 1e-4, opt
    assert out["varpro"][0].search.converged
    assert out["gradient"][0].search.converged
    # variable projection needs far fewer cost evaluations than the sign-gradient
    assert out["varpro"][0].search.nfev < out["gradient"][0].search.nfev
    cm = sd.identify(frf, poles=lam0, band=BAND, optimizer="none", progress=False)
    assert cm.cost > 1e-3                             # residues only: poles not updated
    np.testing.assert_allclose(cm.poles, lam0)


def test_quantity_residues_describe_displacement():
    for q in ("velocity", "acceleration"):
        frf, lam, R = ten_mode(quantity=q, df=0.1)
        cm = sd.identify(frf, poles=lam, band=BAND, progress=False)
        fe, _ze, re = _errors(cm, lam, R)
        assert fe.max() < 1e-8 and re.max() < 1e-6
        Hq = cm.frf(frf.freq, q)
        assert Hq.quantity == q
        assert sd.updating.relative_error(Hq, frf) < 1e-7


def test_real_mode_parametrisation():
    # proportional damping: purely imaginary residues, the real-mode model (3.9) is exact
    lam, R = _truth()
    Rr = 1j * np.abs(R) * np.sign(R.imag)
    freq = np.arange(20, 60, 0.1)
    H = frf_array(lam, Rr, np.zeros((10, 3)), np.zeros((10, 3)), 2j * np.pi * freq)
    frf = sd.FRF(freq, H)
    cm = sd.identify(frf, poles=lam, model="real", progress=False)
    i = _match(cm, lam)
    assert np.max(np.abs(cm.residues[i] - Rr)) < 1e-6 * np.abs(Rr).max()
    assert np.abs(cm.residues.real).max() == 0
    # on non-proportional (complex) data it leaves a larger error than the complex model
    frf2, lam2, _ = ten_mode(df=0.1)
    c_real = sd.identify(frf2, poles=lam2, model="real", progress=False).cost
    c_cplx = sd.identify(frf2, poles=lam2, model="complex", progress=False).cost
    assert c_real > 100 * c_cplx


def test_compression_and_determinism():
    frf, lam, R = ten_mode(df=0.1)
    lam0 = lam * (1 + 2e-4)
    a = sd.identify(frf, poles=lam0, band=BAND, progress=False, compress_rank=24)
    b = sd.identify(frf, poles=lam0, band=BAND, progress=False, compress_rank=0)
    assert a.search.compress_rank == 24 and b.search.compress_rank == 30
    # noise-free data have rank 22 (2 per pole + E + F): compression to 24 is exact
    np.testing.assert_allclose(a.poles, b.poles, rtol=1e-9)
    np.testing.assert_allclose(a.residues, b.residues, atol=1e-7 * np.abs(R).max())
    frfn, _, _ = ten_mode(noise=0.01, seed=3, df=0.1)
    c = sd.identify(frfn, band=BAND, progress=False, compress_rank=26, seed=5)
    d = sd.identify(frfn, band=BAND, progress=False, compress_rank=26, seed=5)
    np.testing.assert_array_equal(c.poles, d.poles)                   # deterministic
    np.testing.assert_array_equal(c.residues, d.residues)
    from sdctrl.identification._compression import compress
    H = np.tile(frf.H.reshape(frf.freq.size, -1), (1, 20))            # 600 channels
    V, sv = compress(H, 30, seed=1)                                   # randomised path
    _Vx, svx = compress(H, 30, seed=2)
    np.testing.assert_allclose(sv[:19], svx[:19], rtol=1e-8)
    assert np.allclose(V.T @ V, np.eye(30), atol=1e-10)
    Y = np.vstack([H.real, H.imag])
    assert np.linalg.norm(Y - (Y @ V) @ V.T) < 1e-8 * np.linalg.norm(Y)


# --------------------------------------------------------------------------------------
# minimality, scaling, variance
# --------------------------------------------------------------------------------------
def test_singular_value_ratios_and_minimal():
    frf, lam, R = ten_mode(noise=0.01, seed=4, df=0.1)
    cm = sd.identify(frf, poles=lam, band=BAND, progress=False)
    ratios = cm.singular_value_ratios()
    assert ratios.shape == (10, 3)
    np.testing.assert_allclose(ratios[:, 0], 1.0)
    strong = IN_BAND & (np.arange(10) != 6)            # the local mode is at the noise level
    assert np.all(ratios[strong, 1] < 0.05)            # noise only: nearly dyadic
    mini = cm.minimal()
    assert np.all(mini.singular_value_ratios()[:, 1] < 1e-12)
    # the dyad is closer to the truth than the full-rank noisy residue (in-band modes)
    i = _match(cm, lam)
    e_full = np.linalg.norm(cm.residues[i] - R, axis=(1, 2))
    e_min = np.linalg.norm(mini.residues[i] - R, axis=(1, 2))
    assert np.mean(e_min[strong] / e_full[strong]) < 0.8
    assert np.allclose(cm.minimal(multiplicity=3).residues, cm.residues)
    with pytest.raises(ValueError, match="multiplicity"):
        cm.minimal(0)


def _collocated_model(n_pairs=3):
    rng = np.random.default_rng(7)
    lam, _ = _truth()
    ns, na = 6, 3
    cpsi = rng.standard_normal((ns, 10)) + 0.1j * rng.standard_normal((ns, 10))
    psib = rng.standard_normal((10, na)) + 0.1j * rng.standard_normal((10, na))
    for a in range(na):                                 # sensor a collocated with actuator a
        psib[:, a] = cpsi[a]
    R = np.einsum("sj,ja->jsa", cpsi, psib)
    pairs = [(a, a) for a in range(n_pairs)]
    return ComplexModeModel(lam, R, collocated=pairs), cpsi, psib


def test_scaled_collocated():
    cm, cpsi, psib = _collocated_model()
    c, b, info = cm.scaled(return_info=True)
    sign = np.sign((c[0] / cpsi[0]).real)                 # sqrt sign is arbitrary
    np.testing.assert_allclose(c * sign, cpsi, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(b * sign[:, None], psib, rtol=1e-10, atol=1e-12)
    assert np.all(info["spread"] < 1e-10)
    c1, _b1 = cm.scaled(collocated=[(1, 1)])
    np.testing.assert_allclose(np.abs(c1), np.abs(cpsi), rtol=1e-10)
    # inconsistent collocation (a 20% error on one collocated FRF): spread reported, warned
    R = cm.residues.copy()
    R[:, :, 2] *= 1.2
    bad = cm.replace(residues=R)
    with pytest.warns(RuntimeWarning, match="disagree"):
        _, _, info = bad.scaled(return_info=True)
    assert np.all(info["spread"] > 0.05)
    with pytest.raises(ValueError, match="collocated"):
        cm.replace(collocated=()).scaled()


@pytest.mark.parametrize("weighting", ["none", "level"])
def test_residue_std_matches_monte_carlo(weighting):
    """The residues' std (3.58)-(3.59) of each line weighting against 200 noise draws
    (measured ratio 1.001 unweighted, 0.995 level-weighted).  The default ("auto") keeps the
    level-weighted fit on every draw here (noise relative to the response, as the coherence
    declares: its maximum-likelihood fit), while the noise-free H0 the std is predicted from
    is fitted unweighted: the two are compared for one weighting at a time."""
    lam, R = _truth()
    freq = np.arange(20, 60, 0.1)
    s = 2j * np.pi * freq
    H0 = frf_array(lam, R, np.zeros((10, 3)), np.zeros((10, 3)), s)
    coh = np.full(H0.shape, 0.9999)
    sig = np.abs(H0) * np.sqrt(1 - coh)                   # (3.59)
    rng = np.random.default_rng(0)
    est = []
    for _ in range(200):
        e = (rng.standard_normal(H0.shape) + 1j * rng.standard_normal(H0.shape)) / np.sqrt(2)
        frf = sd.FRF(freq, H0 + sig * e, coherence=coh)
        est.append(sd.identify(frf, poles=lam, optimizer="none", progress=False,
                               weighting=weighting).residues)
    mc = np.sqrt(np.var(np.array(est), axis=0).sum(axis=0) if False else
                 np.var(np.array(est).real, axis=0) + np.var(np.array(est).imag, axis=0))
    cm = sd.identify(sd.FRF(freq, H0, coherence=coh), poles=lam, optimizer="none",
                     progress=False, weighting=weighting)
    pred = cm.residue_std(sd.FRF(freq, H0, coherence=coh))
    noisy = sd.identify(frf, poles=lam, optimizer="none", progress=False)
    assert noisy.search.weighting == "level" and cm.search.weighting == weighting
    assert pred.shape == R.shape
    ratio = np.median(mc / pred)
    assert 0.9 < ratio < 1.1
    # poles given, not estimated: only the direct part, as stored by identify
    assert np.allclose(cm.residue_std(), pred)
    assert np.allclose(cm.residue_std(sd.FRF(freq, H0, coherence=coh), direct_only=True), pred)
    # without coherence the noise comes from the residual: exact data, no spread
    assert np.all(cm.residue_std(sd.FRF(freq, H0)) < 1e-6 * pred)


# --------------------------------------------------------------------------------------
# bad input, immutability, warnings
# --------------------------------------------------------------------------------------
def test_bad_input():
    frf, lam, _ = ten_mode(df=0.1)
    with pytest.raises(ValueError, match="band"):
        sd.identify(frf, band=(30, 30))
    with pytest.raises(ValueError, match="band"):
        sd.identify(frf, band=(100, 200))
    with pytest.raises(ValueError, match="band"):
        sd.initial_poles(frf, band=(40, 30))
    with pytest.raises(ValueError, match="frequency lines"):
        sd.identify(frf, poles=lam, band=(30, 30.5))
    with pytest.raises(ValueError, match="stable"):
        sd.identify(frf, poles=[0.1 + 200j])
    with pytest.raises(ValueError, match="upper half-plane"):
        sd.identify(frf, poles=[-0.1 - 200j])
    with pytest.raises(ValueError, match="finite"):
        sd.identify(frf, poles=[np.nan + 200j])
    with pytest.raises(ValueError, match="finite"):
        sd.identify(frf, poles=[complex(-1, np.inf)])
    H = frf.H.copy()
    H[3, 0, 0] = np.nan
    with pytest.raises(ValueError, match="H"):
        sd.FRF(frf.freq, H)
    with pytest.raises(ValueError, match="model"):
        sd.identify(frf, poles=lam, model="modal")
    with pytest.raises(ValueError, match="optimizer"):
        sd.identify(frf, poles=lam, optimizer="newton")
    with pytest.raises(ValueError, match="in_band"):
        sd.identify(frf, poles=lam, band=BAND, in_band=[True] * 3)
    with pytest.raises(TypeError, match="frf"):
        sd.identify(frf.H)
    with pytest.raises(ValueError, match="damping"):
        sd.initial_poles(frf, damping=1.5)


def test_inputs_not_modified():
    frf, lam, _ = ten_mode(df=0.1)
    lam_in = lam.copy()
    H_in = frf.H.copy()
    sd.identify(frf, poles=lam_in, band=BAND, progress=False)
    np.testing.assert_array_equal(lam_in, lam)
    np.testing.assert_array_equal(frf.H, H_in)


def test_trouble_is_reported():
    frf, lam, _ = ten_mode(df=0.1)
    # a duplicated pole: ill-conditioned basis, warned and recorded in info
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        cm = sd.identify(frf, poles=np.append(lam, lam[3]), band=BAND, optimizer="none",
                         progress=False)
    msgs = [str(w.message) for w in rec if issubclass(w.category, IdentificationWarning)]
    assert msgs and cm.warnings
    assert any("converge" in m or "ill-conditioned" in m for m in msgs)


def test_progress_bar_and_interrupt(monkeypatch, capsys):
    frf, lam, _ = ten_mode(df=0.1)
    sd.identify(frf, poles=lam, band=BAND, progress=True)
    assert "identify" in capsys.readouterr().err                 # tqdm bar on stderr
    # Ctrl-C during the automatic selection returns the last complete fit, flagged
    from sdctrl.identification._selection import AutoSelection

    def interrupt(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(AutoSelection, "missed", interrupt)
    monkeypatch.setattr(AutoSelection, "prune", lambda *a, **k: None)
    # (no pole searched alone: it would finish this noise-free fit before the scan)
    monkeypatch.setattr("sdctrl.identification._selection.travel", lambda *a: None)
    with pytest.warns(IdentificationWarning, match="interrupted"):
        cm = sd.identify(frf, band=BAND, progress=False)
    assert cm.search.interrupted and cm.n > 0


def test_a_poor_fit_warns_where_the_error_lies_and_what_to_try():
    """Issue 26: a fit error above 10% is never silent; a good fit says nothing."""
    frf = sd.testbed_frf(noise=0.0).band(12.0, 20.0)
    with pytest.warns(sd.identification.IdentificationWarning,
                      match=r"relative fit error of 8\d\.\d% \(above 10%\); \d+% of it lies in "
                            r"[\d.]+-[\d.]+ Hz.*largest channels .*Try band="):
        cm = sd.identify(frf, poles=[-0.01 * 2 * np.pi * 15.8 + 2j * np.pi * 15.8])
    assert cm.cost > 0.8
    with warnings.catch_warnings():
        warnings.simplefilter("error", sd.identification.IdentificationWarning)
        assert sd.identify(frf).cost < 1e-3
