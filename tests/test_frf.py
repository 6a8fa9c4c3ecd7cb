"""FRF container: validation rules, band, quantity conversion, selection, from_system."""

import control
import numpy as np
import pytest

import sdctrl as sd
from sdctrl._lib.statespace import ss_frf


def _data(nf=20, ns=3, na=2, seed=0):
    rng = np.random.default_rng(seed)
    f = np.linspace(1.0, 50.0, nf)
    H = rng.standard_normal((nf, ns, na)) + 1j * rng.standard_normal((nf, ns, na))
    return f, H


# --- validation: every rule, exact error type -----------------------------------------
@pytest.mark.parametrize("freq, match", [
    (np.linspace(1, 10, 19), "H must have shape"),            # length mismatch
    (np.r_[0.0, np.linspace(1, 10, 19)], "strictly positive"),  # 0 Hz
    (-np.linspace(1, 10, 20)[::-1], "strictly positive"),
    (np.r_[1.0, 1.0, np.linspace(2, 10, 18)], "strictly increasing"),
    (np.linspace(10, 1, 20), "strictly increasing"),
    (np.r_[np.nan, np.linspace(2, 10, 19)], "finite"),
    (np.r_[np.inf, np.linspace(2, 10, 19)], "finite"),
    (np.ones((20, 1)) * np.arange(1, 21)[:, None], "1-D"),
])
def test_bad_freq_is_valueerror(freq, match):
    _, H = _data()
    with pytest.raises(ValueError, match=match):
        sd.FRF(freq, H)


def test_bad_H():
    f, H = _data()
    Hn = H.copy()
    Hn[3, 1, 0] = np.nan
    with pytest.raises(ValueError, match="H must contain only finite"):
        sd.FRF(f, Hn)
    Hi = H.copy()
    Hi[0, 0, 0] = np.inf
    with pytest.raises(ValueError, match="finite"):
        sd.FRF(f, Hi)
    with pytest.raises(ValueError, match="H must be a 1 or 2 or 3-D"):
        sd.FRF(f, H[..., None])
    with pytest.raises(ValueError, match="at least one sensor"):
        sd.FRF(f, H[:, :0, :])
    with pytest.raises(TypeError, match="H must be a numeric array"):
        sd.FRF(f, [["a"]] * 20)


def test_shapes_promoted():
    f, H = _data()
    assert sd.FRF(f, H[:, 0, 0]).H.shape == (20, 1, 1)
    assert sd.FRF(f, H[:, :, 0]).H.shape == (20, 3, 1)


def test_quantity_names():
    f, H = _data()
    for q in ("displacement", "velocity", "acceleration"):
        assert sd.FRF(f, H, quantity=q).quantity == q
    assert sd.FRF(f, H, quantity="Acceleration").quantity == "acceleration"
    with pytest.raises(ValueError, match="quantity must be one of"):
        sd.FRF(f, H, quantity="force")
    with pytest.raises(TypeError, match="quantity must be a string"):
        sd.FRF(f, H, quantity=2)


def test_labels():
    f, H = _data()
    frf = sd.FRF(f, H)
    assert frf.sensors == ("s0", "s1", "s2") and frf.actuators == ("a0", "a1")
    frf = sd.FRF(f, H, sensors=["N1.x", "N2.y", "N3.z"], actuators=["N1.x", "N9.z"])
    assert frf.sensors[1] == "N2.y"
    with pytest.raises(ValueError, match="sensors must have 3 labels"):
        sd.FRF(f, H, sensors=["a", "b"])
    with pytest.raises(ValueError, match="actuators must be unique"):
        sd.FRF(f, H, actuators=["a", "a"])
    with pytest.raises(TypeError, match="sensors must be a sequence"):
        sd.FRF(f, H, sensors="abc")
    with pytest.raises(TypeError, match="sensors must contain strings"):
        sd.FRF(f, H, sensors=[1, 2, 3])


def test_collocated_pairs():
    f, H = _data()
    frf = sd.FRF(f, H, sensors=["A", "B", "C"], actuators=["A", "C"],
                 collocated=[(0, 0), ("C", "C")])
    assert frf.collocated == ((0, 0), (2, 1))
    with pytest.raises(ValueError, match="sensor index 3 out of range"):
        sd.FRF(f, H, collocated=[(3, 0)])
    with pytest.raises(ValueError, match="actuator index 2 out of range"):
        sd.FRF(f, H, collocated=[(0, 2)])
    with pytest.raises(ValueError, match="collocated must contain .sensor, actuator. pairs"):
        sd.FRF(f, H, collocated=[(0, 1, 2)])
    with pytest.raises(ValueError, match="unknown sensor label"):
        sd.FRF(f, H, collocated=[("Z", 0)])
    with pytest.raises(TypeError, match="collocated pairs must hold integer"):
        sd.FRF(f, H, collocated=[(0.5, 0)])


def test_coherence_rules():
    f, H = _data()
    coh = np.full(H.shape, 0.9)
    assert np.allclose(sd.FRF(f, H, coherence=coh).coherence, 0.9)
    c2 = sd.FRF(f, H, coherence=np.full((20, 3), 0.5)).coherence
    assert c2.shape == H.shape and np.all(c2 == 0.5)
    with pytest.raises(ValueError, match=r"coherence must lie in \[0, 1\]"):
        sd.FRF(f, H, coherence=np.full(H.shape, 1.01))
    with pytest.raises(ValueError, match=r"coherence must lie in \[0, 1\]"):
        sd.FRF(f, H, coherence=np.full(H.shape, -0.1))
    with pytest.raises(ValueError, match="coherence must have shape"):
        sd.FRF(f, H, coherence=np.ones((20, 2, 2)))
    bad = coh.copy()
    bad[0, 0, 0] = np.nan
    with pytest.raises(ValueError, match="coherence must contain only finite"):
        sd.FRF(f, H, coherence=bad)


