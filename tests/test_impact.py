"""Impact tests (API.md "Real tests"): ``sd.impact_frf`` on simulated hammer hits of a known
3-mode system, damping corrected for the exponential window, double hits and overloads, and
one meaning of ``band`` in ``identify``."""

import functools
import pathlib
import warnings

import numpy as np
import pytest
from scipy import signal

import sdctrl as sd

FN = np.array([12.0, 31.0, 55.0])            # Hz
ZN = np.array([0.01, 0.008, 0.015])
PHI = np.array([[1.0, 0.8, 0.5], [0.6, -0.7, 1.0]])      # 2 sensors x 3 modes
B = np.array([0.9, 0.7, -0.8])                             # the hit point
FS, N = 512.0, 1024                                        # 2 s records, 0.5 Hz lines


def _system():
    w = 2 * np.pi * FN
    A = np.zeros((6, 6))
    A[:3, 3:] = np.eye(3)
    A[3:, :3] = -np.diag(w**2)
    A[3:, 3:] = -np.diag(2 * ZN * w)
    Bm = np.zeros((6, 1))
    Bm[3:, 0] = B
    C = np.zeros((2, 6))
    C[:, :3] = PHI
    return signal.StateSpace(A, Bm, C, np.zeros((2, 1)))


def _hits(noise=0.01, seed=0, double=None, clip=None, nh=5, force_noise=None):
    """Half-sine hammer pulses (6-8 ms) of random size and time, exact responses (lsim with
    first-order hold) of the displacement of 2 sensors, noise of ``noise`` times each
    record's peak on the responses and of ``force_noise`` (default ``noise``) on the force."""
    force_noise = noise if force_noise is None else force_noise
    rng = np.random.default_rng(seed)
    sys = _system()
    t = np.arange(N) / FS
    out = []
    for k in range(nh):
        t0, wid = 0.02 + 0.004 * rng.random(), 0.006 + 0.002 * rng.random()
        amp = 100 * (1 + 0.2 * rng.random())
        f = np.where((t >= t0) & (t < t0 + wid), amp * np.sin(np.pi * (t - t0) / wid), 0.0)
        if k == double:              # a second pulse 50 ms later, 40% of the first
            t1 = t0 + 0.05
            f = f + np.where((t >= t1) & (t < t1 + wid),
                             0.4 * amp * np.sin(np.pi * (t - t1) / wid), 0.0)
        _, y, _ = signal.lsim(sys, f, t)
        y = y + noise * np.abs(y).max(axis=0) * rng.standard_normal(y.shape)
        f = f + force_noise * amp * rng.standard_normal(N)
        if k == clip:                # the first response saturates at 70% of its peak
            top = 0.7 * np.abs(y[:, 0]).max()
            y[:, 0] = np.clip(y[:, 0], -top, top)
        out.append((f, y))
    return out


def _frf(hits, **kw):
    kw = {"force_window": 0.1, "exponential": 0.01, "quantity": "receptance",
          "sensors": ["x1", "x2"], "actuator": "x1"} | kw
    return sd.impact_frf(hits, FS, **kw)


@pytest.fixture(scope="module")
def noisy():
    with warnings.catch_warnings():
        warnings.simplefilter("error", sd.ImpactWarning)      # clean hits: no fault reported
        frf = _frf(_hits())
    return frf, sd.identify(frf.band(5, 100), progress=False)


