"""The scalable lattice plate of the family (sdctrl.testbeds.lattice) through the chain at a
small size: its wrong FE model corrected exactly by its parameters, update, hybrid, and the
low-rank D-strut placement against the full re-analysis; serial and executor runs identical.
"""

import pickle
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
import scipy.linalg as sla

import sdctrl as sd
from sdctrl.closedloop._loops import rms
from sdctrl.closedloop._placement import placement_study


@pytest.fixture(scope="module")
def lat():
    return sd.testbeds.lattice(300)


@pytest.fixture(scope="module")
def chain(lat):
    frf = lat.frf(n=300)
    up = sd.update(lat.wrong(), frf, lat.parameters())
    cm = sd.identify(frf)
    nm = sd.normal_modes(cm, frf.collocated)
    h = sd.hybrid(up.fe, nm, up.fe.point(list(lat.sensors)).T)
    return frf, up, cm, h, nm


def test_lattice_size_io_and_band(lat):
    fe = lat.fe()
    assert fe.N == 300 and len(fe.elements) > 2 * fe.N / 3
    big = sd.testbeds.lattice(3000)
    assert abs(big.fe().N - 3000) / 3000 < 0.1                 # the size parameter holds
    assert len(lat.sensors) == 24 and len(lat.shakers) == 3
    assert lat.sensors[:3] == lat.shakers and all(d in fe.dofs for d in lat.sensors)
    f = fe.modes(10)[0]
    inside = (f >= lat.band[0]) & (f <= lat.band[1])
    assert inside.sum() == 8 and inside[:8].all()              # the first eight modes
    with pytest.raises(ValueError, match="dofs"):
        sd.testbeds.lattice(10)
    assert "lattice" not in " ".join(sd.testbeds.family())     # the five defaults unchanged
    assert isinstance(lat, sd.testbeds.TestStructure)
    back = pickle.loads(pickle.dumps(lat))
    assert back.band == lat.band and back.sensors == lat.sensors
    assert np.array_equal(back.fe().K.toarray(), fe.K.toarray())


def test_lattice_parameters_correct_the_wrong_model_exactly(lat):
    true, wrong = lat.fe(), lat.wrong()
    K, M = wrong.K.toarray(), wrong.M.toarray()
    for p in lat.parameters():
        v = lat.truth[p.name]
        if p.dK is not None:
            K = K + v * p.dK.toarray()
        if p.dM is not None:
            M = M + v * p.dM.toarray()
    assert np.abs(K - true.K.toarray()).max() <= 1e-10 * np.abs(true.K).max()
    assert np.abs(M - true.M.toarray()).max() <= 1e-12 * np.abs(true.M).max()
    assert np.abs(wrong.K - true.K).max() > 1e-3 * np.abs(true.K).max()


def test_lattice_simulated_test_matches_the_full_model(lat):
    frf = lat.frf("displacement", n=40)
    ref = lat.fe().frf(frf.freq, list(lat.shakers), list(lat.sensors), "displacement")
    err = np.abs(frf.H - ref.H).max() / np.abs(ref.H).max()
    assert err < 1e-3
    noisy = lat.frf("displacement", n=40, noise=0.01, seed=1)
    rel = np.abs(noisy.H / frf.H - 1)
    assert 0.005 < np.median(rel) < 0.02


def test_lattice_update_and_hybrid(lat, chain):
    frf, up, cm, h, nm = chain
    for name, v in lat.truth.items():
        assert abs(up.values[name] - v) < 0.02 * abs(v)
    assert up.cost_after < 0.01 * up.cost_before
    f_true = lat.fe().modes(8)[0]
    f_id = np.sort(cm.frequency[cm.in_band])
    assert f_id.size == 8 and np.allclose(f_id, f_true, rtol=2e-3)
    # the hybrid keeps the measured normal-mode frequencies, shapes on every FE DOF
    assert h.shapes.shape[0] == up.fe.N
    fh = np.sort(h.frequency)
    assert all(np.min(np.abs(fh - f)) < 1e-8 * f for f in nm.frequency)


