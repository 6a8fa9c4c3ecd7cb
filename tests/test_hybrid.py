"""Hybrid experimental/analytical models (chapter V.1): expansion (4.7), hybrid (5.1),
modifications (5.2), D-struts (5.3)-(5.4), untested loops, and the thesis's analytic check
(5.1.2): a wrong FE model plus "measured" modes of the true one predicts modified and
untested responses several times better than the wrong FE model."""

import warnings

import numpy as np
import pytest
import scipy.sparse as sp
from test_modal_ops import _chain

import sdctrl as sd
from sdctrl.hybrids._build import hybrid, pairing_report
from sdctrl.hybrids._predictions import HybridModel, with_io, with_modification
from sdctrl.testbeds._truss import SENSORS, SHAKERS
from sdctrl.updating._costs import logls
from sdctrl.hybrids._expansion import expand

IN_BAND = np.arange(6, 18)          # testbed modes 7-18: the 8-60 Hz test band
FREQ = np.linspace(8.0, 60.0, 250)
# longeron: 25 x 1.5 mm aluminium tube, 0.5 m bay (sd.testbed docstring)
K_LONGERON = 70e9 * np.pi * (0.025**2 - 0.022**2) / 4 / 0.5
BAR = ("N13", "N17")                # a longeron of the softened bay


def _measured(fe, shakers=SHAKERS):
    """'Measured' normal modes of the true structure: in-band modes at the test sensors."""
    full = fe.normal_mode_model(list(shakers), list(SENSORS), 18)
    s = IN_BAND
    return sd.NormalModeModel(full.Omega[np.ix_(s, s)], full.Gamma[np.ix_(s, s)],
                              full.cphi[:, s], full.phib[s], sensors=full.sensors,
                              actuators=full.actuators)


def _wrong(fe):
    """Deliberately wrong FE: plate centre masses +0.6 kg, four longerons 30% softer."""
    dK = sp.csr_matrix((fe.N, fe.N))
    for a, b in (("N9", "N13"), ("N10", "N14"), ("N13", "N17"), ("N5", "N9")):
        s = fe.strut(a, b)
        dK = dK - 0.3 * K_LONGERON * sp.csr_matrix(s @ s.T)
    d = np.zeros(fe.N)
    for node in ("N31", "N38", "N45"):
        d[fe.dof_index([f"{node}.{ax}" for ax in "xyz"])] = 0.6
    return sd.FEModel(fe.M + sp.diags(d), fe.K + dK, fe.C, dofs=fe.dofs, nodes=dict(fe.nodes),
                      elements=fe.elements)


def _with_strut(fe, kp, kv):
    s = fe.strut(*BAR)
    return sd.FEModel(fe.M, fe.K + kp * s @ s.T, fe.C + kv * s @ s.T, dofs=fe.dofs)


@pytest.fixture(scope="module", autouse=True)
def _one_blas_thread():
    """Batched small solves: one BLAS thread is much faster on a shared machine."""
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1, user_api="blas"):
        yield


@pytest.fixture(scope="module")
def case(_one_blas_thread):
    true = sd.testbed()
    wrong = _wrong(true)
    nm = _measured(true)
    with warnings.catch_warnings():
        warnings.simplefilter("error")              # the pairing must be good here
        h = hybrid(wrong, nm, list(SENSORS), list(SHAKERS))
    return {"true": true, "wrong": wrong, "nm": nm, "h": h}


# ----------------------------------------------------------------------------------------
# thesis 5.1.2: the analytic check
# ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("kind, kp, kv, min_ratio", [
    ("damping", 0.0, 1e4, 4.0),                      # D-strut dashpot
    ("stiffness", -0.5 * K_LONGERON, 0.0, 4.0),      # D-strut softer than the bar
])
def test_analytic_check_strut(case, kind, kp, kv, min_ratio):
    true, wrong, h = case["true"], case["wrong"], case["h"]
    ref = _with_strut(true, kp, kv).frf(FREQ, list(SHAKERS), list(SENSORS))
    fe_pred = _with_strut(wrong, kp, kv).frf(FREQ, list(SHAKERS), list(SENSORS))
    s = wrong.strut(*BAR)
    hy_pred = h.with_feedback(s, s.T, kp=kp, kv=kv)
    err_fe, err_hy = logls(fe_pred, ref), logls(hy_pred.frf(FREQ), ref)
    ratio = err_fe / err_hy
    print(f"\n5.1.2 {kind}: logLS wrong FE {err_fe:.4f}, hybrid {err_hy:.4f}, ratio {ratio:.1f}")
    # measured: damping 0.329 vs 0.066 (ratio 5.0); stiffness 0.409 vs 0.069 (ratio 5.9)
    assert ratio > min_ratio, (kind, err_fe, err_hy)
    assert err_hy < 0.1
    # the prediction's StateSpace carries the same FRF
    G = hy_pred.to_statespace()
    Hs = np.moveaxis(G(2j * np.pi * FREQ[::40]), -1, 0)
    H = hy_pred.frf(FREQ[::40]).H
    assert np.abs(Hs - H).max() < 1e-8 * np.abs(H).max()
    assert isinstance(hy_pred, HybridModel)


