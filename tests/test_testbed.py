"""The built-in test article: its documented modes, its features, and its simulated test."""

import re

import numpy as np
import pytest

import sdctrl as sd
import sdctrl.testbeds._truss as tb


def _doc_table():
    rows = {}
    for line in tb.testbed.__doc__.splitlines():
        m = re.match(r"\s+(\d+(?:-\d+)?)\s+(\d+\.\d+(?:-\d+\.\d+)?)\s+\S", line)
        if m:
            rows[m.group(1)] = [float(v) for v in m.group(2).split("-")]
    return rows


@pytest.fixture(scope="module")
def fe():
    return sd.testbed()


@pytest.fixture(scope="module")
def modes(fe):
    return fe.modes(24)


def test_docstring_mode_table_matches_computed_modes(fe, modes):
    f, _ = modes
    rows = _doc_table()
    assert len(rows) >= 13                       # the table was found and parsed
    lo, hi = rows.pop("1-6")
    assert f[0] == pytest.approx(lo, abs=0.006) and f[5] == pytest.approx(hi, abs=0.006)
    for mode, (value,) in rows.items():
        assert f[int(mode) - 1] == pytest.approx(value, abs=0.006), f"mode {mode}"
    assert f"{fe.N} DOFs" in tb.testbed.__doc__


def test_testbed_features(fe, modes):
    f, phi = modes
    lo, hi = tb.TESTBED_BAND
    assert np.all(f[:6] < lo / 2)                         # suspension below the band
    in_band = f[(f >= lo) & (f <= hi)]
    assert 8 <= in_band.size <= 12
    # close pair strongly coupled by damping: off-diagonal projected damping comparable to
    # the frequency separation 2 (w2 - w1)
    G = phi.T @ (fe.C @ phi)
    w = 2 * np.pi * f
    i = np.argmin(np.diff(f[6:]) / f[7:]) + 6       # closest pair in the flexible modes
    assert (f[i + 1] - f[i]) / f[i] < 0.03
    assert abs(G[i, i + 1]) > 0.5 * 2 * (w[i + 1] - w[i])
    # non-proportional damping overall
    off = np.abs(G - np.diag(np.diag(G)))[6:18, 6:18]
    assert off.max() > 0.3 * np.diag(G)[6:18].min()
    # a mostly local mode: >= 90% of the kinetic energy on plate C in the band
    plate_c = [f"N{k}" for k in range(44, 50)]            # post middle, centre, corners
    idx = [j for j, lab in enumerate(fe.dofs) if lab.split(".")[0] in plate_c]
    energy = np.einsum("ij,ij->j", phi[idx], (fe.M @ phi)[idx])
    band = (f >= lo) & (f <= hi)
    assert np.any(energy[band] > 0.9)
    assert 200 <= fe.N <= 400
    assert len(tb.SHAKERS) == 6 and len(tb.SENSORS) == 31
    assert set(tb.SENSORS) <= set(fe.dofs) and set(tb.SHAKERS) <= set(fe.dofs)
    assert sd.testbed() is fe                             # built once


def test_testbed_frf_labels_and_passivity():
    frf = sd.testbed_frf(quantity="displacement", n=400)
    assert frf.H.shape == (400, 31, 6) and frf.quantity == "displacement"
    assert frf.actuators == tb.SHAKERS and frf.sensors == tb.SENSORS
    assert frf.collocated == tuple((i, i) for i in range(6))
    for s, a in frf.collocated:
        assert frf.sensors[s] == frf.actuators[a]
        Hd = frf.H[:, s, a]
        assert np.all(Hd.imag <= 1e-9 * np.abs(Hd).max())   # collocated: passive
    acc = sd.testbed_frf(quantity="acceleration", n=400)
    assert np.allclose(acc.H, -(frf.omega**2)[:, None, None] * frf.H, rtol=1e-10)


def test_testbed_frf_matches_exact_fe_response(fe):
    frf = sd.testbed_frf(quantity="acceleration", n=25)
    ref = fe.frf(frf.freq, list(tb.SHAKERS), list(tb.SENSORS), "acceleration")
    err = np.abs(frf.H - ref.H).max(axis=0) / np.abs(ref.H).max(axis=0)
    assert err.max() < 3e-3


def test_testbed_frf_noise_is_seeded_and_of_the_stated_level():
    a = sd.testbed_frf(n=300, noise=0.05, seed=4)
    b = sd.testbed_frf(n=300, noise=0.05, seed=4)
    c = sd.testbed_frf(n=300, noise=0.05, seed=5)
    clean = sd.testbed_frf(n=300)
    assert np.array_equal(a.H, b.H) and not np.array_equal(a.H, c.H)
    rel = a.H / clean.H - 1
    assert np.std(rel.real) == pytest.approx(0.05 / np.sqrt(2), rel=0.05)
    assert abs(np.mean(rel)) < 0.002
    band = sd.testbed_frf(band=(10.0, 20.0), n=11)
    assert band.freq[0] == 10.0 and band.freq[-1] == 20.0


def test_testbed_frf_validation():
    with pytest.raises(ValueError, match="quantity"):
        sd.testbed_frf(quantity="force")
    with pytest.raises(ValueError, match="band"):
        sd.testbed_frf(band=(20.0, 10.0))
    with pytest.raises(ValueError, match="n must"):
        sd.testbed_frf(n=1)
    with pytest.raises(ValueError, match="noise"):
        sd.testbed_frf(noise=-0.1)


def test_testbed_statespace_names():
    nm = tb._modal()
    sys = nm.to_statespace("acceleration")
    assert list(sys.input_labels) == [s.replace(".", "_") + "_u" for s in tb.SHAKERS]
    assert sys.noutputs == 31