def test_inputs_not_modified_and_immutable():
    f, H = _data()
    f0, H0 = f.copy(), H.copy()
    frf = sd.FRF(f, H, quantity="acceleration")
    frf.to("displacement")
    frf.band(5, 20)
    assert np.array_equal(f, f0) and np.array_equal(H, H0)
    H[0, 0, 0] = 99.0                      # changing the caller's array does not leak in
    assert frf.H[0, 0, 0] == H0[0, 0, 0]
    with pytest.raises(ValueError):
        frf.H[0, 0, 0] = 1.0               # read-only
    with pytest.raises(AttributeError):
        frf.quantity = "velocity"


# --- band -------------------------------------------------------------------------------
def test_band():
    f, H = _data(nf=50)
    frf = sd.FRF(f, H, coherence=np.full(H.shape, 0.7), collocated=[(0, 0)])
    b = frf.band(10.0, 20.0)
    assert b.freq.min() >= 10 and b.freq.max() <= 20
    assert np.array_equal(b.H, H[(f >= 10) & (f <= 20)])
    assert b.coherence.shape == b.H.shape and b.collocated == ((0, 0),)
    with pytest.raises(ValueError, match="contains no frequency line"):
        frf.band(100.0, 200.0)
    with pytest.raises(ValueError, match="empty band"):
        frf.band(20.0, 10.0)
    with pytest.raises(TypeError, match="band must be a pair"):
        frf.band("a", 3)


# --- quantity conversion -------------------------------------------------------------------
def test_to_is_powers_of_jw():
    f, H = _data()
    d = sd.FRF(f, H, quantity="displacement")
    w = 2 * np.pi * f[:, None, None]
    assert np.allclose(d.to("velocity").H, 1j * w * H, rtol=1e-14)
    assert np.allclose(d.to("acceleration").H, -(w**2) * H, rtol=1e-14)
    a = d.to("acceleration")
    assert a.quantity == "acceleration"
    assert np.allclose(a.to("velocity").H, 1j * w * H, rtol=1e-14)


@pytest.mark.parametrize("q", ["displacement", "velocity", "acceleration"])
def test_round_trip_identity(q):
    f, H = _data(seed=3)
    a = sd.FRF(f, H, quantity="acceleration")
    back = a.to(q).to("displacement").to("acceleration")
    assert np.allclose(back.H, H, rtol=1e-13, atol=0)
    assert back.quantity == "acceleration"


# --- select ------------------------------------------------------------------------------
def test_select():
    f, H = _data()
    frf = sd.FRF(f, H, sensors=["A", "B", "C"], actuators=["A", "C"], collocated=[(0, 0), (2, 1)])
    s = frf.select(sensors=["C", "A"], actuators=["C"])
    assert s.sensors == ("C", "A") and s.actuators == ("C",)
    assert np.array_equal(s.H[:, 0, 0], H[:, 2, 1])
    assert s.collocated == ((0, 0),)
    with pytest.raises(ValueError, match="unknown label"):
        frf.select(sensors=["Z"])


# --- from_system ----------------------------------------------------------------------------
def test_from_system_matches_closed_form():
    wn, z = 2 * np.pi * 12.0, 0.02
    sys = control.ss(control.tf([1.0], [1.0, 2 * z * wn, wn**2]))
    f = np.linspace(1, 30, 200)
    frf = sd.FRF.from_system(sys, f)
    s = 2j * np.pi * f
    assert np.allclose(frf.H[:, 0, 0], 1 / (s**2 + 2 * z * wn * s + wn**2), rtol=1e-10)
    tf = sd.FRF.from_system(control.tf([1.0], [1.0, 2 * z * wn, wn**2]), f, "velocity")
    assert tf.quantity == "velocity" and np.allclose(tf.H, frf.H, rtol=1e-10)


def test_from_system_mimo_names_and_defective_A():
    rng = np.random.default_rng(2)
    sys = control.rss(8, 3, 2, strictly_proper=False)
    sys = control.ss(sys.A, sys.B, sys.C, sys.D, inputs=["u1", "u2"], outputs=["y1", "y2", "y3"])
    f = np.logspace(-2, 1, 50)
    frf = sd.FRF.from_system(sys, f)
    ref = np.moveaxis(control.frequency_response(sys, 2 * np.pi * f).complex, -1, 0)
    assert np.allclose(frf.H, ref, rtol=1e-9, atol=1e-12)
    assert frf.sensors == ("y1", "y2", "y3") and frf.actuators == ("u1", "u2")
    # a Jordan block (double pole) forces the robust path
    A = np.array([[-1.0, 1.0], [0.0, -1.0]])
    Hd = ss_frf(A, np.array([[0.0], [1.0]]), np.array([[1.0, 0.0]]), np.zeros((1, 1)),
                2 * np.pi * f)
    s = 2j * np.pi * f
    assert np.allclose(Hd[:, 0, 0], 1 / (s + 1) ** 2, rtol=1e-12)
    del rng


def test_from_system_bad_input():
    with pytest.raises(TypeError, match="sys must be"):
        sd.FRF.from_system(np.eye(2), [1.0, 2.0])
    dsys = control.ss(control.tf([1], [1, 0.5], dt=0.1))
    with pytest.raises(ValueError, match="continuous-time"):
        sd.FRF.from_system(dsys, [1.0, 2.0])
    with pytest.raises(ValueError, match="freq"):
        sd.FRF.from_system(control.ss(-1, 1, 1, 0), [2.0, 1.0])
