"""D-strut placement by chunks of candidates evaluated as arrays (closedloop._strut_chunks)
against the dense path it replaces: each candidate's closed loop built as a model
(``with_feedback``, the hybrid's own static correction mode per strut, 5.4) and its RMS by
:func:`sdctrl.rms` on its StateSpace.  Poles agree to 1e-8 on clean and noisy data, with a
position gain, and the same bars are skipped for the same reasons; the RMS to the dense
reference's own accuracy on the default hybrid (:data:`DENSE_RTOL`), 1e-8 on a plain model.
"""

import numpy as np
import pytest

import sdctrl as sd
from sdctrl.closedloop._loops import rms
from sdctrl.closedloop._placement import _track, placement_study
from sdctrl.fe._static import strut_entries


#: the dense reference's accuracy on the default hybrid (``residual="auto"``: the test's
#: residual dynamics and F kept, the closed loop's defective clusters sending its band
#: integral to matrix logarithms): against an adaptive quadrature of |H|^2 over the band
#: (quad_vec, epsrel 1e-13) on the clean lattice hybrid, the array path is within 3.2e-14
#: and the logm reference within 1.17e-7 (tests/test_lattice.py, DENSE_RTOL); x2.5
DENSE_RTOL = 3e-7


@pytest.fixture(scope="module")
def lat():
    return sd.testbeds.lattice(300)


def _hybrid(lat, noise):
    frf = lat.frf(n=300, noise=noise, seed=3) if noise else lat.frf(n=300)
    up = sd.update(lat.wrong(), frf, lat.parameters())
    nm = sd.normal_modes(sd.identify(frf), frf.collocated)
    return up.fe, sd.hybrid(up.fe, nm, up.fe.point(list(lat.sensors)).T)


@pytest.fixture(scope="module", params=[0.0, 0.01], ids=["clean", "noisy"])
def case(request, lat):
    return _hybrid(lat, request.param)


def _dense(model, fe, bar, band, outputs, kv, kp):
    """The dense path: the closed loop as a model, its RMS from its StateSpace."""
    s = fe.strut(*bar)
    cl = model.with_feedback(s, s.T, kp=kp, kv=kv)
    idx = [list(model.sensors).index(o) for o in outputs]
    return cl, rms(cl.to_statespace()[idx, :], band)


def test_strut_entries_are_the_strut_shape(lat):
    fe = lat.fe()
    grounded = 0
    for bar in fe.elements[::7]:
        try:
            s = fe.strut(*bar)[:, 0]
        except ValueError as exc:                # a bar between two grounded nodes
            with pytest.raises(ValueError, match=str(exc)):
                strut_entries(fe, *bar)
            grounded += 1
            continue
        rows, vals = strut_entries(fe, *bar)
        assert rows.size <= 6 and np.array_equal(np.flatnonzero(s), np.sort(rows[vals != 0]))
        full = np.zeros(fe.N)
        full[rows] = vals
        assert np.array_equal(full, s)
        e = np.subtract(fe.nodes[bar[1]], fe.nodes[bar[0]])
        e = e / np.linalg.norm(e)                                  # the bar's unit axis
        for i, v in zip(rows, vals):
            node, ax = fe.dofs[i].split(".")
            assert v == pytest.approx((1 if node == bar[1] else -1) * e["xyz".index(ax)],
                                      abs=1e-15)
    assert 0 < grounded < len(fe.elements[::7]) / 4
    with pytest.raises(ValueError, match="node_b: unknown node"):
        strut_entries(fe, fe.elements[0][0], "nowhere")
    with pytest.raises(ValueError, match="distinct"):
        strut_entries(fe, fe.elements[0][0], fe.elements[0][0])


