"""Initial poles of ``identify`` (LSCF estimator, stabilisation), its shortcuts, scale
invariance, data without resonances, and the FE shift-invert factorisation (issue 14)."""

import matplotlib
import numpy as np
import pytest
import scipy.sparse as sp
from test_identify import BAND, F_TRUE, IN_BAND, Z_TRUE, ten_mode

import sdctrl as sd
from sdctrl.identification._complex_modes import frf_array
from sdctrl.identification._initial import lscf_candidates
from sdctrl.identification._lscf import lscf_poles
from sdctrl.identification._residues import stack
from sdctrl.identification._missed_scan import ResidualScan

matplotlib.use("Agg")


def _ema_like(ns=12, n=1000):
    """Noise-free receptance, 6 modes spread over the band, single input."""
    rng = np.random.default_rng(3)
    f = np.array([31.0, 58.0, 97.0, 133.0, 171.0, 214.0])
    z = np.array([0.01, 0.006, 0.012, 0.008, 0.015, 0.005])
    w = 2 * np.pi * f
    lam = -z * w + 1j * w * np.sqrt(1 - z**2)
    c = rng.standard_normal((6, ns)) + 0.1j * rng.standard_normal((6, ns))
    b = rng.standard_normal((6, 1)) + 0.1j * rng.standard_normal((6, 1))
    R = np.einsum("ji,jk->jik", c, b) / (2j * lam.imag)[:, None, None]
    freq = np.linspace(1.0, 250.0, n)
    H = frf_array(lam, R, np.zeros((ns, 1)), np.zeros((ns, 1)), 2j * np.pi * freq)
    return sd.FRF(freq, H), lam


def test_lscf_converges_to_the_poles_of_a_rational_model():
    """A sum of 3 poles is rational in s, not in the z of the band's map: the extra roots
    of higher orders absorb the difference, and the roots next to the poles converge
    geometrically (measured 4e-4, 1.5e-5, 5e-7, 2e-8 at orders 4, 6, 8, 10)."""
    lam = np.array([-0.5 + 60j, -0.3 + 75j, -1.0 + 90j])
    freq = np.linspace(8, 16, 300)
    s = 2j * np.pi * freq
    P = np.column_stack([np.sum([r / (s - p) for r, p in zip(rr, lam)], axis=0)
                         for rr in ([1, 2, 1j], [0.5, -1, 2], [1j, 1, 0.3])])
    err = [max(np.min(np.abs(roots - p)) / abs(p) for p in lam)
           for roots in lscf_poles(freq, P, [4, 6, 8, 10])]
    assert np.all(np.diff(np.log10(err)) < -1)         # > 10x per order step of 2
    assert err[-1] < 1e-7


def test_lscf_finds_every_mode_of_the_noise_free_set_and_draws_a_diagram():
    frf, _lam, _ = ten_mode(df=0.05)
    data = frf.band(*BAND)
    Y = stack(data.H.reshape(data.freq.size, -1))
    w, z, stab = lscf_candidates(data.freq, Y, BAND, 8, 0.1)
    f_in = F_TRUE[IN_BAND]
    assert w.size == f_in.size                         # all 8, the local mode included
    assert np.max(np.abs(w / (2 * np.pi) / f_in - 1)) < 1e-6
    assert np.max(np.abs(z / Z_TRUE[IN_BAND] - 1)) < 1e-3
    # the per-order poles feed the stabilisation diagram of sdctrl.plot
    assert len(stab["poles"]) == len(stab["orders"]) >= 3
    flags = sd.plot.stabilisation_flags(stab["poles"])
    assert np.count_nonzero(flags[-1] >= 2) >= 8       # the modes stable in f and damping
    fig = sd.plot.stabilisation(stab["poles"], data, orders=stab["orders"])
    assert fig.axes


