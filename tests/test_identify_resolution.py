"""Resolution of ``identify``: lightly damped modes narrower than the line spacing (few
lines), the damping uncertainty (3.56) that tells them from noise poles, the out-of-band
trials made before insignificant poles are removed, and the partner of a close pair in
noisy single-reference data (LSCF order)."""

import numpy as np
import pytest
from test_identify import BAND, F_TRUE, IN_BAND, Z_TRUE, ten_mode

import sdctrl as sd
from sdctrl.identification._complex_modes import frf_array
from sdctrl.identification._noise import NoiseTest
from sdctrl.identification._residues import stack
from sdctrl.identification._search import PoleProblem
from sdctrl.identification._selection import RESOLVED_STD
from sdctrl.testbeds._truss import TESTBED_BAND

#: in-band testbed modes (Hz) and the damping of the narrowest, 9.52 Hz (0.2%)
F_TESTBED = np.array([9.5178, 12.6598, 15.7865, 15.8717, 18.1345, 18.6302, 27.6011, 43.8284,
                      48.4220, 52.9001, 54.7305, 56.3986])
Z_9HZ = 0.002034


@pytest.mark.parametrize("seed", [0, 1])
def test_testbed_600_lines_every_mode(seed):
    """600 lines over 8-60 Hz (0.087 Hz apart): the 9.52 Hz mode's half-power bandwidth is
    0.45 line spacing.  Before: it was rejected as noise fitting (bandwidth rule) or as not
    significant against the noise of a first fit without the 63 Hz mode, and never tried
    again (missed at 400-700 lines, found from 800).  Measured now (seeds 0-3, 400-1000
    lines): every mode, frequency errors <= 2.3e-4, 9.52 Hz damping within 1%."""
    frf = sd.testbed_frf(quantity="acceleration", n=600, noise=0.01, seed=seed)
    cm = sd.identify(frf, band=TESTBED_BAND, progress=False)
    f = cm.frequency[cm.in_band]
    assert f.size == F_TESTBED.size                      # none missed, none spurious
    i = [int(np.argmin(np.abs(f - ft))) for ft in F_TESTBED]
    assert len(set(i)) == F_TESTBED.size
    np.testing.assert_allclose(f[i], F_TESTBED, rtol=1e-3)
    assert abs(cm.damping[cm.in_band][i[0]] / Z_9HZ - 1) < 0.05
    assert 2 * Z_9HZ * F_TESTBED[0] < 0.5 * (frf.freq[1] - frf.freq[0])   # below the rule


def _one_mode(seed, noise=0.01, df=0.1, ns=6):
    """One mode at 10 Hz, 0.2% damping (bandwidth 0.4 line), ``ns`` sensors, 1% noise."""
    w = 2 * np.pi * 10.0
    lam = np.array([-0.002 * w + 1j * w * np.sqrt(1 - 0.002**2)])
    rng = np.random.default_rng(100)
    R = (rng.standard_normal((1, ns, 1)) + 0.2j * rng.standard_normal((1, ns, 1))) * 10.0
    freq = np.arange(8.0, 12.0 + 1e-9, df)
    H = frf_array(lam, R, np.zeros((ns, 1)), np.zeros((ns, 1)), 2j * np.pi * freq)
    g = np.random.default_rng(seed)
    H = H * (1 + noise * (g.standard_normal(H.shape) + 1j * g.standard_normal(H.shape))
             / np.sqrt(2))
    return sd.FRF(freq, H), lam


def _log_damping_std(frf, lam):
    """std(ln zeta) (3.56) of the poles ``lam`` on the data ``frf`` (residual of that fit)."""
    nf = frf.freq.size
    prob = PoleProblem(stack(frf.H.reshape(nf, -1)), 2j * np.pi * frf.freq, 0, "complex",
                       (True, True))
    w, z = np.abs(lam), -lam.real / np.abs(lam)
    ev = prob.evaluate(np.concatenate([np.log(w), np.log(z)]))
    return NoiseTest(prob, 2.0).log_damping_std(w, z, ev, np.arange(lam.size))


def test_damping_std_predicts_the_spread_over_noise_draws():
    """The first-order damping uncertainty (3.56) with the estimated noise field against
    the spread of the identified damping over 40 noise draws: measured std(ln zeta)
    predicted 0.0049, observed 0.0031 (ratio 1.1-1.6 over 6-20 sensors and 0.05-0.1 Hz
    lines: the running-median noise field is on the safe side); a narrow pole put where
    there is only noise has an undetermined damping (measured std(ln zeta) > 1)."""
    lz, pred = [], []
    for seed in range(40):
        frf, lam = _one_mode(seed)
        cm = sd.identify(frf, poles=lam, progress=False)
        lz.append(np.log(cm.damping[0]))
        if seed < 5:
            pred.append(_log_damping_std(frf, cm.poles)[0])
    observed, predicted = np.std(lz, ddof=1), np.median(pred)
    assert predicted < 0.1 < RESOLVED_STD                 # resolved although 0.4 line wide
    assert 0.8 < predicted / observed < 2.0
    # a narrow pole put on noise (no mode there): damping not determined
    frf, lam = _one_mode(0)
    w = 2 * np.pi * 11.3
    noise_pole = np.array([-0.002 * w + 1j * w])
    std = _log_damping_std(frf, np.concatenate([lam, noise_pole]))
    assert std[0] < 0.1 and std[1] > RESOLVED_STD


@pytest.mark.parametrize("seed", [0, 1, 3, 4])
def test_close_pair_partner_single_reference_3pct_noise(seed):
    """10 sensors x 1 actuator of the 10-mode set, 3% noise: the partner of the close pair
    (33.165 Hz, 1.2% damping, beside 33.0 Hz at 0.3%) is 10-14 times its noise threshold
    and its residue 12 times its standard deviation (3.60), yet was lost in seeds 0, 1, 3
    and 4 of 0-7: the indicator functions show 5 peaks for 8 modes, the LSCF stopped at
    order 20 where the partner is not stable, and the residual scan cannot see it while
    the mode above the band is missing (whose trial fails while the partner is missing).
    Measured now (seeds 0-7): found in all, frequency error <= 8.3e-4, damping within 11%;
    the local 44 Hz mode is below the noise at 3% (0.4-0.96 times its threshold with the
    true poles) and is not asserted."""
    frf, _lam, _R = ten_mode(noise=0.03, seed=seed)
    frf1 = sd.FRF(frf.freq, frf.H[:, :, :1], sensors=frf.sensors,
                  actuators=frf.actuators[:1], collocated=[(0, 0)])
    cm = sd.identify(frf1, band=BAND, progress=False)
    f, z = cm.frequency[cm.in_band], cm.damping[cm.in_band]
    strong = IN_BAND & (np.arange(10) != 6)
    i = [int(np.argmin(np.abs(f - ft))) for ft in F_TRUE[strong]]
    assert len(set(i)) == len(i)                         # the pair is two poles
    np.testing.assert_allclose(f[i], F_TRUE[strong], rtol=2e-3)
    j = i[list(F_TRUE[strong]).index(33.165)]
    assert abs(z[j] / Z_TRUE[4] - 1) < 0.15
    spurious = [x for x in f if np.min(np.abs(F_TRUE[IN_BAND] - x)) / x > 2e-3]
    assert not spurious