@pytest.mark.parametrize("kp", [0.0, -2e3])
def test_chunked_placement_equals_the_dense_path(lat, case, kp):
    fe, h = case
    # the chunked path runs: each strut gets its static correction mode, and the default
    # hybrid's fixed part (the test's residual dynamics and F, kept at the tested I/O) is
    # appended to every closed loop
    assert h.static_ready and h.E is None
    assert h.construction.residual.representation == "tested" and h.F is not None
    bars = list(fe.elements[::29])[:5]
    outs = list(h.sensors[::3])
    st = placement_study(h, fe, lat.band, kv=300.0, kp=kp, candidates=bars, outputs=outs,
                         progress=False)
    assert not st.skipped and len(st.candidates) == len(bars)
    f = np.abs(h.poles) / (2 * np.pi)
    p_open = h.poles[(f >= lat.band[0]) & (f <= lat.band[1])]
    assert np.allclose(st.frequency, np.abs(p_open[p_open.imag > 0]) / (2 * np.pi))
    for c in st.candidates:
        cl, r = _dense(h, fe, c.bar, lat.band, outs, 300.0, kp)
        assert cl.n == h.n + 1                                    # its static mode
        p = _track(p_open[p_open.imag > 0], cl.poles)
        assert np.allclose(c.frequency, np.abs(p) / (2 * np.pi), rtol=1e-8, atol=0)
        assert np.allclose(c.damping, -p.real / np.abs(p), rtol=1e-8, atol=1e-12)
        assert np.allclose(c.rms, r, rtol=DENSE_RTOL, atol=0)
        assert np.allclose(c.reduction, 1 - r / st.rms_open, rtol=0, atol=DENSE_RTOL)
    # the strut damps: on average the band's modes gain damping, the RMS drops
    assert np.mean([c.damping.mean() for c in st.candidates]) > st.damping.mean()
    assert st.best.score == max(c.score for c in st.candidates) > 0


def test_chunked_placement_on_an_fe_model_without_static_modes(lat):
    fe = lat.fe()
    nm = fe.normal_mode_model(list(lat.shakers), list(lat.sensors), 20)
    bars = list(fe.elements[::41])[:8]
    st = placement_study(nm, fe, lat.band, kv=300.0, candidates=bars, criterion="damping",
                         progress=False)
    for c in st.candidates:
        cl, r = _dense(nm, fe, c.bar, lat.band, list(nm.sensors), 300.0, 0.0)
        assert cl.n == nm.n
        assert np.allclose(c.rms, r, rtol=1e-8, atol=0)
        assert c.score == pytest.approx(np.min(c.damping), rel=0, abs=0)
    scores = [c.score for c in st.candidates]
    assert scores == sorted(scores, reverse=True)


def test_chunked_placement_skips_what_the_dense_path_refuses(lat, case):
    fe, h = case
    bars = list(fe.elements[:3])
    bad = (bars[0][0], "nowhere")
    st = placement_study(h, fe, lat.band, kv=300.0, candidates=bars + [bad], progress=False)
    assert dict(st.skipped) == {bad: "node_b: unknown node 'nowhere'"}
    assert [c.bar for c in st.candidates if c.bar in bars] and len(st.candidates) == 3
    kp = -1e12                                                    # a destabilising spring
    with pytest.raises(ValueError) as dense:
        _dense(h, fe, bars[0], lat.band, list(h.sensors), 300.0, kp)
    assert "right half-plane" in str(dense.value)
    with pytest.raises(ValueError) as chunked:
        placement_study(h, fe, lat.band, kv=300.0, kp=kp, candidates=bars, progress=False)
    assert str(chunked.value) == ("candidates: none could be evaluated (closed loop with "
                                  f"kv=300, kp={kp:g}: {dense.value})")


def test_default_thread_pool_gives_the_serial_result_bit_for_bit(lat, case, monkeypatch):
    import os
    import threading

    import sdctrl.closedloop._placement as placement

    fe, h = case
    bars = list(fe.elements[::7])[:placement.CHUNK + 2]         # two chunks: the pool runs
    seen = []
    evaluate = placement._evaluate

    def spy(chunk, loop):
        seen.append(threading.current_thread() is threading.main_thread())
        return evaluate(chunk, loop)

    monkeypatch.setattr(placement, "_evaluate", spy)
    kw = {"candidates": bars, "outputs": list(h.sensors[::2]), "progress": False}
    pooled = placement_study(h, fe, lat.band, kv=300.0, **kw)
    assert seen == [(os.cpu_count() or 1) < 2] * 2              # workers, not this thread
    monkeypatch.setattr(placement, "THREADS", 1)
    seen.clear()
    serial = placement_study(h, fe, lat.band, kv=300.0, **kw)
    assert seen == [True, True]
    assert len(serial.candidates) == len(bars) - len(serial.skipped) > placement.CHUNK
    assert [c.bar for c in pooled.candidates] == [c.bar for c in serial.candidates]
    for a, b in zip(pooled.candidates, serial.candidates):
        for name in ("frequency", "damping", "rms", "reduction"):
            assert np.array_equal(getattr(a, name), getattr(b, name)), name
        assert a.score == b.score
    assert pooled.skipped == serial.skipped
    assert np.array_equal(pooled.rms_open, serial.rms_open)
