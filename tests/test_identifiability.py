"""Identifiability of FE parameters by a test (Table 4.1) and cost maps (Figure 4.6) on the
built-in testbed."""

import concurrent.futures as cf

import numpy as np
import pytest

import sdctrl as sd

CORNERS = ["N32", "N33", "N34", "N35"]                   # plate A corners (+-0.15 m)
NOISE = 0.01


@pytest.fixture(scope="module")
def fe():
    return sd.testbed()


@pytest.fixture(scope="module")
def frf():
    """1% noise, with the coherence that this noise level implies: the log-magnitude error
    variance (1 - coherence) / 2 = NOISE^2 / 2."""
    test = sd.testbed_frf(n=150, noise=NOISE, seed=0)
    return sd.FRF(test.freq, test.H, quantity=test.quantity, sensors=test.sensors,
                  actuators=test.actuators, collocated=test.collocated,
                  coherence=np.full(test.H.shape, 1 - NOISE**2))


@pytest.fixture(scope="module")
def params(fe):
    # 0.5 kg concentrated at the plate centre with the rotary inertia the same mass has
    # on the four corners (4 x 0.125 kg at (+-0.15, +-0.15) m), against the distributed one
    J = 0.5 * 0.15**2
    return [fe.mass_parameter("mirror", ["N31"], mass=0.5, inertia=(J, J, 2 * J)),
            fe.mass_parameter("edge", CORNERS, mass=0.5),
            fe.stiffness_parameter("post A", elements=[("N29", "N30"), ("N30", "N31")]),
            fe.stiffness_parameter("post C", elements=[("N43", "N44"), ("N44", "N45")]),
            fe.mass_parameter("20 mg on the truss", ["N13"], mass=2e-5)]


@pytest.fixture(scope="module")
def ident(fe, frf, params):
    return sd.identifiability(fe, frf, params)


def test_confounded_weak_and_separable(ident):
    assert ident.error_source == "coherence"
    assert ident.error_level == pytest.approx(NOISE**2 / 2)
    # concentrated and distributed masses of the same total move the same modes
    assert ident.correlation[0, 1] > 0.99
    # a 20 mg mass: an update with this test could not determine it (predicted std above
    # its standard change), its effect far below the measurement error
    assert ident.weak == ["20 mg on the truss"]
    assert ident.std["20 mg on the truss"] > ident.standard_change["20 mg on the truss"]
    assert ident.sensitivity["20 mg on the truss"] < 1e-3 * ident.error_level
    for name in ("mirror", "edge", "post A", "post C"):
        assert ident.std[name] < 0.01 * ident.standard_change[name]
    # the two masses: estimates correlated beyond 0.95 (the effects alike, the estimates
    # opposite), the posts' estimates nearly independent
    assert ident.estimate_correlation[0, 1] < -0.95
    assert abs(ident.estimate_correlation[2, 3]) < 0.5
    # the two posts act on different modes: told apart
    assert abs(ident.correlation[2, 3]) < 0.5
    # at this noise each mass is determined to 1% of its standard change: the update tells
    # them apart whatever their correlation (issue 24: the verdict follows what an update can
    # determine, not the correlation alone)
    assert ident.confounded == []
    for name in ("mirror", "edge", "post A", "post C"):
        assert ident.sensitivity[name] > 100 * ident.error_level
    rep = ident.report()
    assert "Table 4.1" in rep and "Confounded pairs" in rep and "| 20 mg on the truss | 1 |" in rep


def test_confounded_when_the_joint_region_spans_the_standard_changes(fe, frf, params, ident):
    """With noise raising the masses' std to half their standard change (not weak), their
    thin joint 95% region is longer than the standard changes: confounded."""
    factor = (0.5 * ident.standard_change["mirror"] / ident.std["mirror"]) ** 2
    noisy = sd.identifiability(fe, frf, params, noise=ident.error_level * factor)
    assert noisy.std["mirror"] == pytest.approx(0.5 * noisy.standard_change["mirror"], rel=1e-6)
    assert "mirror" not in noisy.weak and "edge" not in noisy.weak
    assert ("mirror", "edge") in noisy.confounded
    assert all("post A" not in pair or "post C" not in pair for pair in noisy.confounded)
    assert "(mirror, edge)" in noisy.report()


