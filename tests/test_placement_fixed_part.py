"""D-strut placement on a model with terms a strut leaves unchanged: a hybrid whose residual
representation is the test's own (``residual="tested"``: residual mass ``F`` realised by
correction modes, complex-mode residual dynamics at the tested I/O).  Its candidates are
evaluated as arrays like those of a plain model, the fixed block appended to every closed
loop (:mod:`sdctrl._lib.bandappend`); each equals the dense path -- the closed loop built as
a model (``with_feedback``) and its RMS from its whole StateSpace by matrix logarithms.
"""

import warnings

import numpy as np
import pytest

import sdctrl as sd
from sdctrl._lib.bandappend import band_integral_appended, fixed_block
from sdctrl._lib.bandint import band_integral
from sdctrl._lib.statespace import mass_correction, second_order
from sdctrl.closedloop._loops import rms
from sdctrl.closedloop._placement import _track, placement_study

BAND = (8.0, 60.0)


@pytest.fixture(scope="module")
def case():
    st = sd.testbeds.structure("truss")
    frf = st.frf(n=400, noise=0.01, seed=1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        nm = sd.normal_modes(sd.identify(frf, progress=False), std=False)
        fe = st.wrong()
        h = sd.hybrid(fe, nm, list(st.sensors), list(st.shakers), residual="tested")
    return fe, h


def _assembled(A1, B1, C1, A2, B2, C2, D):
    k = A1.shape[0]
    A = np.zeros((k + A2.shape[0],) * 2)
    A[:k, :k], A[k:, k:] = A1, A2
    return A, np.vstack([B1, B2]), np.hstack([C1, C2]), D


@pytest.mark.parametrize("critical", [False, True])
def test_appended_integral_equals_the_assembled_one(critical):
    """Modes (one critically damped pair when ``critical``: a 2x2 defective cluster) with a
    residual-mass block (a triple real pole, defective) and a feedthrough appended."""
    rng = np.random.default_rng(4)
    n, ns, na = 6, 3, 2
    w = 2 * np.pi * np.array([9.0, 14.0, 21.0, 33.0, 47.0, 58.0])
    zeta = np.array([0.01, 0.02, 0.015, 0.03, 0.01, 0.02])
    if critical:
        zeta[3] = 1.0
    A1, B1, C1, _ = second_order(np.diag(w**2), np.diag(2 * zeta * w),
                                 rng.normal(size=(n, na)), rng.normal(size=(ns, n)))
    A2, B2, C2, D2 = mass_correction(1e-3 * rng.normal(size=(ns, na)), 2 * np.pi * 0.8)
    D = 1e-4 * rng.normal(size=(ns, na)) + D2
    S = np.array([1.0, 0.5])
    w1, w2 = 2 * np.pi * np.array(BAND)
    ref = band_integral(*_assembled(A1, B1, C1, A2, B2, C2, D), S, w1, w2)
    got = band_integral_appended(A1, B1, C1, fixed_block(A2, B2, C2, D, S, w1, w2))
    assert got is not None
    assert np.abs(got - ref).max() <= 1e-9 * np.abs(ref).max()


def test_tested_hybrid_candidates_equal_the_dense_path(case):
    fe, h = case
    assert h.F is not None and h.residual is not None and h.residual.m > 0   # a fixed block
    bars = list(fe.elements[::23])[:4]
    outs = list(h.sensors[::4])
    st = placement_study(h, fe, BAND, kv=300.0, candidates=bars, outputs=outs, progress=False)
    assert not st.skipped and len(st.candidates) == len(bars)
    idx = [list(h.sensors).index(o) for o in outs]
    # the same band integral by two paths: 2.8e-8 apart on one machine, below 1e-8 on
    # another (the BLAS kernels' round-off), so equal to 1e-6 (as the closed loops below)
    assert np.allclose(st.rms_open, rms(h.to_statespace()[idx, :], BAND), rtol=1e-6, atol=0)
    f = np.abs(h.poles) / (2 * np.pi)
    p_open = h.poles[(f >= BAND[0]) & (f <= BAND[1]) & (h.poles.imag > 0)]
    for c in st.candidates:
        s = fe.strut(*c.bar)
        cl = h.with_feedback(s, s.T, kv=300.0)
        assert cl.n == h.n + 1                                  # the strut's static mode
        p = _track(p_open, cl.poles)
        assert np.allclose(c.frequency, np.abs(p) / (2 * np.pi), rtol=1e-10, atol=0)
        assert np.allclose(c.damping, -p.real / np.abs(p), rtol=1e-8, atol=1e-12)
        r = rms(cl.to_statespace()[idx, :], BAND)
        assert np.allclose(c.rms, r, rtol=1e-6, atol=0)          # 1.06e-7 apart (1e-7 once)
        # the residual terms count: without them the RMS differs by far more
        bare = cl.replace(F=None, residual=None)
        assert np.max(np.abs(rms(bare.to_statespace()[idx, :], BAND) / r - 1)) > 1e-4
