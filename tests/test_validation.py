"""Bad input at the public boundary (issue 15): the cases the fuzz of the API reproduced, each a
clear ValueError/TypeError naming its argument, and the numbers that must not move when the
input is valid but extreme (scale invariance, read-only arrays)."""

import control
import numpy as np
import pytest

import sdctrl as sd


def _nm(E=True):
    w = 2 * np.pi * np.array([10.0, 25.0])
    c = np.array([[1.0, 0.5], [0.3, -1.0]])
    return sd.NormalModeModel(np.diag(w**2), np.diag(0.04 * w), c, c.T,
                              E=np.full((2, 2), 1e-5) if E else None,
                              sensors=["N1.x", "N2.x"], actuators=["N1.x", "N2.x"])


def _cm():
    nm = _nm()
    lam = nm.poles
    R = np.einsum("sj,ja->jsa", nm.cphi, nm.phib) / (2j * lam.imag)[:, None, None]
    return sd.ComplexModeModel(lam, R, E=np.full((2, 2), 1e-5), F=np.full((2, 2), -1e-3),
                               collocated=[(0, 0), (1, 1)])


@pytest.mark.parametrize("model", [_nm, _cm], ids=["normal", "complex"])
@pytest.mark.parametrize("omega_c", [-100.0, 0.0, np.nan, np.inf, 1e300, "1000", 1j])
def test_omega_c_refused(model, omega_c):
    """Negative (an unstable realisation before), zero, NaN, inf, 1e300 (OverflowError before)."""
    with pytest.raises((ValueError, TypeError), match="omega_c"):
        model().to_statespace("acceleration", omega_c=omega_c)


@pytest.mark.parametrize("model", [_nm, _cm], ids=["normal", "complex"])
def test_omega_c_valid_realisation_is_stable_and_exact_in_band(model):
    m = model()
    G = m.to_statespace("acceleration", omega_c=2 * np.pi * 4000.0)
    assert np.all(np.linalg.eigvals(G.A).real < 0)
    f = np.linspace(5.0, 40.0, 30)
    H = sd.FRF.from_system(G, f, "acceleration").H
    ref = m.frf(f, "acceleration").H
    # the E (and residual) terms are realised through w_c^2/(s+w_c)^2: ~2 f/f_c of their size
    assert np.max(np.abs(H - ref) / np.abs(ref)) < 0.05


def test_normal_mode_model_omega_c_field_refused():
    with pytest.raises(ValueError, match="omega_c"):
        _nm().replace(omega_c=-1.0)


def test_rms_of_a_system_with_nan_feedthrough_is_refused():
    G = _nm(E=False).to_statespace()
    bad = control.ss(G.A, G.B, G.C, np.full(G.D.shape, np.nan))
    with pytest.raises(ValueError, match="sys must have finite state-space matrices: D"):
        sd.rms(bad, (1.0, 50.0))


def test_rms_psd_given_as_text_is_refused():
    with pytest.raises(TypeError, match="psd"):
        sd.rms(_nm(E=False), (1.0, 50.0), psd="1.0")


def _records(nt=4096, seed=0):
    rng = np.random.default_rng(seed)
    u = rng.standard_normal((nt, 2))
    y = np.column_stack([u[:, 0] + 0.5 * np.roll(u[:, 1], 1), u[:, 1] - 0.2 * np.roll(u[:, 0], 2)])
    return u, y


def test_estimate_frf_names_the_dead_input_channel():
    u, y = _records()
    u[:, 1] = 0.0
    with pytest.raises(ValueError, match=r"u: input channel 1 \('shaker B'\) is constant"):
        sd.estimate_frf(u, y, 100.0, nperseg=256, actuators=["shaker A", "shaker B"])


@pytest.mark.parametrize("factor", [1.0, -3.0])
def test_estimate_frf_identical_inputs_name_u_not_linalg(factor):
    u, y = _records()
    u[:, 1] = factor * u[:, 0]
    with pytest.raises(ValueError, match=r"u: input channels 0 \('a0'\) and 1 \('a1'\) are the "
                                         "same signal"):
        sd.estimate_frf(u, y, 100.0, nperseg=256)


def test_estimate_frf_is_scale_invariant():
    """Records at 1e-150 and 1e+150 give the same FRF up to the scale ratio, no overflow."""
    u, y = _records()
    ref = sd.estimate_frf(u, y, 100.0, nperseg=256)
    tiny = sd.estimate_frf(u * 1e-150, y * 1e150, 100.0, nperseg=256)
    np.testing.assert_allclose(tiny.H, ref.H * 1e300, rtol=1e-10)
    np.testing.assert_allclose(tiny.coherence, ref.coherence, rtol=1e-10, atol=1e-12)
    # the H1 of y = u0 + 0.5 u1 (delayed one sample) is 1 at low frequency
    assert ref.H[0, 0, 0] == pytest.approx(1.0, abs=0.05)
    with pytest.raises(ValueError, match="y / u"):
        sd.estimate_frf(u * 1e-200, y * 1e200, 100.0, nperseg=256)


def test_read_only_inputs_are_accepted_and_left_alone():
    f = np.linspace(1.0, 10.0, 5)
    H = np.ones((5, 1, 1), complex)
    for a in (f, H):
        a.setflags(write=False)
    frf = sd.FRF(f, H)
    assert not frf.H.flags.writeable and frf.H is not H
    np.testing.assert_array_equal(frf.to("velocity").H[:, 0, 0], 2j * np.pi * f)


