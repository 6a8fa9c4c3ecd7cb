"""StateSpace signal names (API.md "Conventions"): outputs are sensor labels, inputs actuator
labels + ``_u``, ``.`` replaced by ``_``; no input shares an output's name, no side has two
equal names, so python-control's ``interconnect`` closes exactly the loops it is asked to."""

import control
import numpy as np
import pytest

import sdctrl as sd
from sdctrl._lib.signals import signal_name, signal_names
from struts import rate_outputs


def _chain(n=5):
    """Fixed-free spring-mass chain with proportional damping, DOFs N1.x ... Nn.x."""
    m = np.linspace(1.0, 2.0, n)
    k = 1e4 * np.linspace(1.0, 1.6, n)
    K = np.diag(k + np.r_[k[1:], 0.0]) - np.diag(k[1:], 1) - np.diag(k[1:], -1)
    M = np.diag(m)
    return sd.FEModel(M, K, 1e-4 * K + 0.02 * M, dofs=[f"N{i + 1}.x" for i in range(n)])


def _collocated_model():
    fe = _chain()
    # actuators N5.x (collocated with sensor N5.x) and N2.x (a disturbance shaker)
    return fe.normal_mode_model(["N5.x", "N2.x"], ["N5.x", "N1.x", "N3.x"], fe.N)


def _all_emitted(nm):
    um = nm.uncertain(dGamma=0.1 * np.abs(np.diag(np.diag(nm.Gamma))))
    P, _ = um.lft()
    return {"nm displacement": nm.to_statespace(), "nm acceleration":
            nm.to_statespace("acceleration"), "uncertain nominal": um.nominal,
            "uncertain lft": P, "uncertain sample": um.sample(1, seed=0)[0],
            "closed loop": sd.feedback(nm.to_statespace(), control.ss(
                [], [], [], [[1.0]], inputs=["N5_x"], outputs=["N5_x_u"]))}


def test_names_follow_the_convention():
    nm = _collocated_model()
    G = nm.to_statespace()
    assert G.output_labels == ["N5_x", "N1_x", "N3_x"]
    assert G.input_labels == ["N5_x_u", "N2_x_u"]
    for what, sys in _all_emitted(nm).items():
        ins, outs = list(sys.input_labels), list(sys.output_labels)
        assert len(set(ins)) == len(ins) and len(set(outs)) == len(outs), what
        assert not set(ins) & set(outs), f"{what}: an input shares an output's name"
        assert not any("." in n for n in ins + outs), what


def test_complex_mode_statespace_names():
    nm = _collocated_model()
    f = np.linspace(1.0, 40.0, 400)
    cm = sd.identify(nm.frf(f), poles=nm.poles[nm.poles.imag > 0], band=(1.0, 40.0))
    G = cm.to_statespace()
    assert G.output_labels == ["N5_x", "N1_x", "N3_x"]
    assert G.input_labels == ["N5_x_u", "N2_x_u"]


def test_interconnect_by_names_equals_with_feedback():
    """The collocated loop closed by names with control.interconnect has the poles of
    NormalModeModel.with_feedback (D-strut 5.4): F = -kv y' - kp y at N5.x."""
    nm = _collocated_model()
    kp, kv = 3e3, 40.0
    G = rate_outputs(nm.to_statespace(), ["N5_x"])           # adds N5_x_dot
    K = control.ss([], [], [], [[-kp, -kv]], inputs=["N5_x", "N5_x_dot"], outputs=["N5_x_u"])
    cl = control.interconnect([G, K], inplist=["N2_x_u"], outlist=["N1_x", "N3_x"])
    pb, cp = nm.phib[:, [0]], nm.cphi[[0], :]                 # collocated: cp = pb^T
    assert np.allclose(cp, pb.T)
    ref = nm.with_feedback(pb, cp, kp=kp, kv=kv, modal=True).poles
    p = cl.poles()
    p = np.sort_complex(p[p.imag > 0])
    ref = np.sort_complex(ref[ref.imag > 0])
    assert p.size == ref.size == nm.n
    np.testing.assert_allclose(p, ref, rtol=1e-9)
    assert np.all(p.real < 0)
    # the loop damps: the smallest closed-loop damping ratio exceeds the open loop's
    z = lambda q: np.min(-q.real / np.abs(q))
    p0 = nm.poles[nm.poles.imag > 0]
    assert z(p) > z(p0)


def test_no_silent_positive_feedback_by_names():
    """Issue 10: with equal names, interconnect(inplist=[sensor name]) closed a positive loop
    on a collocated pair.  Now the sensor name is not an input: naming the input gives the
    open loop, and naming the sensor as an input is refused by python-control."""
    nm = _collocated_model()
    G = nm.to_statespace()
    assert not set(G.input_labels) & set(G.output_labels)
    ol = control.interconnect([G], inplist=["N5_x_u"], outlist=["N1_x"], check_unused=False)
    p_open = np.sort_complex(nm.poles[nm.poles.imag > 0])
    p = ol.poles()
    np.testing.assert_allclose(np.sort_complex(p[p.imag > 0]), p_open, rtol=1e-9)
    assert np.all(p.real < 0)
    with pytest.raises(ValueError):
        control.interconnect([G], inplist=["N5_x"], outlist=["N1_x"])


def test_colliding_labels_raise_naming_the_argument():
    nm = _collocated_model()
    bad = nm.replace(sensors=["a.b", "a_b", "c"])
    with pytest.raises(ValueError, match="sensors: labels 'a.b' and 'a_b'"):
        bad.to_statespace()
    with pytest.raises(ValueError, match="sensors"):
        bad.uncertain().nominal  # noqa: B018
    bad = nm.replace(actuators=["x.1", "x_1"])
    with pytest.raises(ValueError, match="actuators: labels 'x.1' and 'x_1'"):
        bad.to_statespace()
    # an input and an output of one name: sensor "f_u" with actuator "f"
    bad = nm.replace(sensors=["f_u", "y", "z"], actuators=["f", "g"])
    with pytest.raises(ValueError, match="both an input and an output"):
        bad.to_statespace()


def test_signal_name_helper():
    assert signal_name("N42.y") == "N42_y"
    assert signal_name("-x") == "_x"
    assert signal_names(["N42.y"], ["N42.y"]) == (["N42_y_u"], ["N42_y"])
    ins, outs = signal_names(["s"], ["a"], extra_inputs=["d_w"], extra_outputs=["d_z"])
    assert ins == ["d_w", "a_u"] and outs == ["d_z", "s"]


def test_from_system_round_trip_labels():
    nm = _collocated_model()
    f = np.linspace(1.0, 40.0, 50)
    frf = sd.FRF.from_system(nm.to_statespace(), f)
    assert frf.sensors == ("N5_x", "N1_x", "N3_x")
    assert frf.actuators == ("N5_x", "N2_x")                  # the _u suffix is dropped
    np.testing.assert_allclose(frf.H, nm.frf(f).H, rtol=1e-9, atol=0)
    plain = control.ss([[-1.0]], [[1.0]], [[1.0]], [[0.0]], inputs=["f"], outputs=["x"])
    assert sd.FRF.from_system(plain, f).actuators == ("f",)   # no suffix: names kept
