"""``sd.identify``'s default line weighting, ``"auto"`` (issue 22): on data with measurable
noise the unweighted and the level-weighted fits are both made and the one closer to the
data kept (``sdctrl/identification/_line_weights.py``).

Measured (1% noise, seed 1, logLS against the exact response, unweighted / level-weighted):
truss 0.0057 / 0.0041, truss_high 0.00047 / 7.5e-5, ladder 0.0019 / 0.00043, plate 0.00029
/ 0.00050, cluster 0.030 / 0.00032 -- the kept fit is the closer one on every member (and on
36 cases over seeds 1-3, fresh bands and displacement data, module notes).  Noise-free data
are fitted unweighted only.
"""

import warnings

import numpy as np
import pytest

import sdctrl as sd
from sdctrl.updating import logls

#: the fit auto keeps at 1%, seed 1 (measured)
KEPT = {"truss": "level", "truss_high": "level", "ladder": "level", "plate": "none",
        "cluster": "level"}


def _fit(frf, weighting=None):
    kw = {} if weighting is None else {"weighting": weighting}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return sd.identify(frf, progress=False, **kw)


@pytest.mark.parametrize("name", sd.testbeds.family())
def test_the_fit_closer_to_the_data_is_kept_and_it_is_closer_to_the_truth(name):
    st = sd.testbeds.structure(name)
    exact = st.frf(n=400)
    frf = st.frf(n=400, noise=0.01, seed=1)
    cm = _fit(frf)
    both = {w: _fit(frf, w) for w in ("none", "level")}
    scores = cm.search.weighting_logls
    assert scores == pytest.approx((both["none"].search.logls, both["level"].search.logls),
                                   rel=1e-12)
    kept = ("none", "level")[int(np.argmin(scores))]
    assert cm.search.weighting == kept == KEPT[name]
    # the kept fit is the explicit pass's, bit for bit
    np.testing.assert_array_equal(cm.poles, both[kept].poles)
    np.testing.assert_array_equal(cm.residues, both[kept].residues)
    err = {w: logls(m.frf(frf.freq, quantity=frf.quantity).H, exact) for w, m in both.items()}
    print(f"\n{name}: data {scores}, exact {err}, kept {kept}")
    assert err[kept] <= min(err.values())


def test_noise_free_and_windowed_data_are_fitted_once_unweighted():
    st = sd.testbeds.structure("truss")
    frf = st.frf(n=400)
    cm = _fit(frf)
    assert cm.search.weighting == "none" and cm.search.weighting_logls is None
    np.testing.assert_array_equal(cm.poles, _fit(frf, "none").poles)
    noisy = st.frf(n=400, noise=0.01, seed=1)
    windowed = sd.FRF(noisy.freq, noisy.H, quantity=noisy.quantity, sensors=noisy.sensors,
                      actuators=noisy.actuators, collocated=noisy.collocated,
                      exponential_tau=0.5)
    cw = _fit(windowed)
    assert cw.search.weighting == "none" and cw.search.weighting_logls is None


def test_measurable_noise_is_scale_free():
    from sdctrl.identification._compression import measurable_noise

    st = sd.testbeds.structure("plate")
    H = st.frf(n=400, noise=0.01, seed=1).H.reshape(400, -1)
    H0 = st.frf(n=400).H.reshape(400, -1)
    for scale in (1.0, 1e-160, 1e160):
        assert measurable_noise(H * scale) and not measurable_noise(H0 * scale)
    assert not measurable_noise(H[:6]) and not measurable_noise(np.zeros((50, 3)))


def test_the_weighted_truss_does_not_cycle_to_the_round_cap():
    """Truss at 1%, seed 1, level-weighted: a residual peak at the 60 Hz band edge was added,
    pushed to the bound, pruned and proposed again ten times until the 20-round cap warned
    (the scan now runs once per pole set, ``identification._travel.scanned``)."""
    frf = sd.testbeds.structure("truss").frf(n=400, noise=0.01, seed=1)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        cm = sd.identify(frf, progress=False, weighting="level")
    assert not [w for w in caught if "rounds" in str(w.message)]
    assert cm.n == 13 and int(cm.in_band.sum()) == 12          # measured