def test_analytic_check_untested_shaker(case):
    true, wrong = case["true"], case["wrong"]
    tested, untested = list(SHAKERS[:5]), SHAKERS[5]
    h = hybrid(wrong, _measured(true, tested), list(SENSORS), tested)
    pred = h.with_io(b=[untested])
    assert pred.actuators == (untested,) and pred.sensors == tuple(SENSORS)
    ref = true.frf(FREQ, [untested], list(SENSORS))
    err_fe = logls(wrong.frf(FREQ, [untested], list(SENSORS)), ref)
    err_hy = logls(pred.frf(FREQ), ref)
    print(f"\n5.1.2 untested shaker {untested}: logLS wrong FE {err_fe:.4f}, hybrid "
          f"{err_hy:.4f}, ratio {err_fe / err_hy:.1f}")
    # measured: 0.471 vs 0.045 (ratio 10.5)
    assert err_fe / err_hy > 4.0 and err_hy < 0.1
    # the untested sensor direction too: a collocated pair that was never measured
    pred2 = h.with_io(b=["N20.y"], c=["N20.y", "N33.z"])
    ref2 = true.frf(FREQ, ["N20.y"], ["N20.y", "N33.z"])
    err2_fe = logls(wrong.frf(FREQ, ["N20.y"], ["N20.y", "N33.z"]), ref2)
    assert logls(pred2.frf(FREQ), ref2) < err2_fe / 2


def test_appended_modes_damping_pairing_and_orthogonality(case):
    h, nm, wrong = case["h"], case["nm"], case["wrong"]
    built = h.construction
    meas = h.measured
    assert meas.sum() == nm.n == 12 and h.n == h.shapes.shape[1]
    assert np.all(np.diff(h.frequency) >= 0)
    # measured frequencies and full damping kept exactly
    assert np.allclose(np.sort(h.frequency[meas]), np.sort(nm.frequency), rtol=1e-12)
    Gm = h.Gamma[np.ix_(meas, meas)]
    assert np.allclose(Gm, nm.Gamma, rtol=1e-12, atol=1e-12)
    # appended FE modes: below (suspension) and above the band, mean measured damping
    fe_modes = h.kind == "fe"
    f_app = h.frequency[fe_modes]
    assert np.sum(f_app < 8.0) == 6 and np.sum(f_app > 60.0) >= 8
    zeta = np.diag(h.Gamma)[fe_modes] / (2 * 2 * np.pi * f_app)
    zmean = np.mean(np.diag(nm.Gamma) / (2 * np.sqrt(np.diag(nm.Omega))))
    assert np.allclose(zeta, zmean, rtol=1e-10) and built.mean_damping == pytest.approx(zmean)
    assert np.all(h.Gamma[np.ix_(fe_modes, meas)] == 0)
    # pairing reported: MAC of every pair, FE and test frequencies
    p = built.pairing
    assert p.mac.min() > 0.9 and p.poor.size == 0
    assert np.all(np.abs(p.fe_hz / p.test_hz - 1) < 0.1)
    # appended shapes are FE-mass-orthogonal to the expanded ones (distinct FE modes)
    S = h.shapes
    Mx = S.T @ (wrong.M @ S)
    assert np.abs(Mx[np.ix_(fe_modes, meas)]).max() < 1e-10
    assert h.expanded is h.shapes and h.dofs == wrong.dofs
    table = pairing_report(h).splitlines()
    assert len(table) == 2 + nm.n and "(poor)" not in "".join(table)
    assert table[2].startswith("| 0 | 9.518 | 6 |")


