"""Identification with the lines weighted by their level (``identify(...,
weighting="level")``, :mod:`sdctrl.identification._line_weights`; issue 22).

The least squares of the fit weigh a line by the square of its level, the logLS cost (3.12)
that judges the model weighs every line alike: weighted by the inverse of its level across
the channels, the fit is the logLS cost linearised.  Measured at 1% noise, seed 1, 400 lines
(logLS of the identified model against the exact response, ``"none"`` -> ``"level"``): truss
0.0057 -> 0.0041, truss_high 0.00047 -> 0.00083, ladder 0.0019 -> 0.00043, plate 0.00029 ->
0.00050, cluster 0.030 -> 0.00032; the truss from displacement / velocity data 0.030 /
0.0077 -> 0.0041 / 0.0041; truss_high from displacement data 0.073 -> 0.00083; the cluster
over 8-30 Hz 0.099 -> 1.5e-5.  Every member's weighted fit within 2x the estimator's floor
(least-squares residues at the exact poles, unweighted: tests/test_family_identify.py),
where the truss was 2.4x.  The statistics are those of the weighted fit and calibrated (30
draws: frequency and damping scatter 0.69-1.30 of the predicted std over the family at 1%
and 5%).
"""

import functools
import warnings

import numpy as np
import pytest

import sdctrl as sd
from sdctrl.identification._line_weights import line_weights
from sdctrl.updating import logls
from test_family_identify import FLOOR
from test_statistics_family import calibration, family_draws

#: the truss's floor (tests/test_family_identify.py notes, seed 1), not in FLOOR there: the
#: unweighted fit is 2.4x it
FLOORS = {**FLOOR, "truss": 0.0024}
#: logLS against the exact response, weighted fit, 1% noise, seed 1 (measured)
#: (truss_high 0.00083 -> 7.5e-5 since the LSCF start fits the data without the weights)
MEASURED = {"truss": 0.00414, "truss_high": 0.000075, "ladder": 0.00043, "plate": 0.00050,
            "cluster": 0.00032}
#: logLS of the weighted fit's normal modes against the data (measured): within 3x the
#: identified model's (the issue's max(3x, 0.01)) but truss_high, 3.4x (0.000415 against
#: 0.000122; unweighted 0.00084 against 0.00052)
NM_MEASURED = {"truss": 0.00726, "truss_high": 0.000415, "ladder": 0.00102, "plate": 0.00064,
               "cluster": 0.00037}