def test_cost_map_shows_the_valley_of_confounded_masses(ident, frf):
    cmap = ident.cost_map("mirror", "edge", values_a=[-0.4, 0.0, 0.4],
                          values_b=[-0.4, 0.0, 0.4])
    assert cmap.cost.shape == (3, 3)
    assert cmap.cost[1, 1] < 1e-3                # the nominal model is the tested one
    same_total = cmap.cost[2, 0]                 # +0.2 kg at the centre, -0.2 kg on the edge
    heavier = cmap.cost[2, 2]                    # +0.2 kg on both
    assert same_total < 0.05 * heavier           # a flat valley of constant total mass
    with cf.ThreadPoolExecutor(2) as ex:
        par = ident.cost_map("mirror", "edge", values_a=[-0.4, 0.0, 0.4],
                             values_b=[-0.4, 0.0, 0.4], executor=ex)
    assert np.array_equal(par.cost, cmap.cost)
    default = ident.cost_map("post A", "post C", n=3)
    assert np.allclose(default.x, [-0.9, 0.05, 1.0]) and default.xlabel == "post A"  # bounds
    fig = sd.plot.cost_map(cmap)
    ax = fig.axes[0]
    assert ax.get_xlabel() == "mirror" and ax.get_ylabel() == "edge"
    with pytest.raises(ValueError, match="parameter name"):
        ident.cost_map("mirror", "nope")
    with pytest.raises(ValueError, match="different"):
        ident.cost_map("edge", "edge")


def test_error_level_from_an_identified_fit_without_coherence(fe, params):
    frf = sd.testbed_frf(n=300, noise=NOISE, seed=1)
    ident = sd.identifiability(fe, frf, params[2:4])
    assert ident.error_source == "identified fit"
    # the identified model's own misfit adds to the noise (measured 3.6e-4 for 5e-5 of noise;
    # on 150 lines identify misses modes and the level is 0.04): an upper bound
    assert NOISE**2 / 2 < ident.error_level < 2e-3
    assert ident.weak == [] and ident.confounded == []
    given = sd.identifiability(fe, frf, params[2:4], noise=1e8)   # std of log|H|: 1e4
    assert given.error_source == "given" and given.weak == ["post A", "post C"]


def test_a_coherence_of_round_off_is_no_error_level(fe, params):
    """A coherence one up to round-off at every line (a noise-free simulation through
    ``sd.impact_frf``: 1e-16 below one) measures no noise: the level comes from the identified
    fit, as without a coherence (before: "coherence", 5.6e-17, and stds of 1e-11)."""
    test = sd.testbed_frf(n=300, noise=NOISE, seed=1)
    roundoff = sd.FRF(test.freq, test.H, quantity=test.quantity, sensors=test.sensors,
                      actuators=test.actuators, collocated=test.collocated,
                      coherence=np.full(test.H.shape, 1.0 - 1e-16))
    bare = sd.identifiability(fe, test, params[2:4])
    got = sd.identifiability(fe, roundoff, params[2:4])
    assert got.error_source == "identified fit"
    assert got.error_level == bare.error_level and got.std == bare.std


def test_bad_input(fe, frf, params):
    with pytest.raises(ValueError, match="duplicate"):
        sd.identifiability(fe, frf, [params[0], params[0]])
    with pytest.raises(ValueError, match="corr_max"):
        sd.identifiability(fe, frf, params[:2], corr_max=1.5)
    with pytest.raises(ValueError, match="noise"):
        sd.identifiability(fe, frf, params[:2], noise=-1.0)
    with pytest.raises(TypeError, match="frf"):
        sd.identifiability(fe, frf.H, params[:2])
