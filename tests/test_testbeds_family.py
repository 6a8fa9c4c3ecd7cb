"""The family of test structures (issue 22): what each member is built to test, checked on its
FE model, and the truth of its deliberately wrong model."""

import pickle

import numpy as np
import pytest

import sdctrl as sd
from sdctrl.updating import apply_parameters

NAMES = sd.testbeds.family()


def test_the_family_and_its_members():
    assert NAMES == ("truss", "truss_high", "ladder", "plate", "cluster")
    with pytest.raises(ValueError, match=r"name must be one of \('truss'"):
        sd.testbeds.structure("bridge")
    for name in NAMES:
        s = sd.testbeds.structure(name)
        fe = s.fe()
        assert set(s.sensors) <= set(fe.dofs) and set(s.shakers) <= set(fe.dofs)
        assert s.sensors[:len(s.shakers)] == s.shakers            # collocated first
        assert pickle.loads(pickle.dumps(s)).truth == s.truth
        assert sd.testbeds.structure(name) is s and s.fe() is fe  # cached, immutable


@pytest.mark.parametrize("name", NAMES)
def test_the_truth_corrects_the_wrong_model_exactly(name):
    """Applying the documented parameter values to the wrong model gives the true M and K."""
    s = sd.testbeds.structure(name)
    true, wrong = s.fe(), s.wrong()
    fixed = apply_parameters(wrong, s.parameters(), s.truth)
    for X in ("M", "K"):
        a, b = getattr(fixed, X), getattr(true, X)
        a, b = (a.toarray(), b.toarray()) if hasattr(a, "toarray") else (a, b)
        assert np.abs(a - b).max() <= 1e-10 * np.abs(b).max()
    assert np.abs(getattr(wrong, "K") - getattr(true, "K")).max() > 0


def _modes(name, n=30):
    fe = sd.testbeds.structure(name).fe()
    return fe.modes(min(fe.N - 2, n))[0]


def test_modes_sit_where_each_member_says():
    f = _modes("ladder")
    np.testing.assert_allclose(f[:6].max(), 2.48, atol=0.01)         # suspension far below
    np.testing.assert_allclose(f[6:8], [7.99, 10.03], atol=0.01)      # just below 12 Hz
    assert np.sum((f > 12) & (f < 90)) == 12 and f[f > 90][0] == pytest.approx(98.27, abs=0.01)
    f = _modes("plate")
    below, inside, above = f[f < 20][-1], f[(f > 20) & (f < 62)], f[f > 62][0]
    assert below == pytest.approx(18.76, abs=0.01) and above == pytest.approx(64.58, abs=0.01)
    np.testing.assert_allclose(inside[:2], [26.32, 28.26], atol=0.01)
    f = _modes("cluster")
    blades = f[:4]
    assert blades.max() / blades.min() - 1 < 0.015                    # a dense cluster
    assert f[4] == pytest.approx(36.98, abs=0.01) and f[5] > 45       # the local mode, alone
    f = _modes("truss")
    assert np.sum((f > 9) & (f < 19)) == 6 and f[f > 19][0] > 20      # below truss_high's band


def test_the_simulated_test_is_the_exact_response_plus_seeded_noise():
    s = sd.testbeds.structure("plate")
    frf = s.frf(n=50)
    ref = s.fe().frf(frf.freq, list(s.shakers), list(s.sensors), "acceleration")
    np.testing.assert_allclose(frf.H, ref.H, rtol=1e-12, atol=0)
    assert frf.collocated == ((0, 0), (1, 1))
    assert (frf.freq[0], frf.freq[-1]) == s.band
    a, b = s.frf(n=50, noise=0.01, seed=3), s.frf(n=50, noise=0.01, seed=3)
    assert np.array_equal(a.H, b.H) and not np.array_equal(a.H, frf.H)
    rel = np.abs(a.H / frf.H - 1)
    assert 0.005 < np.sqrt(np.mean(rel ** 2)) < 0.015                # 1% relative noise


def _small_frame(stiff=1.0):
    """A structure that is not a family member (a held-out stand-in)."""
    return sd.testbeds._structures.ladder(rung_stiffness=1.3 * stiff, payload_mass=0.7)


def test_a_structure_outside_the_family_has_the_same_interface():
    """A TestStructure built by a user (any builder, any name -- even one starting with
    "truss") gives its own models, test and survey: nothing is looked up by name."""
    lad = sd.testbeds.structure("ladder")
    st = sd.testbeds.TestStructure(
        "truss_like_name", "a stiffer, lighter ladder", (12.0, 90.0), lad.sensors,
        lad.shakers, {"stiff": 0.9}, {"rungs": 1 / 0.9 - 1}, _small_frame,
        lad.parameter_maker)
    true, wrong = st.fe(), st.wrong()
    assert st.fe() is true                                   # cached, immutable
    np.testing.assert_allclose(true.K.toarray(), _small_frame().K.toarray())
    np.testing.assert_allclose(wrong.K.toarray(), _small_frame(0.9).K.toarray())
    f_own, f_family = true.modes(40)[0], lad.fe().modes(40)[0]
    assert np.max(np.abs(f_own / f_family - 1)) > 0.01     # not the family's ladder
    frf = st.frf(n=50)
    ref = true.frf(np.linspace(12, 90, 50), list(st.shakers), list(st.sensors),
                   "acceleration")
    np.testing.assert_allclose(frf.H, ref.H, rtol=1e-12)
    sv = sd.testbeds.survey(st, n_hits=10, noise=0.0, lines=200, averages=1, seed=0)
    f = np.abs(sv.poles) / (2 * np.pi)
    inb = (f_own > 12) & (f_own < 90)
    np.testing.assert_allclose(np.sort(f), f_own[inb], rtol=2e-3)    # its own modes