def test_noise_free_exact_without_scan(monkeypatch):
    """Noise-free data, all modes in the LSCF start: one search, no scan, no out-of-band
    trial (the fit is numerically exact), poles to 1e-8."""
    frf, lam = _ema_like()
    calls = []
    orig = ResidualScan.candidates
    monkeypatch.setattr(ResidualScan, "candidates",
                        lambda self, *a, **k: calls.append(1) or orig(self, *a, **k))
    cm = sd.identify(frf, progress=False)
    assert not calls
    assert cm.n == lam.size and np.all(cm.in_band)
    assert np.max(np.abs(cm.poles / lam - 1)) < 1e-8
    assert cm.cost < 1e-8
    st = cm.stabilisation
    assert len(st.poles) == len(st.orders)


@pytest.mark.parametrize("scale", [1e160, 1e-160, 1e-155, 3.0])
def test_identification_does_not_depend_on_the_scale_of_H(scale):
    frf, _, _ = ten_mode(noise=0.01, seed=0, df=0.1)
    ref = sd.identify(frf, band=BAND, progress=False)
    # the same FRF but for its scale: its collocated pair too (without it, the level-weighted
    # fit auto keeps has no 13.7 Hz pole below the band: 10 poles, not 11; unweighted, 9
    # either way; logLS against the exact response 6.3e-6 weighted, 1.2e-4 unweighted)
    cm = sd.identify(sd.FRF(frf.freq, frf.H * scale, sensors=frf.sensors,
                            actuators=frf.actuators, collocated=frf.collocated),
                     band=BAND, progress=False)
    assert cm.n == ref.n == 11 and cm.search.weighting == ref.search.weighting == "level"
    assert np.max(np.abs(cm.poles / ref.poles - 1)) < 1e-9
    assert np.max(np.abs(cm.residues / scale - ref.residues)) < 1e-8 * np.max(
        np.abs(ref.residues))
    assert abs(cm.cost - ref.cost) < 1e-6 * ref.cost
    # given poles too
    cg = sd.identify(sd.FRF(frf.freq, frf.H * scale), poles=ref.poles, band=BAND,
                     in_band=ref.in_band, optimizer="none", progress=False)
    assert np.allclose(cg.residues / scale, ref.residues, rtol=1e-8, atol=0)


@pytest.mark.parametrize("kind", ["ones", "white noise"])
def test_no_resonance_is_a_clear_error(kind):
    freq = np.linspace(10, 50, 400)
    rng = np.random.default_rng(1)
    # a constant complex FRF (a real one is refused earlier, as magnitude-only data)
    H = (np.full((400, 3, 2), 1.0 + 0.5j) if kind == "ones" else
         rng.standard_normal((400, 3, 2)) + 1j * rng.standard_normal((400, 3, 2)))
    with pytest.raises(ValueError, match="no mode found in the band"):
        sd.identify(sd.FRF(freq, H), progress=False)


def test_sparse_modes_equal_dense_and_non_pd_mass_refused():
    """The shift-invert factorisation (symmetric-mode LU) gives the dense eigenvalues;
    a shift on an eigenvalue is a ValueError naming sigma."""
    n = 300
    K = sp.diags([-np.ones(n - 1), 2 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1]).tocsr()
    M = sp.diags([np.ones(n - 1), 4 * np.ones(n), np.ones(n - 1)], [-1, 0, 1]).tocsr() / 6
    fe = sd.FEModel(M, K)
    f_s, phi = fe.modes(6, method="sparse")
    f_d, _ = fe.modes(6, method="dense")
    assert np.max(np.abs(f_s / f_d - 1)) < 1e-9
    assert np.allclose(phi.T @ (M @ phi), np.eye(6), atol=1e-9)
    with pytest.raises(ValueError, match="sigma"):
        sd.FEModel(sp.identity(4, format="csr"), sp.diags([1.0, 2.0, 3.0, 4.0]).tocsr()).modes(
            1, method="sparse", sigma=1.0)
    with pytest.raises(ValueError, match="M must be positive definite"):
        sd.FEModel(M - 0.5 * sp.identity(n, format="csr"), K)