def test_static_correction_modes_are_critically_damped(case):
    true, nm = case["true"], case["nm"]
    s = true.strut(*BAR)
    hs = hybrid(true, nm, list(SENSORS), list(SHAKERS), static_b=s)
    st = hs.kind == "static"
    assert hs.n_static == st.sum() == 1
    w = 2 * np.pi * hs.frequency[st]
    assert np.allclose(np.diag(hs.Gamma)[st], 2 * w)          # critical damping (2.20)
    # with the exact FE model, the expanded + appended + static modes are static-complete
    # for the strut load: sum_j (s^T phi_j)^2 / w_j^2 = s^T K^-1 s
    flex_fe = float((s.T @ true.static_response(s))[0, 0])
    sphi = (s.T @ hs.shapes)[0]
    flex_hy = float(np.sum(sphi**2 / np.diag(hs.Omega)))
    assert flex_hy == pytest.approx(flex_fe, rel=1e-6)
    without = float(np.sum((s.T @ case["h"].shapes)[0] ** 2 / np.diag(case["h"].Omega)))
    assert abs(without / flex_fe - 1) > 1e-3      # (a different FE basis, not complete)


# ----------------------------------------------------------------------------------------
# exactness on a complete basis
# ----------------------------------------------------------------------------------------
def test_hybrid_of_exact_data_reproduces_the_fe_model_and_modifications():
    fe = _chain()
    c = fe.point(list(fe.dofs)).T                 # as many sensors as DOFs: A = I
    b = fe.point(["N2.x", "N6.x"])
    nm = fe.normal_mode_model(b, c, fe.N)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        h = hybrid(fe, nm, c, b)
    f = np.linspace(1.0, 40.0, 200)
    assert np.allclose(h.frf(f).H, nm.frf(f).H, rtol=1e-9, atol=1e-12)
    assert np.allclose(np.abs(h.construction.expansion), np.eye(fe.N), atol=1e-9)
    # default actuator_b: identified phib, point forces from the DOF labels for the
    # appended modes (proportional damping 1%: the mean damping is exact)
    fe0 = sd.FEModel(fe.M, fe.K, dofs=fe.dofs)
    h2 = hybrid(fe0, fe0.normal_mode_model(["N2.x"], c, 4), c)
    assert h2.kind.tolist().count("fe") == 2
    ref = fe0.normal_mode_model(["N2.x"], c, fe.N).frf(f).H
    assert np.allclose(h2.frf(f).H, ref, rtol=1e-9, atol=1e-12)
    # modifications on physical DOFs (5.2) equal the direct FE solution on a full basis
    dM = np.zeros((fe.N, fe.N))
    dM[2, 2] = 0.7
    dK = np.zeros((fe.N, fe.N))
    dK[np.ix_([0, 1], [0, 1])] = 3e3 * np.array([[1, -1], [-1, 1]])
    dC = np.zeros((fe.N, fe.N))
    dC[5, 5] = 4.0
    dM0 = dM.copy()
    mod = with_modification(h, dM, sp.csr_matrix(dC), dK)
    direct = sd.FEModel(fe.M + dM, fe.K + dK, fe.C + dC, dofs=fe.dofs).frf(f, b, c)
    assert np.abs(mod.frf(f).H - direct.H).max() < 1e-9 * np.abs(direct.H).max()
    assert isinstance(mod, HybridModel) and np.array_equal(dM, dM0)
    assert np.allclose(h.with_modification(dM, dC, dK).frf(f).H, mod.frf(f).H)
    # new inputs and outputs by label and by array agree
    m1 = with_io(h, b=["N5.x"], c=["N2.x"])
    m2 = h.with_io(b=fe.point(["N5.x"]), c=fe.point(["N2.x"]).T, actuators=["u"],
                   sensors=["y"])
    assert m1.actuators == ("N5.x",) and m2.sensors == ("y",)
    assert np.allclose(m1.frf(f).H, m2.frf(f).H)
    assert np.allclose(m1.frf(f).H, fe.frf(f, ["N5.x"], ["N2.x"]).H, rtol=1e-9, atol=1e-14)


def test_subclass_survives_model_operations(case):
    h = case["h"]
    s = case["wrong"].strut(*BAR)
    for m in (h.with_feedback(s, s.T, kv=1e3), h.modified(dGamma=0.01 * np.eye(h.n)),
              h.proportional(), h.replace(info={}), h.with_io(c=["N20.y"])):
        assert isinstance(m, HybridModel) and callable(m.with_io)
    # plain NormalModeModel with shapes is accepted and promoted
    fe = _chain()
    nm = fe.normal_mode_model(["N2.x"], ["N3.x"], 4)
    assert isinstance(with_io(nm, b=["N4.x"]), HybridModel)