def _full_reanalysis(nm, fe, bar, kv):
    """Closed-loop poles of the strut on the projection of the full FE matrices."""
    s = fe.strut(*bar)
    phi = nm.shapes
    Kr = phi.T @ (fe.K @ phi)
    Cr = phi.T @ (fe.C @ phi) + kv * (phi.T @ s) @ (s.T @ phi)
    Mr = phi.T @ (fe.M @ phi)
    n = Kr.shape[0]
    A = np.block([[np.zeros((n, n)), np.eye(n)],
                  [-sla.solve(Mr, Kr), -sla.solve(Mr, Cr)]])
    lam = np.linalg.eigvals(A)
    return lam[lam.imag > 0]


def test_lowrank_placement_equals_full_reanalysis(lat):
    fe = lat.fe()
    nm = fe.normal_mode_model(list(lat.shakers), list(lat.sensors), 20)
    bars = list(fe.elements[::37])[:12]
    kv = 300.0
    st = placement_study(nm, fe, lat.band, kv=kv, candidates=bars, progress=False)
    assert len(st.candidates) == len(bars) and not st.skipped
    for c in st.candidates:
        lam = _full_reanalysis(nm, fe, c.bar, kv)
        for f, z in zip(c.frequency, c.damping):
            p = lam[np.argmin(np.abs(np.abs(lam) / (2 * np.pi) - f))]
            assert abs(abs(p) / (2 * np.pi) - f) < 1e-8 * f
            assert abs(-p.real / abs(p) - z) < 1e-8
        s = fe.strut(*c.bar)
        cl = nm.with_feedback(s, s.T, kv=kv)
        r = rms(cl.to_statespace(), lat.band)
        assert np.allclose(c.rms, r, rtol=1e-8, atol=0)
    assert np.mean([np.mean(c.damping) for c in st.candidates]) > np.mean(st.damping)


#: relative accuracy of the dense reference ``sd.rms(cl.to_statespace())`` on the default
#: hybrid (``residual="auto"`` keeps the test's residual dynamics and F: 239 closed-loop
#: states, defective clusters -- F's triple poles, the static modes -- so the band integral
#: falls back to matrix logarithms).  Measured against a third, independent reference, an
#: adaptive quadrature of sum |H(j 2 pi f)|^2 over the band (scipy.integrate.quad_vec,
#: epsrel 1e-13, breakpoints at the in-band poles, its error estimate 3e-10 of the integral),
#: on the 6 bars below: the placement's array path agrees with the quadrature to 3.2e-14 at
#: worst, the logm reference to 1.17e-7 (1.8e-8 to 1.17e-7 per bar).  The array path is
#: right; the tolerance is the dense reference's own error, x2.5
DENSE_RTOL = 3e-7


def test_lowrank_placement_on_the_hybrid_equals_its_feedback(lat, chain):
    _, up, _, h, _ = chain
    assert h.static_ready                       # each strut gets its static correction mode
    bars = list(up.fe.elements[::53])[:8]
    st = placement_study(h, up.fe, lat.band, kv=300.0, candidates=bars, progress=False)
    for c in st.candidates:
        s = up.fe.strut(*c.bar)
        cl = h.with_feedback(s, s.T, kv=300.0)
        assert cl.n == h.n + 1
        assert np.allclose(c.rms, rms(cl.to_statespace(), lat.band), rtol=DENSE_RTOL, atol=0)
    with ThreadPoolExecutor(2) as ex:
        par = placement_study(h, up.fe, lat.band, kv=300.0, candidates=bars, progress=False,
                              executor=ex)
    assert [c.bar for c in par.candidates] == [c.bar for c in st.candidates]
    for a, b in zip(par.candidates, st.candidates):
        assert np.array_equal(a.rms, b.rms) and np.array_equal(a.damping, b.damping)