def _fit(frf, weighting="level", **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return sd.identify(frf, progress=False, weighting=weighting, **kw)


@functools.lru_cache(maxsize=None)
def _member(name, quantity="acceleration", band=None, weighting="level"):
    st = sd.testbeds.structure(name)
    band = band or st.band
    frf = st.frf(quantity=quantity, n=400, noise=0.01, seed=1, band=band)
    cm = _fit(frf, weighting)
    exact = st.frf(quantity=quantity, n=400, band=band)
    return st, frf, cm, logls(cm.frf(frf.freq, quantity=quantity).H, exact)


def test_weights_closed_form_and_scale_free():
    """Two channels of levels ``a_f`` and ``b_f``: the weight is ``1 / sqrt(a_f b_f)``,
    normalised to a geometric mean of one; a channel's scale and an identically zero channel
    do not change it."""
    rng = np.random.default_rng(0)
    a, b = rng.uniform(0.1, 10, 50), rng.uniform(0.1, 10, 50)
    H = np.stack([a * np.exp(1j * rng.uniform(0, 6, 50)), b], axis=1)
    w = line_weights(H)
    ref = 1 / np.sqrt(a * b)
    assert np.allclose(w, ref / np.exp(np.mean(np.log(ref))), rtol=1e-12)
    assert np.allclose(line_weights(H * [1e-9, 1e6]), w, rtol=1e-12)
    assert np.allclose(line_weights(np.column_stack([H, np.zeros(50)])), w, rtol=1e-12)
    assert np.array_equal(line_weights(np.zeros((5, 2))), np.ones(5))
    assert np.isclose(np.mean(np.log(w)), 0.0, atol=1e-12)


@pytest.mark.parametrize("name", sd.testbeds.family())
def test_weighted_fit_within_twice_the_floor_on_every_member(name):
    st, frf, cm, err = _member(name)
    f, _ = st.fe().modes(40)
    true_in_band = int(np.sum((f > st.band[0]) & (f < st.band[1])))
    print(f"\n{name}: weighted {err:.4g} (floor {FLOORS[name]})")
    assert cm.search.weighting == "level"
    assert int(cm.in_band.sum()) == true_in_band                 # no mode lost or invented
    assert err <= 2 * FLOORS[name]
    assert err <= 1.5 * MEASURED[name] + 1e-5
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        nm = sd.normal_modes(cm, std=False)
    H = frf.H
    q = frf.quantity
    e_nm = logls(nm.frf(frf.freq, quantity=q).H, H)
    assert e_nm <= max(3 * logls(cm.frf(frf.freq, quantity=q).H, H), 0.01)
    assert e_nm <= 1.5 * NM_MEASURED[name] + 1e-5


def test_the_measured_quantity_no_longer_matters():
    """The truss at 1% from displacement, velocity and acceleration data: a weight ``1 /
    level`` absorbs the quantity's ``|s|^k``, and the three weighted fits agree (0.0041 each)
    where the unweighted ones do not (0.030 / 0.0077 / 0.0057): lines weighted by the square
    of their level undervalue the top of a displacement band (the roll-off ``1 / w^2``)."""
    errs = {q: _member("truss", q)[3] for q in ("displacement", "velocity", "acceleration")}
    plain = _member("truss", "displacement", weighting="none")[3]
    print(f"\ntruss weighted {errs}; displacement unweighted {plain:.4g}")
    vals = np.array(list(errs.values()))
    assert vals.max() <= 1.05 * vals.min()
    assert vals.max() <= 2 * FLOORS["truss"]
    assert plain >= 5 * errs["displacement"]                      # 0.030 against 0.0041


def test_tails_of_modes_beyond_the_band_are_fitted():
    """truss_high from displacement data (its six modes just below the band weigh heavily
    there, the 63 Hz mode just above lightly): 0.073 unweighted, 0.00083 weighted; the
    cluster over 8-30 Hz (its hub mode at 37 Hz just above; near-null hub channels):
    0.099 -> 1.5e-5."""
    disp = _member("truss_high", "displacement")[3]
    plain = _member("truss_high", "displacement", weighting="none")[3]
    low = _member("cluster", band=(8.0, 30.0))[3]
    low_plain = _member("cluster", band=(8.0, 30.0), weighting="none")[3]
    print(f"\ntruss_high displacement {plain:.4g} -> {disp:.4g}; cluster 8-30 Hz "
          f"{low_plain:.4g} -> {low:.4g}")
    assert disp <= 2 * FLOORS["truss_high"] and plain >= 50 * disp
    assert low <= 1e-4 and low_plain >= 100 * low


@pytest.mark.parametrize("name", ["truss_high", "plate"])
def test_weighted_statistics_calibrated(name):
    """The statistics of the weighted fit (data, basis and noise weighted alike, 3.56-3.59):
    50 draws at 1% noise, poles searched from the noiseless weighted fit's; measured ratios
    of the empirical std to the predicted one 0.75-1.21 (truss_high) and 0.85-1.07 (plate),
    per-mode coverage of the 95% intervals 0.90-1.0 (the family's five members at 1% and
    5%: 0.69-1.30).  With 30 draws the truss_high's 6th frequency read 0.69 on one machine
    and 0.65 on another: the sampling scatter of a std from 30 draws (0.67 is its 0.1%
    quantile for a ratio of 1)."""
    ref, d = family_draws(name, 0.01, n_draws=50, seed=10, weighting="level")
    c = calibration(ref, d)
    assert ref.search.weighting == "level" and np.all(d["same_order"])
    for key in ("f", "z"):
        r = c[key + "_ratio"]
        print(f"\n{name} {key}: ratios {np.round(r, 2)}, coverage {np.round(c[key + '_cover'], 2)}")
        assert np.all((r >= 0.67) & (r <= 1.5))
        assert np.mean(c[key + "_cover"]) >= 0.88 and np.all(c[key + "_cover"] >= 0.8)


def test_windowed_data_and_the_default_are_not_weighted(tmp_path):
    """Impact data through an exponential window (lines correlated) stay unweighted, as does
    the default; the record is kept by save/load; a wrong value is refused."""
    st, frf, cm, _ = _member("plate")
    assert _fit(frf, "none").search.weighting == "none"
    assert _fit(frf.band(*st.band)).search.weighting == "level"
    windowed = sd.FRF(frf.freq, frf.H, quantity=frf.quantity, sensors=frf.sensors,
                      actuators=frf.actuators, collocated=frf.collocated, exponential_tau=0.5)
    assert _fit(windowed).search.weighting == "none"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert sd.identify(frf, progress=False).search.weighting == "none"
    path = sd.save(cm, tmp_path / "cm.npz")
    assert sd.load(path).search.weighting == "level"
    with pytest.raises(ValueError, match="weighting"):
        sd.identify(frf, weighting="lines", progress=False)


@pytest.mark.parametrize("scale", [3.0, 1e160, 1e-155])
def test_weighted_fit_does_not_depend_on_the_scale_of_h(scale):
    """The weights are the inverse geometric mean of the levels, normalised: a unit of H
    changes nothing (poles to 1e-9, residues scaled, the same selection)."""
    st, frf, cm, _ = _member("plate")
    scaled = sd.FRF(frf.freq, frf.H * scale, quantity=frf.quantity, sensors=frf.sensors,
                    actuators=frf.actuators, collocated=frf.collocated)
    cs = _fit(scaled)
    assert cs.n == cm.n and cs.search.weighting == "level"
    assert np.max(np.abs(cs.poles / cm.poles - 1)) < 1e-9
    assert np.max(np.abs(cs.residues / scale - cm.residues)) < 1e-8 * np.max(np.abs(cm.residues))
