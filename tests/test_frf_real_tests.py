"""FRF conventions of real tests (API.md "Real tests"): quantity names, collocated pairs by
label, one pair or a list, and reciprocity (``FRF.transpose``)."""

import numpy as np
import pytest

import sdctrl as sd

F = np.linspace(1.0, 50.0, 40)


def _two_dof(f):
    """Exact receptance of a symmetric 2-DOF chain (m = 1, k = [2e4, 1e4], c = 0.5% K)."""
    M = np.eye(2)
    K = np.array([[3e4, -1e4], [-1e4, 1e4]])
    C = 5e-3 * K / (2 * np.pi * 20)
    w = 2 * np.pi * np.asarray(f)
    return np.array([np.linalg.inv(K - wi**2 * M + 1j * wi * C) for wi in w])


@pytest.mark.parametrize(("name", "canonical"), [
    ("receptance", "displacement"), ("mobility", "velocity"),
    ("accelerance", "acceleration"), ("inertance", "acceleration"),
    ("Accelerance", "acceleration"), ("displacement", "displacement"),
])
def test_quantity_standard_names(name, canonical):
    H = _two_dof(F)
    frf = sd.FRF(F, H, quantity=name)
    assert frf.quantity == canonical
    # the name means the same powers of j*omega: displacement -> named quantity -> back
    d = sd.FRF(F, H).to(name)
    k = {"displacement": 0, "velocity": 1, "acceleration": 2}[canonical]
    np.testing.assert_allclose(d.H, H * ((2j * np.pi * F) ** k)[:, None, None], rtol=1e-14)
    np.testing.assert_allclose(d.to("receptance").H, H, rtol=1e-12)


@pytest.mark.parametrize("bad", ["acc", "accel", "disp", "vel", "a", "accelerations"])
def test_quantity_abbreviations_refused(bad):
    with pytest.raises(ValueError, match=r"quantity must be one of .*accelerance.*inertance"):
        sd.FRF(F, _two_dof(F), quantity=bad)
    with pytest.raises(ValueError, match="quantity"):
        sd.FRF(F, _two_dof(F)).to(bad)


def test_collocated_by_label_and_declared():
    H = np.ones((F.size, 3, 2), complex)
    s, a = ["P1.z", "P2.z", "P3.z"], ["P3.z", "P1.z"]
    assert sd.FRF(F, H, sensors=s, actuators=a).collocated == ((0, 1), (2, 0))
    assert sd.FRF(F, H, sensors=s, actuators=a, collocated=()).collocated == ()
    assert sd.FRF(F, H, sensors=s, actuators=a, collocated=[]).collocated == ()
    # one pair, as labels or indices, and a list of pairs
    assert sd.FRF(F, H, sensors=s, actuators=a, collocated=("P1.z", "P1.z")).collocated == \
        ((0, 1),)
    assert sd.FRF(F, H, sensors=s, actuators=a, collocated=(2, 0)).collocated == ((2, 0),)
    assert sd.FRF(F, H, sensors=s, actuators=a,
                  collocated=[("P1.z", "P1.z"), (2, 0)]).collocated == ((0, 1), (2, 0))
    # default labels never collide: no pair
    assert sd.FRF(F, H).collocated == ()
    # operations keep the pairs they are given, and never re-derive them from labels
    frf = sd.FRF(F, H, sensors=s, actuators=a, collocated=[(2, 0)])
    assert frf.band(5, 20).collocated == ((2, 0),) and frf.to("velocity").collocated == ((2, 0),)
    with pytest.raises(TypeError, match="collocated must be a .sensor, actuator. pair"):
        sd.FRF(F, H, sensors=s, actuators=a, collocated="P1.z")
    with pytest.raises(ValueError, match="collocated: unknown sensor label 'P9.z'"):
        sd.FRF(F, H, sensors=s, actuators=a, collocated=("P9.z", "P1.z"))


def test_transpose_reciprocity_and_round_trip():
    rng = np.random.default_rng(1)
    H = rng.standard_normal((F.size, 3, 2)) + 1j * rng.standard_normal((F.size, 3, 2))
    coh = rng.uniform(0.2, 1.0, H.shape)
    H0 = H.copy()
    frf = sd.FRF(F, H, quantity="mobility", sensors=["A", "B", "C"], actuators=["C", "X"],
                 coherence=coh, units="m/s/N", exponential_tau=0.25)
    t = frf.transpose()
    assert t.shape == (F.size, 2, 3)
    assert t.sensors == ("C", "X") and t.actuators == ("A", "B", "C")
    assert t.collocated == ((0, 2),) and frf.collocated == ((2, 0),)
    for i in range(3):
        for j in range(2):
            assert np.array_equal(t.H[:, j, i], H[:, i, j])
            assert np.array_equal(t.coherence[:, j, i], coh[:, i, j])
    assert (t.quantity, t.units, t.exponential_tau) == ("velocity", "m/s/N", 0.25)
    back = t.transpose()
    assert np.array_equal(back.H, frf.H) and np.array_equal(back.coherence, frf.coherence)
    assert np.array_equal(back.freq, frf.freq)
    assert (back.sensors, back.actuators, back.collocated) == \
        (frf.sensors, frf.actuators, frf.collocated)
    assert back.exponential_tau == frf.exponential_tau
    # reciprocity of a symmetric structure: the transposed test is the same test
    sym = sd.FRF(F, _two_dof(F), sensors=["x1", "x2"], actuators=["x1", "x2"])
    np.testing.assert_allclose(sym.transpose().H, sym.H, rtol=1e-12)
    assert np.array_equal(H, H0)                          # the input is not touched


def test_exponential_tau_survives_operations_and_storage(tmp_path):
    frf = sd.FRF(F, _two_dof(F), quantity="inertance", exponential_tau=0.125)
    assert frf.band(10, 30).exponential_tau == 0.125
    assert frf.to("displacement").exponential_tau == 0.125
    assert frf.select(sensors=[1]).exponential_tau == 0.125
    sd.save(frf, tmp_path / "f.npz")
    back = sd.load(tmp_path / "f.npz")
    assert back.exponential_tau == 0.125 and np.array_equal(back.H, frf.H)
    assert sd.FRF(F, _two_dof(F)).exponential_tau is None
    for bad in (0.0, -1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="exponential_tau"):
            sd.FRF(F, _two_dof(F), exponential_tau=bad)