def test_kind_and_n_static_follow_the_modes(case):
    h = case["h"]
    hs = h.with_static(case["wrong"].strut(*BAR))      # static correction of a strut appended
    k = hs.n - h.n
    assert k >= 1 and hs.n_static == h.n_static + k
    assert hs.kind[:h.n].tolist() == h.kind.tolist() and set(hs.kind[h.n:]) == {"static"}
    assert np.array_equal(hs.measured, hs.kind == "measured")
    assert hs.measured.sum() == h.measured.sum() == h.construction.pairing.test_mode.size
    # a mode added through replace (as diagnosis adds one) has no known origin: kind dropped
    grown = h.replace(Omega=np.diag(np.r_[np.diag(h.Omega), 1e6]),
                      Gamma=np.pad(h.Gamma, (0, 1)) + np.diag(np.r_[np.zeros(h.n), 2e3]),
                      cphi=np.pad(h.cphi, ((0, 0), (0, 1))), phib=np.pad(h.phib, ((0, 1), (0, 0))),
                      shapes=np.pad(h.shapes, ((0, 0), (0, 1))))
    assert grown.n == h.n + 1 and grown.kind is None and grown.measured is None
    with pytest.raises(ValueError, match="kind must hold one of"):
        h.replace(kind=h.kind[:-1])
    with pytest.raises(ValueError, match="kind must hold one of"):
        h.replace(kind=np.where(h.kind == "fe", "guessed", h.kind))


def test_expand_least_squares_smoothing():
    rng = np.random.default_rng(1)
    phi = np.linalg.qr(rng.standard_normal((20, 3)))[0]
    c = np.eye(20)[:8]
    A_true = np.array([[0.9, 0.3], [-0.3, 0.9], [0.05, 0.0]])
    cphi = c @ phi @ A_true
    noise = 1e-3 * rng.standard_normal(cphi.shape)
    shapes, A = expand(phi, c, cphi + noise)
    assert A.shape == (3, 2) and shapes.shape == (20, 2)
    assert np.abs(A - A_true).max() < 1e-2
    assert np.allclose(A, np.linalg.lstsq(c @ phi, cphi + noise, rcond=None)[0], atol=1e-12)
    # least squares: residual orthogonal to the span of c phi
    r = c @ shapes - (cphi + noise)
    assert np.abs((c @ phi).T @ r).max() < 1e-12


# ----------------------------------------------------------------------------------------
# pairing report and bad input
# ----------------------------------------------------------------------------------------
def test_poor_pairing_warns_and_is_reported(case):
    nm = case["nm"]
    rng = np.random.default_rng(3)
    bad = nm.replace(cphi=nm.cphi + 0.8 * np.abs(nm.cphi).max() * rng.standard_normal(
        nm.cphi.shape))
    with pytest.warns(UserWarning, match="poor FE/test mode pairing"):
        h = hybrid(case["wrong"], bad, list(SENSORS), list(SHAKERS))
    assert h.construction.pairing.poor.size > 0
    assert "(poor)" in pairing_report(h)
    assert np.all(h.construction.pairing.mac[h.construction.pairing.poor] < 0.8)


def test_bad_input_names_the_argument(case):
    wrong, nm, h = case["wrong"], case["nm"], case["h"]
    c = wrong.point(list(SENSORS)).T
    c0 = c.copy()
    with pytest.raises(TypeError, match="fe must be an FEModel"):
        hybrid(np.eye(3), nm, c)
    with pytest.raises(TypeError, match="nm must be a NormalModeModel"):
        hybrid(wrong, "nm", c)
    with pytest.raises(ValueError, match="sensor_c"):
        hybrid(wrong, nm, c[:-1])
    with pytest.raises(ValueError, match="sensor_c"):
        hybrid(wrong, nm, c[:, :-1])
    with pytest.raises(ValueError, match="actuator_b"):
        hybrid(wrong, nm, c, wrong.point(list(SHAKERS[:2])))
    with pytest.raises(ValueError, match="unknown DOF label"):
        hybrid(wrong, nm, ["nope"] * nm.ns)
    with pytest.raises(ValueError, match="fmax"):
        hybrid(wrong, nm, c, fmax=-1.0)
    bad = c.copy()
    bad[0, 0] = np.nan
    with pytest.raises(ValueError, match="sensor_c must contain only finite"):
        hybrid(wrong, nm, bad)
    with pytest.raises(ValueError, match="Omega must be diagonal"):
        hybrid(wrong, nm.replace(Omega=nm.Omega + 1.0), c)
    with pytest.raises(ValueError, match="b must have shape"):
        h.with_io(b=np.ones((3, 1)))
    with pytest.raises(ValueError, match="c must have shape"):
        h.with_io(c=np.ones((1, 3)))
    with pytest.raises(ValueError, match="no shapes"):
        with_io(nm, b=np.ones((wrong.N, 1)))
    with pytest.raises(ValueError, match="dK must have shape"):
        with_modification(h, dK=np.eye(3))
    assert np.array_equal(c, c0)


