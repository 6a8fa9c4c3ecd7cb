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


def test_normal_modes_of_a_roving_hammer_survey_by_reciprocity():
    """2 accelerometers (at hit points 0 and 1), 8 hit points, 4 modes with proportional
    damping: fewer sensors than modes, so ``normal_modes`` works on the transposed test,
    says so, and returns the survey's orientation with the exact poles and FRFs."""
    rng = np.random.default_rng(4)
    w = 2 * np.pi * np.array([11.0, 23.0, 37.0, 52.0])
    z = np.array([0.01, 0.02, 0.015, 0.01])
    lam = -z * w + 1j * w * np.sqrt(1 - z**2)
    phi = rng.standard_normal((8, 4))                    # mass-normalised shapes at 8 points
    # displacement residues of mode j: phi_s phi_a / (2 j Im lam) (3.7, proportional damping)
    R = np.einsum("sj,aj->jsa", phi[:2], phi) / (2j * lam.imag)[:, None, None]
    labels = [f"P{i}.z" for i in range(8)]
    cm = sd.ComplexModeModel(lam, R, sensors=labels[:2], actuators=labels,
                             collocated=[(0, 0), (1, 1)])
    with pytest.warns(RuntimeWarning, match="roving-hammer survey.*transposed test"):
        nm = sd.normal_modes(cm)
    assert nm.sensors == tuple(labels[:2]) and nm.actuators == tuple(labels)
    assert nm.cphi.shape == (2, 4) and nm.phib.shape == (4, 8)
    np.testing.assert_allclose(np.sort_complex(nm.poles), np.sort_complex(lam), rtol=1e-9)
    f = np.linspace(5, 60, 300)
    a, b = nm.frf(f).H, cm.frf(f).H
    assert np.abs(a - b).max() < 1e-8 * np.abs(b).max()
    # the collocated pairs stay dual: c_s = b_a^T
    np.testing.assert_allclose(nm.cphi[0], nm.phib[:, 0], rtol=1e-8)
    np.testing.assert_allclose(nm.cphi[1], nm.phib[:, 1], rtol=1e-8)