def test_frf_text_is_not_parsed_as_numbers():
    with pytest.raises(TypeError, match="H must be a numeric array, got text"):
        sd.FRF([1.0, 2.0], ["1.0", "2.0"])
    with pytest.raises(TypeError, match="band"):
        sd.FRF([1.0, 2.0], [1.0, 2.0]).band("1", "2")


def test_frf_conversion_overflow_names_h():
    frf = sd.FRF([1e3, 2e3], [1e305, 1e305])
    with pytest.raises(ValueError, match="H or freq"):
        frf.to("acceleration")


def test_normal_mode_frf_overflow_is_an_error_not_inf():
    nm = _nm()
    big = nm.replace(cphi=nm.cphi * 1e300, phib=nm.phib * 1e300)
    with pytest.raises(ValueError, match="overflows"):
        big.frf([10.0])


def test_scaled_refuses_a_mode_no_pair_sees():
    cm = _cm()
    R = cm.residues.copy()
    R[1] = 0.0
    with pytest.raises(ValueError, match="collocated: modes 1 are not seen"):
        cm.replace(residues=R).scaled()


def test_complex_mode_model_band_and_mask_validated():
    cm = _cm()
    with pytest.raises(ValueError, match="band"):
        cm.replace(band=(40.0, 5.0))
    with pytest.raises(ValueError, match="in_band"):
        cm.replace(in_band=[np.nan, 1.0])
    assert cm.replace(in_band=[1, 0]).in_band.tolist() == [True, False]


def test_first_use_refusals_say_what_to_do(tmp_path):
    """Issue 25: what a first-time user hit, each refusal naming the argument and the fix."""
    import sdctrl as sd

    f = np.linspace(1.0, 10.0, 20)
    H = np.ones((20, 3, 2)) * (1 + 1j)
    with pytest.raises(ValueError, match=r"sensors must have 3 labels \(one per sensor: axis 1 "
                                         r"of H\[f, sensor, actuator\]\), got 2 .*transpose"):
        sd.FRF(f, H, sensors=["a", "b"], actuators=["x", "y", "z"])
    bad = H.copy()
    bad[7, 1, 0] = np.nan
    with pytest.raises(ValueError, match=r"H must contain only finite .* 1 non-finite entry, "
                                         r"the first .*nan.* at index \(7, 1, 0\)"):
        sd.FRF(f, bad)
    missing = tmp_path / "nope.uff"
    with pytest.raises(FileNotFoundError) as err:
        sd.read_uff(missing)
    assert str(err.value).count(str(missing)) == 1          # the path said once
    frf = sd.testbed_frf(noise=0.0).band(14.0, 20.0)
    with pytest.raises(ValueError, match=r"poles must be complex poles in rad/s.*Hz\?"):
        sd.identify(frf, poles=[15.8, 16.0])
    with pytest.raises(ValueError, match=r"poles must be stable \(Re < 0, rad/s\)"):
        sd.identify(frf, poles=[0.1 + 2j * np.pi * 15.8])
    with pytest.raises(ValueError, match=r"frf.H is real-valued .*magnitude and phase"):
        sd.identify(sd.FRF(frf.freq, np.abs(frf.H)))


def test_check_labels_remembers_the_long_tuples_it_returned():
    """A model built from another's FE DOF labels (a hybrid's candidates, ``replace``) skips
    their O(N) check: ``check_labels`` returns a long tuple it returned before as is, and
    still refuses a wrong count, duplicates, non-strings; ``np.str_`` become ``str``."""
    from sdctrl._lib.validate import check_labels

    labs = [f"d{i}" for i in range(2000)]
    out = check_labels(labs, 2000, "dofs", "q")
    assert out == tuple(labs) and check_labels(out, 2000, "dofs", "q") is out
    with pytest.raises(ValueError, match="dofs must have 2001 labels"):
        check_labels(out, 2001, "dofs", "q")
    with pytest.raises(ValueError, match="dofs must be unique"):
        check_labels(out[:-1] + ("d0",), 2000, "dofs", "q")
    with pytest.raises(TypeError, match="dofs must contain strings, got int"):
        check_labels(out[:-1] + (7,), 2000, "dofs", "q")
    conv = check_labels(np.array(labs), 2000, "dofs", "q")
    assert conv == out and {type(x) for x in conv} == {str}


def test_checked_label_tuples_remembered_from_any_thread():
    """The same from a pool of threads (the placement and diagnosis sweeps build models on
    threads): each tuple comes back equal, a remembered one as is."""
    from concurrent.futures import ThreadPoolExecutor

    from sdctrl._lib.validate import check_labels

    tuples = [tuple(f"n{k}.{i}" for i in range(1500)) for k in range(12)]
    with ThreadPoolExecutor(4) as pool:
        outs = list(pool.map(lambda t: check_labels(t, 1500, "dofs", "q"), tuples * 3))
    for t, out in zip(tuples * 3, outs):
        assert out == t and check_labels(out, 1500, "dofs", "q") == t
    last = check_labels(tuples[0], 1500, "dofs", "q")
    assert check_labels(last, 1500, "dofs", "q") is last
    with pytest.raises(ValueError, match="1499 labels"):
        check_labels(last, 1499, "dofs", "q")
    with pytest.raises(ValueError, match="unique"):
        check_labels(last[:-1] + (last[0],), 1500, "dofs", "q")
    with pytest.raises(TypeError, match="strings"):
        check_labels(last[:-1] + (3,), 1500, "dofs", "q")
    with pytest.raises(TypeError, match="sequence"):
        check_labels(set(last), 1500, "dofs", "q")
