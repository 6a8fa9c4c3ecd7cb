"""Identification statistics on roving-hammer surveys (issue 24): ``frequency_std`` and
``damping_std`` of the window-corrected poles calibrated over noise draws of
``sd.testbeds.survey`` (3 accelerometers, 20 hit points, hammer hits through
``sd.impact_frf`` with force and exponential windows; the identification uses the transposed
test, 20 outputs x 3 inputs).

The truth of each mode is the fit of the noise-free survey (its value without noise), started
from the exact poles; each draw's poles are searched from it (the model structure fixed, as
in tests/test_statistics_family.py).  Two findings of this check, both in
:mod:`sdctrl.identification._pole_statistics`:

- the exponential window correlates the noise of neighbouring lines (0.83 between
  neighbours): with independent lines the prediction was 1.2-2.4 times too small (coverage of
  the 95% intervals 0.53-0.93); with the window's correlation the scatter is 0.76-1.32 times
  the prediction;
- the point variance ``|H|^2 (1 - coherence)`` (3.59) with the ordinary coherence of ``n_d``
  hits overstates the H1 estimate's variance ``n_d - 1`` times: unbiased for two hits per
  point, conservative by ``sqrt(2)`` for the survey's default three -- until the FRF recorded
  its averages (``FRF.averages``) and the statistics divided by ``n_d - 1``.
"""

import warnings

import numpy as np
import pytest

import sdctrl as sd

N_DRAWS = 30
N_HITS = 20
LINES = 400
Z95 = 1.959964


def _identify(frf, poles, band):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return sd.identify(frf, poles=poles, band=band, progress=False)


def survey_draws(name, averages, noise=0.01, n_draws=N_DRAWS, seed=0):
    """Noise-free fit and, for each of its in-band poles, the estimates and predicted std of
    every draw (arrays (n_draws, n_modes): "f", "z", "fs", "zs", and "zw" the damping of the
    windowed pole, before the correction)."""
    kw = dict(n_hits=N_HITS, lines=LINES, averages=averages)
    exact = sd.testbeds.survey(name, noise=0.0, seed=seed, **kw)
    tau = exact.frf.exponential_tau
    ref = _identify(exact.frf, exact.poles - 1.0 / tau, exact.band)
    assert ref.exponential_tau == pytest.approx(tau) and np.all(ref.in_band)
    d = {k: np.empty((n_draws, ref.n)) for k in ("f", "z", "fs", "zs", "zw")}
    for k in range(n_draws):
        sv = sd.testbeds.survey(name, noise=noise, seed=seed + 1 + k, **kw)
        cm = _identify(sv.frf, ref.poles - 1.0 / tau, sv.band)
        j = [int(np.argmin(np.abs(cm.poles - p))) for p in ref.poles]
        for key, arr in (("f", cm.frequency), ("z", cm.damping), ("fs", cm.frequency_std),
                         ("zs", cm.damping_std)):
            d[key][k] = arr[j]
        w = cm.poles[j] - 1.0 / tau                       # the poles the data hold
        d["zw"][k] = -w.real / np.abs(w)
    return exact, ref, d


def _ratios(ref, d):
    out = {}
    for key, truth in (("f", ref.frequency), ("z", ref.damping)):
        out[key] = np.std(d[key], axis=0, ddof=1) / np.median(d[key + "s"], axis=0)
        out[key + "_cover"] = np.mean(np.abs(d[key] - truth) <= Z95 * d[key + "s"], axis=0)
    return out