@pytest.mark.parametrize("model", ["complex", "real"])
def test_partial_search_reuses_the_fixed_factorisation_exactly(model):
    """SubProblem factorises only the free poles against the fixed ones' QR: same cost,
    gradient (3.19) and Gauss-Newton matrix as the full problem, to round-off."""
    from sdctrl.identification._search import PoleProblem, SubProblem

    frf, lam, _ = ten_mode(noise=0.01, seed=0, df=0.1)
    d = frf.band(*BAND)
    prob = PoleProblem(stack(d.H.reshape(d.freq.size, -1)), 2j * np.pi * d.freq, 0, model,
                       (True, True))
    lam0 = lam[IN_BAND] * (1 + 1e-3)
    x = np.concatenate([np.log(np.abs(lam0)), np.log(-lam0.real / np.abs(lam0))])
    only = np.array([2, 5])
    free = np.concatenate([only, lam0.size + only])
    a = SubProblem(prob, x, free).evaluate(x[free], jac=True)
    b = prob.evaluate(x, jac=True, free=free)
    assert abs(a["cost"] / b["cost"] - 1) < 1e-12
    np.testing.assert_allclose(a["grad"], b["grad"], rtol=0, atol=1e-12 * np.abs(b["grad"]).max())
    np.testing.assert_allclose(a["JtJ"], b["JtJ"], rtol=0, atol=1e-12 * np.abs(b["JtJ"]).max())


@pytest.mark.parametrize(("model", "k"), [("complex", 0), ("complex", 2), ("real", 1)])
def test_fft_trial_correlations_equal_the_products(model, k):
    """The scan's correlations of on-grid trial poles (FFT) are the inner products of
    their basis columns (3.15) with the data, to round-off; non-uniform lines are
    detected (the scan then forms the products)."""
    from sdctrl.identification._trial_correlation import TrialCorrelations, uniform_grid
    from sdctrl.identification._residues import basis

    rng = np.random.default_rng(0)
    freq = np.linspace(20, 60, 401)
    s = 2j * np.pi * freq
    Y = rng.standard_normal((802, 5))
    Q = np.linalg.qr(rng.standard_normal((802, 7)))[0]
    corr = TrialCorrelations(uniform_grid(freq), s, k, model, (Q, Y))
    idx = np.arange(4, 397, 3)
    sigma = 2 * np.pi * 4 * (freq[1] - freq[0])
    G = stack(basis(-sigma + 1j * corr.omega(idx), s, k, model, (False, False)))
    T, Gr = corr.products(sigma, idx)
    np.testing.assert_allclose(T.T, Q.T @ G, rtol=0, atol=1e-12 * np.abs(Q.T @ G).max())
    np.testing.assert_allclose(Gr, G.T @ Y, rtol=0, atol=1e-12 * np.abs(G.T @ Y).max())
    assert uniform_grid(np.append(freq[:-1], freq[-1] + 1e-3)) is None


def test_one_blas_thread_for_the_whole_call(monkeypatch):
    """Compression, LSCF and final residues run in the call's one-thread context too,
    and the caller's setting is restored."""
    from threadpoolctl import threadpool_info, threadpool_limits

    from sdctrl.identification import _fit_pass as fit

    seen = []

    def spy(name, fn):
        def wrapped(*args, **kwargs):
            seen.append((name, [i["num_threads"] for i in threadpool_info()
                                if i["user_api"] == "blas"]))
            return fn(*args, **kwargs)
        monkeypatch.setattr(fit, name, wrapped)

    for name in ("compressed_data", "lscf_candidates", "final_model"):
        spy(name, getattr(fit, name))
    frf, _, _ = ten_mode(df=0.1)
    with threadpool_limits(limits=2, user_api="blas"):
        before = [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]
        sd.identify(frf, band=BAND, progress=False, compress_rank=20)
        after = [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]
    assert after == before
    assert {n for n, _ in seen} == {"compressed_data", "lscf_candidates", "final_model"}
    assert all(t == 1 for _, threads in seen for t in threads)