# ----------------------------------------------------------------------------------------
# damper placement on the hybrid model
# ----------------------------------------------------------------------------------------
def test_placement_study_on_the_hybrid_ranks_like_the_true_structure(case, capsys):
    from scipy.stats import spearmanr

    from sdctrl.closedloop._loops import rms
    from sdctrl.closedloop._placement import placement_study

    h, wrong, true = case["h"], case["wrong"], case["true"]
    truss = [e for e in wrong.elements if max(int(e[0][1:]), int(e[1][1:])) <= 28]
    outs = list(SENSORS[:6])
    study = placement_study(h, wrong, (8, 60), kv=4e4, candidates=truss, outputs=outs,
                            progress=False)
    assert capsys.readouterr().err == ""                    # progress bar disabled
    assert len(study.candidates) == len(truss) == 83 and not study.skipped
    scores = [c.score for c in study.candidates]
    assert scores == sorted(scores, reverse=True)
    best = study.best
    # numbers of a candidate recomputed independently
    s = wrong.strut(*best.bar)
    cl = h.with_feedback(s, s.T, kv=4e4)
    r = rms(cl.to_statespace()[list(range(6)), :], (8, 60))
    assert np.allclose(best.rms, r, rtol=1e-10)
    assert np.allclose(best.reduction, 1 - r / study.rms_open, rtol=1e-10)
    assert best.damping.size == study.damping.size == 12     # the 12 modes of the band
    assert np.mean(best.damping) > np.mean(study.damping)
    assert "| 1 | " + "-".join(best.bar) in study.table(3)
    # the same study on the true structure (40 FE modes) picks the same bar, same order
    ref = placement_study(true.normal_mode_model(list(SHAKERS), list(SENSORS), 40), true,
                          (8, 60), kv=4e4, candidates=truss, outputs=outs, progress=True)
    assert "D-strut placement" in capsys.readouterr().err    # tqdm progress bar
    assert ref.best.bar == best.bar
    a = {c.bar: c.score for c in study.candidates}
    b = {c.bar: c.score for c in ref.candidates}
    rho = spearmanr([a[k] for k in truss], [b[k] for k in truss]).correlation
    assert rho > 0.95
    # damping criterion and skipped candidates
    st2 = placement_study(h, wrong, (8, 60), kv=4e4, candidates=truss[:5] + [("N1", "N99")],
                          criterion="damping", progress=False)
    assert [c.score for c in st2.candidates] == [float(np.min(c.damping))
                                                 for c in st2.candidates]
    assert st2.skipped[0][0] == ("N1", "N99") and "unknown node" in st2.skipped[0][1]


def test_placement_study_bad_input(case):
    from sdctrl.closedloop._placement import placement_study

    h, wrong = case["h"], case["wrong"]
    with pytest.raises(TypeError, match="model must be"):
        placement_study("h", wrong, (8, 60), kv=1.0)
    with pytest.raises(TypeError, match="fe must be"):
        placement_study(h, "fe", (8, 60), kv=1.0)
    with pytest.raises(ValueError, match="band must be finite"):
        placement_study(h, wrong, (8, np.inf), kv=1.0)
    with pytest.raises(ValueError, match="criterion"):
        placement_study(h, wrong, (8, 60), kv=1.0, criterion="cost")
    with pytest.raises(ValueError, match="outputs: unknown output"):
        placement_study(h, wrong, (8, 60), kv=1.0, outputs=["nope"])
    with pytest.raises(ValueError, match="band: no mode"):
        placement_study(h, wrong, (1000, 2000), kv=1.0)
    with pytest.raises(ValueError, match="kv"):
        placement_study(h, wrong, (8, 60), kv=np.nan)