@pytest.mark.parametrize("name", ["plate", "ladder"])
def test_survey_statistics_calibrated(name):
    """30 draws, 1% noise, two hits per point (where (3.59) is unbiased).  Every in-band
    mode: scatter within [0.67, 1.5] of the median predicted std; the 95% intervals cover
    the truth in at least 90% of the draws over the member's modes, and for each mode in at
    least 23 of 30 (with exact 95% intervals a mode falls below that with probability 0.004).

    Measured: plate (5 modes) f 0.76-1.29, zeta 0.92-1.13; ladder (12 modes) f 0.77-1.32,
    zeta 0.90-1.17; coverage 0.83-1.0 per mode, 0.91-0.94 over the modes.  The window's
    share of the windowed decay is 0.13 to 5.2 times the mode's own damping."""
    exact, ref, d = survey_draws(name, averages=2)
    assert ref.n == exact.poles.size >= 5
    assert np.all(np.isfinite(d["fs"])) and np.all(d["zs"] > 0)
    c = _ratios(ref, d)
    for key in ("f", "z"):
        assert np.all((c[key] >= 0.67) & (c[key] <= 1.5)), (key, np.round(c[key], 2))
        cover = c[key + "_cover"]
        assert np.mean(cover) >= 0.9 - 1e-12 and np.all(cover >= 23 / N_DRAWS), (key, cover)
    # the window correction: the exponential window adds 1/tau to every decay -- more than
    # the modes' own on the plate's first mode -- and the damping's std is that of the
    # corrected estimate (its coverage above); the windowed damping is off by many std
    tau = exact.frf.exponential_tau
    assert np.all(np.abs(np.median(d["zw"], axis=0) - ref.damping)
                  > 10 * np.median(d["zs"], axis=0))
    zeta_window = 1.0 / (tau * np.abs(ref.poles))                # the window's share
    np.testing.assert_allclose(np.median(d["zw"] - d["z"], axis=0), zeta_window, rtol=0.02)


def test_survey_statistics_with_three_hits_are_calibrated():
    """The survey's default three hits per point: the ordinary coherence of 3 hits gives the
    point variance (3.59) twice the H1 estimate's (``n_d - 1 = 2``); the FRF records its
    three averages (``impact_frf``) and the statistics divide by ``n_d - 1``: scatter within
    [0.67, 1.5] of the prediction, 95% intervals covering the truth in at least 90% of the
    draws over the modes.  Measured (plate, 30 draws): before the FRF recorded its averages
    scatter/predicted 0.53-0.92 (conservative by sqrt(2)); now f 0.76-1.25, zeta 0.96-1.30,
    coverage 0.90-0.97 (0.87-0.97, mean 0.92, with the plate's mirror layout of sensors: 26
    of 30 happens to one of ten such checks with probability 0.4 for exact intervals, so
    each mode is held to 23 of 30 and the mean to 0.9, as above)."""
    _, ref, d = survey_draws("plate", averages=3)
    c = _ratios(ref, d)
    print({k: np.round(v, 2) for k, v in c.items()})
    for key in ("f", "z"):
        assert np.all((c[key] >= 0.67) & (c[key] <= 1.5)), (key, np.round(c[key], 2))
        cover = c[key + "_cover"]                 # the criterion of the test above
        assert np.mean(cover) >= 0.9 - 1e-12 and np.all(cover >= 23 / N_DRAWS), (key, cover)


def test_unrecorded_averages_keep_the_conservative_variance():
    """The same three-hit survey without its record of averages: every predicted std is
    sqrt(n_d - 1) = sqrt(2) times larger (the point variance 3.59 not divided), the poles
    identical -- the averages change the statistics, never the fit."""
    sv = sd.testbeds.survey("plate", noise=0.01, seed=3, n_hits=N_HITS, lines=LINES,
                            averages=3)
    frf = sv.frf
    assert frf.averages == 3
    bare = sd.FRF(frf.freq, frf.H, quantity=frf.quantity, sensors=frf.sensors,
                  actuators=frf.actuators, collocated=frf.collocated,
                  coherence=frf.coherence, exponential_tau=frf.exponential_tau)
    assert bare.averages is None and frf.band(*sv.band).averages == 3
    assert frf.transpose().averages == 3
    a = _identify(frf, None, sv.band)
    b = _identify(bare, a.poles, sv.band)
    a = _identify(frf, a.poles, sv.band)
    np.testing.assert_allclose(b.poles, a.poles, rtol=1e-12)
    np.testing.assert_allclose(b.frequency_std, np.sqrt(2) * a.frequency_std, rtol=1e-6)
    np.testing.assert_allclose(b.damping_std, np.sqrt(2) * a.damping_std, rtol=1e-6)
    np.testing.assert_allclose(b.residue_std(), np.sqrt(2) * a.residue_std(), rtol=1e-6)
    np.testing.assert_allclose(a.residue_std(bare, n_averages=2), a.residue_std(), rtol=1e-6)
    with pytest.raises(ValueError, match="averages"):
        sd.FRF(frf.freq, frf.H, averages=0)