def test_impact_frf_layout_and_window(noisy):
    frf, _ = noisy
    assert frf.shape == (N // 2, 2, 1) and frf.quantity == "displacement"
    np.testing.assert_allclose(frf.freq, np.arange(1, N // 2 + 1) * FS / N)
    T = (N - 1) / FS
    assert frf.exponential_tau == pytest.approx(T / np.log(100), rel=1e-12)
    assert frf.collocated == ((0, 0),)                   # sensor "x1" at the hit point "x1"
    # coherence is high at the modes (1% noise) and the FRF matches the exact receptance
    k = np.searchsorted(frf.freq, FN)
    assert np.all(frf.coherence[k] > 0.99)
    assert sd.impact_frf(_hits(nh=1), FS).exponential_tau is None
    assert frf.averages == 5 and sd.impact_frf(_hits(nh=1), FS).averages == 1


def test_damping_corrected_for_exponential_window(noisy):
    frf, cm = noisy
    assert cm.n == 3 and np.all(cm.in_band)
    np.testing.assert_allclose(cm.frequency, FN, rtol=1e-3)
    err = np.abs(cm.damping / ZN - 1)
    assert err.max() < 0.05, err                         # measured: 2.7%, 4.3%, 1.0%
    assert cm.exponential_tau == frf.exponential_tau
    # the window's share: poles shifted back by exactly 1/tau
    plain = sd.FRF(frf.freq, frf.H, quantity=frf.quantity)
    raw = sd.identify(plain.band(5, 100), progress=False)
    assert raw.exponential_tau is None and raw.n == 3
    np.testing.assert_allclose(cm.poles.real - raw.poles.real, 1 / frf.exponential_tau,
                               rtol=1e-6)
    # (the two fits converge separately: their poles agree to the search's tolerance, measured
    # 1.6e-11 since the significance of windowed data meets the window's second differences)
    np.testing.assert_allclose(cm.poles.imag, raw.poles.imag, rtol=1e-10)
    raw_err = np.abs(raw.damping / ZN - 1)
    assert np.all(raw_err > 0.3) and np.all(raw_err > 5 * err)    # uncorrected: 36-300% off


def test_noise_free_exact_and_estimators_agree():
    hits = _hits(noise=0.0)
    H = {e: _frf(hits, estimator=e) for e in ("H1", "H2", "Hv")}
    band = (H["H1"].freq > 2) & (H["H1"].freq < 120)
    # the hits differ only by the part of each response the record cuts off (measured:
    # 0.18% at most), so the three estimates agree to that and the coherence is near 1
    for e in ("H2", "Hv"):
        np.testing.assert_allclose(H[e].H[band], H["H1"].H[band], rtol=5e-3)
    assert np.all(H["H1"].coherence[band] > 0.995)
    # one hit: the three are the same ratio Y / F exactly
    one = {e: _frf(hits[:1], estimator=e).H for e in ("H1", "H2", "Hv")}
    np.testing.assert_allclose(one["H2"], one["H1"], rtol=1e-9)
    np.testing.assert_allclose(one["Hv"], one["H1"], rtol=1e-9)
    cm = sd.identify(H["H1"].band(5, 100), progress=False)
    j = np.argmin(np.abs(cm.frequency[:, None] - FN[None, :]), axis=0)
    np.testing.assert_allclose(cm.damping[j], ZN, rtol=0.01)        # measured: 0.02%
    np.testing.assert_allclose(cm.frequency[j], FN, rtol=1e-4)
    # with 1% noise on the response only, H1 is unbiased where H2 is not: H2 >= H1 in size
    noisy = _hits(noise=0.01, seed=3)
    h1, h2 = _frf(noisy, estimator="H1"), _frf(noisy, estimator="H2")
    hv = _frf(noisy, estimator="Hv")
    assert np.all(np.abs(h2.H) >= np.abs(h1.H) * (1 - 1e-9))
    assert np.all(np.abs(hv.H) >= np.abs(h1.H) * (1 - 1e-9))
    assert np.all(np.abs(hv.H) <= np.abs(h2.H) * (1 + 1e-9))


def test_double_hit_and_overload_warned():
    with pytest.warns(sd.ImpactWarning, match=r"hits\[1\]: double hit"):
        _frf(_hits(double=1))
    with pytest.warns(sd.ImpactWarning, match=r"hits\[2\]: overload on the response 'x1'"):
        _frf(_hits(clip=2))
    # a load cell saturating at 80% of a 40-sample pulse
    t = np.arange(N)
    pulse = np.where(t < 40, np.sin(np.pi * t / 40), 0.0)
    resp = np.convolve(pulse, np.exp(-t / 50) * np.sin(t / 3))[:N]
    hits = [(pulse, resp), (np.minimum(pulse, 0.8), resp)]
    with pytest.warns(sd.ImpactWarning, match=r"hits\[1\]: overload on the force"):
        sd.impact_frf(hits, FS)
    with warnings.catch_warnings():
        warnings.simplefilter("error", sd.ImpactWarning)
        sd.impact_frf(hits[:1], FS)
    # smooth records, even quantised to 12 bits, are not taken for overloads
    quant = [(f, np.round(y / np.abs(y).max() * 2047) / 2047) for f, y in _hits(noise=0.0)]
    with warnings.catch_warnings():
        warnings.simplefilter("error", sd.ImpactWarning)
        _frf(quant)


def test_poor_coherence_at_modes_warned():
    hits = _hits(noise=0.3, seed=5, force_noise=0.01)     # 30% noise: coherence drops
    with pytest.warns(sd.ImpactWarning, match="poor coherence .* resonance lines"):
        _frf(hits, force_window=None, exponential=None)


def test_bad_input_named():
    hits = _hits(nh=2)
    with pytest.raises(ValueError, match="hits must hold at least one"):
        sd.impact_frf([], FS)
    with pytest.raises(ValueError, match=r"hits\[1\]: every hit must have"):
        sd.impact_frf([hits[0], (hits[1][0][:-1], hits[1][1][:-1])], FS)
    with pytest.raises(ValueError, match="estimator must be one of"):
        sd.impact_frf(hits, FS, estimator="H3")
    with pytest.raises(ValueError, match="exponential must lie in"):
        sd.impact_frf(hits, FS, exponential=1.0)
    with pytest.raises(ValueError, match="force_window"):
        sd.impact_frf(hits, FS, force_window=1.5)
    with pytest.raises(ValueError, match=r"hits\[0\] force is constant"):
        sd.impact_frf([(np.zeros(N), hits[0][1])], FS)
    with pytest.raises(ValueError, match="quantity must be one of"):
        sd.impact_frf(hits, FS, quantity="acc")
    with pytest.raises(TypeError, match="hits must be a list"):
        sd.impact_frf(np.zeros((2, N)), FS)
    before = [(f.copy(), y.copy()) for f, y in hits]
    sd.impact_frf(hits, FS, force_window=0.1, exponential=0.01)
    for (f0, y0), (f1, y1) in zip(before, hits, strict=True):
        assert np.array_equal(f0, f1) and np.array_equal(y0, y1)      # inputs untouched


def test_band_argument_is_the_band_method(noisy):
    frf, _ = noisy
    a = sd.identify(frf, band=(5, 100), progress=False)
    b = sd.identify(frf.band(5, 100), progress=False)
    assert a.n == b.n == 3
    np.testing.assert_allclose(a.frequency, b.frequency, rtol=1e-4)
    assert a.band == (5.0, 100.0) and b.band == (frf.band(5, 100).freq[0], 100.0)


def test_band_argument_is_the_band_method_on_the_testbed():
    frf = sd.testbed_frf(noise=0.01, seed=0, n=600)
    a = sd.identify(frf, band=(10, 50), progress=False)
    b = sd.identify(frf.band(10, 50), progress=False)
    assert a.n == b.n
    np.testing.assert_allclose(a.frequency, b.frequency, rtol=1e-4)
    np.testing.assert_array_equal(a.in_band, b.in_band)


REAL = pathlib.Path(__file__).resolve().parents[1] / "examples" / "data" / "impact_pyfrf"


@functools.lru_cache(maxsize=None)
def _real_frf():
    """The 5 hammer hits of pyFRF (MIT, examples/data/impact_pyfrf) as one H1 FRF with the
    source's windows (an FRF is immutable: the tests share it)."""
    hits = [tuple(np.load(REAL / f"measurements_{k}.npy")[1:]) for k in range(1, 6)]
    with warnings.catch_warnings():
        warnings.simplefilter("error", sd.ImpactWarning)   # no double hit, overload
        return sd.impact_frf(hits, 25600.0, force_window=0.01, exponential=0.01,
                             quantity="accelerance")


def test_real_impact_records():
    """The 5 hammer hits of pyFRF: H1 with the source's windows, the documented resonances
    found, damping corrected for the window, and one meaning of ``band``."""
    frf = _real_frf()
    assert frf.shape == (12800, 1, 1) and frf.quantity == "acceleration"
    assert frf.exponential_tau == pytest.approx((25599 / 25600) / np.log(100), rel=1e-12)
    assert frf.band(10, 5000).coherence.mean() > 0.99       # source: about 0.998
    band = (3500.0, 4500.0)
    a = sd.identify(frf, band=band, progress=False)
    b = sd.identify(frf.band(*band), progress=False)
    assert a.n == b.n
    np.testing.assert_allclose(a.frequency, b.frequency, rtol=1e-4)
    for f0 in (3669.0, 3689.0, 4128.0, 4164.0, 4392.0):     # the source's strongest peaks
        assert np.min(np.abs(a.frequency - f0)) < 3.0
    # measured: 2.1% (12 modes; 5.0% and 9 modes before a pole pushed to its bound was
    # searched alone: it settled on the 4167 Hz mode beside 4163 Hz, and the residual scan
    # then found 3819 and 4101.7 Hz -- the coherence, 0.998, puts the noise near 2%)
    assert a.cost < 0.03
    # the window's decay rate 1/tau removed from every pole: the same data and coherence
    # without the window's record, identified by the rules of unwindowed data (which add
    # out-of-band poles while significant against second differences; windowed data keep
    # the direct noise field, their lines being correlated)
    # (unweighted: the windowed data are fitted once, unweighted -- their lines are
    # correlated -- and the comparison is of the window's correction, not of the weighting.
    # The default, weighting="auto", weights these unmarked data, whose lines it takes for
    # independent: 28 poles in the band, misfit over the point variance 0.14 against 13.8
    # unweighted -- below the noise the coherence declares; no truth to judge it by)
    unmarked = sd.FRF(frf.freq, frf.H, quantity="acceleration", coherence=frf.coherence)
    raw = sd.identify(unmarked, band=band, progress=False, weighting="none")
    inb, rin = a.in_band, raw.in_band
    assert a.n == np.sum(inb) == np.sum(rin) == 12            # measured: 12 in band
    assert raw.n - np.sum(rin) <= 1
    np.testing.assert_allclose(a.frequency[inb], raw.frequency[rin], rtol=1e-5)
    # measured: median 1.2% off 1/tau, the two modes nearest the extra pole -16% and +11%
    shift = (a.poles[inb].real - raw.poles[rin].real) * frf.exponential_tau
    assert np.all(np.abs(shift - 1) < 0.2) and np.median(np.abs(shift - 1)) < 0.02
    assert np.all(a.damping > 0) and np.all(a.damping[inb] < raw.damping[rin])
    # light damping: the window is half the apparent damping of the 4164 Hz mode (measured
    # 0.49: 1.87e-4 of the structure's, 1.76e-4 the window's)
    j = np.argmin(np.abs(a.frequency - 4164.0))
    r = raw.damping[np.argmin(np.abs(raw.frequency - 4164.0))]
    assert (r - a.damping[j]) / r > 0.4


def test_real_impact_records_over_a_wide_band():
    """The same records over 100-5000 Hz: the weak modes at 810, 851 and 900 Hz are kept and
    the fit error is within 2x the coherence's floor.  A pole's significance meets the noise
    field of second differences divided by their gain for the window's correlation: before,
    against the direct field alone, the smooth misfit that each removed pole left across the
    band raised the noise at the others and the pruning cascaded (810 Hz at 9.4x its
    threshold with 19 poles, 0.99x with 16): 15 poles, fit error 5.8%, 7.8x the floor, 810
    and 851 Hz missing.  Measured now: 22 poles in the band, 1.08% against a floor of 0.74%.
    Still missed over this band: the doublets at 899.4/906.9 Hz (one pole) and 1518/1520 Hz,
    which a 700-1600 Hz band resolves (8 poles, 0.77%)."""
    from sdctrl.identification import IdentificationWarning
    from sdctrl.identification._quality import coherence_floor

    frf = _real_frf()
    band = (100.0, 5000.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error", IdentificationWarning)      # no fit-quality warning
        cm = sd.identify(frf, band=band, progress=False)
    for f0 in (810.0, 851.0, 900.0, 3669.0, 3689.0, 4128.0, 4164.0, 4392.0):
        assert np.min(np.abs(cm.frequency - f0)) < 3.0, f0
    floor = coherence_floor(frf.band(*band))
    assert 0.007 < floor < 0.008 and cm.cost < 2 * floor       # 1.08% / 0.74%
    assert np.all(cm.damping > 0)
