"""FE model update (thesis 4.4) on the built-in testbed: a deliberately wrong FE model (post
links 50% too soft, plate masses 25% too heavy) updated against the simulated test of the
nominal structure."""

import warnings

import numpy as np
import pytest
import scipy.sparse as sp

import sdctrl as sd
from sdctrl.updating import apply_parameters, logls

LINKS = ["post_AB", "post_C"]
PLATES = [f"N{k}" for k in (31, 32, 33, 34, 35, 38, 39, 40, 41, 42, 45, 46, 47, 48, 49)]
WRONG = {"link_stiffness": 0.5, "plate_mass": 1.25}
#: the values that make the wrong model right: (1 + p) * factor = 1
TRUTH = {"links": 1 / 0.5 - 1, "plates": 1 / 1.25 - 1}
RAYLEIGH = (0.1, 4e-5)          # the testbed's C = alpha M + beta K (+ dashpots)


def _ratio_errors(res):
    """Relative errors of the recovered physical properties ``(1 + p) / (1 + p_true) - 1``."""
    return {k: (1 + res.values[k]) / (1 + TRUTH[k]) - 1 for k in TRUTH}


@pytest.fixture(scope="module")
def wrong():
    return sd.testbed(**WRONG)


@pytest.fixture(scope="module")
def params(wrong):
    return [wrong.stiffness_parameter("links", section=LINKS),
            wrong.mass_parameter("plates", PLATES)]


@pytest.fixture(scope="module")
def params_with_damping(params):
    """The same parameters carrying the Rayleigh damping of the elements they scale, so that
    ``fe.C`` of the updated model is the true one ("C known")."""
    links, plates = params
    alpha, beta = RAYLEIGH
    return [sd.Parameter("links", dK=links.dK, dC=beta * links.dK),
            sd.Parameter("plates", dM=plates.dM, dC=alpha * plates.dM)]


@pytest.fixture(scope="module")
def clean():
    return sd.testbed_frf(n=250)


@pytest.fixture(scope="module")
def noisy():
    return sd.testbed_frf(n=250, noise=0.01, seed=3)


@pytest.fixture(scope="module")
def updated(wrong, clean, params_with_damping):
    return sd.update(wrong, clean, params_with_damping, progress=False)


def test_initial_model_is_far_off(wrong):
    """The case is hard: the wrong model's modes are 10-30% low in the band."""
    f0, _ = sd.testbed().modes(18)
    f1, _ = wrong.modes(18)
    err = f1[6:] / f0[6:] - 1
    assert err.max() < -0.08 and err.min() < -0.25


def test_recovers_two_parameters_noise_free_with_known_damping(updated):
    err = _ratio_errors(updated)
    # measured: 0.16% on both (the simulated test is itself a truncated modal model,
    # within 2.4e-4 logLS of the exact FE response)
    assert all(abs(e) < 0.01 for e in err.values()), err
    assert updated.cost_before > 1.0 and updated.cost_after < 1e-3
    assert updated.damping.startswith("FE damping matrix")


def test_recovers_with_one_percent_noise_and_damping_from_data(wrong, noisy, params):
    res = sd.update(wrong, noisy, params, damping="data", progress=False)
    err = _ratio_errors(res)
    # stated tolerance 1%; measured 0.2-0.4% over seeds 0-3
    assert all(abs(e) < 0.01 for e in err.values()), err
    assert "from the data" in res.damping
    assert res.test_modes == "identified normal modes"
    assert res.cost_after < 0.05 * res.cost_before


def test_naive_logls_start_fails_where_update_succeeds(wrong, clean, params_with_damping,
                                                         updated):
    """A plain local optimiser on logLS from the nominal values stops in a local minimum
    (frequencies 10-30% off); the frequency stage of ``update`` avoids it."""
    naive = sd.update(wrong, clean, params_with_damping, strategy="logls", progress=False)
    err = _ratio_errors(naive)
    assert max(abs(e) for e in err.values()) > 0.2, err
    assert naive.cost_after > 100 * updated.cost_after
    assert max(abs(e) for e in _ratio_errors(updated).values()) < 0.01


def test_a_coherence_of_round_off_measures_no_noise(wrong, clean, params_with_damping, updated):
    """A noise-free test whose coherence is one up to round-off (``sd.impact_frf`` of a
    simulation: 1e-16 below one) is updated as without a coherence: the same values and the
    stds of the residual.  Before, the round-off was read as the noise level: links std
    1.8e-11 against an error of 3.7e-3 in ``p`` (now 4.3e-5: the residual here is the
    simulated test's modal truncation, a bias no std of noise covers)."""
    roundoff = sd.FRF(clean.freq, clean.H, quantity=clean.quantity, sensors=clean.sensors,
                      actuators=clean.actuators, collocated=clean.collocated,
                      coherence=np.full(clean.H.shape, 1.0 - 1e-16))
    res = sd.update(wrong, roundoff, params_with_damping, progress=False)
    assert res.values == updated.values
    for name, std in updated.std.items():
        assert std > 1e-6                                  # the residual's, not round-off
        assert res.std[name] == pytest.approx(std, rel=1e-12)


def test_updated_fe_is_the_full_model_at_the_values(wrong, updated, params_with_damping):
    ref = apply_parameters(wrong, params_with_damping, updated.values)
    for key in ("M", "K", "C"):
        assert abs(getattr(updated.fe, key) - getattr(ref, key)).max() == 0
    p = updated.values
    dK = sp.csr_matrix(updated.fe.K - wrong.K)
    assert abs(dK - p["links"] * params_with_damping[0].dK).max() < 1e-9 * abs(wrong.K).max()
    # the re-solved model's modes match the true structure's
    f_true, _ = sd.testbed().modes(18)
    f_upd, _ = updated.fe.modes(18)
    assert np.abs(f_upd[6:] / f_true[6:] - 1).max() < 3e-3


def test_model_overlays_the_data_and_pairing_is_reported(updated, clean):
    pred = updated.model.frf(clean.freq, clean.quantity)
    assert logls(pred, clean) == pytest.approx(updated.cost_after, rel=1e-6)
    pr = updated.pairing
    assert pr["test_hz"].size >= 9
    good = pr["mac_after"] > 0.99        # on 250 lines identify merges the close 15.6/16.0 Hz
    assert good.sum() >= pr["test_hz"].size - 1          # pair into one mode (MAC 0.67)
    assert np.abs(pr["fe_hz_after"][good] / pr["test_hz"][good] - 1).max() < 0.002
    assert np.abs(pr["fe_hz_before"] / pr["test_hz"] - 1).max() > 0.1
    rep = updated.report()
    for text in ("| links | 0 |", "| plates | 0 |", "[-0.9, 9]", "before", "after",
                 "MAC before", "FE after (Hz)"):
        assert text in rep
    assert repr(updated).startswith("UpdateResult(links=")


def test_bounds_are_respected(wrong, clean, params):
    links, plates = params
    tight = sd.Parameter("links", dK=links.dK, bounds=(-0.5, 0.6))
    res = sd.update(wrong, clean, [tight, plates], damping=0.003, progress=False)
    assert -0.5 <= res.values["links"] <= 0.6
    assert res.values["links"] == pytest.approx(0.6, abs=1e-6)   # the truth (1.0) is outside


def test_deterministic_and_inputs_untouched(wrong, clean, params):
    K0 = params[0].dK.copy()
    H0 = clean.H.copy()
    a = sd.update(wrong, clean.band(10, 40), params, damping=0.003, progress=False)
    b = sd.update(wrong, clean.band(10, 40), params, damping=0.003, progress=False)
    assert a.values == b.values and a.cost_after == b.cost_after
    assert abs(params[0].dK - K0).max() == 0 and np.array_equal(clean.H, H0)


def test_identified_normal_mode_model_gives_its_full_damping(wrong, clean, params):
    from sdctrl.updating._placed_test import identify_measured, place_test

    cm = identify_measured(place_test(wrong, clean))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")          # the identified Gamma is not quite PSD here
        nm = sd.normal_modes(cm, clean.collocated, modes=cm.in_band)
    assert np.abs(nm.Gamma - np.diag(np.diag(nm.Gamma))).max() > 0.5     # coupled pair
    res = sd.update(wrong, clean, params, damping=nm, progress=False)
    assert res.test_modes == "given normal modes"
    assert all(abs(e) < 0.01 for e in _ratio_errors(res).values())


def test_bad_input(wrong, clean, params):
    links, plates = params
    with pytest.raises(TypeError, match="fe"):
        sd.update("fe", clean, params)
    with pytest.raises(ValueError, match="duplicate"):
        sd.update(wrong, clean, [links, sd.Parameter("links", dM=plates.dM)])
    with pytest.raises(ValueError, match="N=246"):
        sd.update(wrong, clean, [sd.Parameter("small", dK=np.eye(3))])
    other = sd.FRF(clean.freq, clean.H, sensors=[f"s{i}" for i in range(31)],
                   actuators=clean.actuators)
    with pytest.raises(ValueError, match="frf: sensor labels must be DOF labels"):
        sd.update(wrong, other, params)
    with pytest.raises(TypeError, match="Parameter"):
        sd.update(wrong, clean, [links, "plates"])
    with pytest.raises(ValueError, match="strategy"):
        sd.update(wrong, clean, params, strategy="simplex")
    with pytest.raises(ValueError, match="damping"):
        sd.update(wrong, clean, params, damping="modal")
    with pytest.raises(ValueError, match="band"):
        sd.update(wrong, clean, params, band=(70.0, 80.0))
