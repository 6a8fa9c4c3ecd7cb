"""Every model and result prints as one short line (sizes, frequency range, key figures), never
its arrays; notebook tables (``_repr_markdown_``) are bounded too."""

import control
import numpy as np
import pytest

import sdctrl as sd
from sdctrl._lib.display import MAX_ROWS
from sdctrl.closedloop._placement import Candidate, PlacementStudy, placement_study
from sdctrl.hybrids._predictions import HybridModel
from sdctrl.robust._stability import RobustResult, robust_stability
from sdctrl.testbeds._truss import SENSORS, SHAKERS
from sdctrl.testing import RMSSnapshot
from sdctrl.robust._uncertainty import multi_test_statistics

SHORT = 200


@pytest.fixture(scope="module")
def big():
    fe = sd.testbed()
    nm = fe.normal_mode_model(list(SHAKERS), list(SENSORS), 40, static=True)
    return fe, nm


def _short(obj, *needles):
    text = repr(obj)
    assert len(text) < SHORT and "\n" not in text, text
    assert "array" not in text and "[[" not in text, text
    for needle in needles:
        assert needle in text, (needle, text)
    return text


def _table_rows(md: str) -> int:
    return sum(1 for line in md.splitlines() if line.startswith("| ") and "---" not in line) - 1


def test_normal_mode_and_hybrid_models(big):
    _, nm = big
    _short(nm, "NormalModeModel(", f"n={nm.n}", "ns=31", "na=6", "band=0.448-815 Hz",
           "full Gamma", "shapes on 246 DOFs")
    md = nm._repr_markdown_()
    assert _table_rows(md) == MAX_ROWS and f"and {nm.n - MAX_ROWS} more" in md
    assert "| 1 | 0.448 |" in md
    hy = HybridModel(nm.Omega, nm.Gamma, nm.cphi, nm.phib, sensors=nm.sensors,
                     actuators=nm.actuators, shapes=nm.shapes, dofs=nm.dofs)
    _short(hy, "HybridModel(", f"n={nm.n}", "shapes on 246 DOFs")
    small = sd.NormalModeModel(np.diag([4.0, 9.0]) * 4 * np.pi**2, np.diag([0.1, 0.2]),
                               np.eye(2), np.eye(2))
    assert repr(small) == "NormalModeModel(n=2, ns=2, na=2, band=2-3 Hz)"
    assert _table_rows(small._repr_markdown_()) == 2


def test_complex_mode_model():
    rng = np.random.default_rng(0)
    f = np.linspace(10.0, 90.0, 50)
    lam = 2 * np.pi * f * (-0.01 + 1j)
    R = rng.standard_normal((50, 31, 6)) + 1j * rng.standard_normal((50, 31, 6))
    ib = (f >= 20) & (f <= 60)
    cm = sd.ComplexModeModel(lam, R, in_band=ib, band=(20.0, 60.0), cost=1.5e-3)
    _short(cm, "ComplexModeModel(", "n=50", "ns=31", "na=6", "10-90 Hz", f"{ib.sum()} in band",
           "band=20-60 Hz", "cost=0.0015")
    md = cm._repr_markdown_()
    assert _table_rows(md) == MAX_ROWS and "| in band |" in md


def test_frf_and_fe_model(big):
    fe, _ = big
    H = np.ones((2000, 31, 6), complex)
    frf = sd.FRF(np.linspace(1, 100, 2000), H)
    _short(frf, "2000 lines", "31 sensors x 6 actuators")
    _short(fe, "FEModel(", "246 DOFs", "sparse")


def test_uncertain_model_and_multi_test(big):
    _, nm = big
    um = nm.uncertain(dGamma=0.1 * np.abs(nm.Gamma))
    nb = len(um.blocks)
    assert nb > 1000
    _short(um, "UncertainModel(", f"n={nm.n}", f"{nb} uncertain parameters")
    assert _table_rows(um._repr_markdown_()) == MAX_ROWS
    small = nm.replace(Omega=nm.Omega * 1.01)
    mt = multi_test_statistics([nm, small])
    _short(mt, "MultiTestResult(", "2 models", "min MAC=1.000")


def test_results():
    r = RobustResult(0.5, 0.6, True, 12.3, np.zeros(300), np.linspace(0, 100, 5000),
                     np.ones(5000), {"n_freq": 5000})
    _short(r, "margin=0.5", "margin_lower=0.6", "stable=True", "frequency=12.3 Hz")
    nm = sd.NormalModeModel(np.diag([1.0]), np.diag([0.02]), [[1.0]], [[1.0]])
    real = robust_stability(nm.uncertain(dGamma=[[0.05]]), control.ss([], [], [], [[0.0]]),
                            n_directions=2)
    _short(real, "RobustResult(", "1 blocks")
    cands = tuple(Candidate((f"N{i}", f"N{i + 1}"), np.ones(20), np.full(20, 0.02),
                            np.ones(31), np.full(31, 0.1), 0.1) for i in range(200))
    st = PlacementStudy(cands, (8.0, 60.0), tuple(SENSORS), np.ones(20), np.ones(20),
                        np.ones(31), 0.0, 4e4, "rms")
    _short(st, "PlacementStudy(", "200 candidates", "best=N0-N1", "band=8-60 Hz")
    _short(cands[0], "Candidate(", "N0-N1", "score=0.1", "10.0 %", "2.00 %")
    assert _table_rows(st._repr_markdown_()) == 10
    _short(RMSSnapshot("snap.json"), "RMSSnapshot(", "snap.json")


def test_placement_study_repr_from_a_real_study():
    K = 1e4 * np.array([[2.0, -1, 0], [-1, 2, -1], [0, -1, 1]])
    nodes = {"N0": (0.0, 0, 0), "N1": (1.0, 0, 0), "N2": (2.0, 0, 0), "N3": (3.0, 0, 0)}
    fe = sd.FEModel(np.eye(3), K, 1e-4 * K, dofs=["N1.x", "N2.x", "N3.x"], nodes=nodes,
                    elements=[("N1", "N2"), ("N2", "N3")])
    st = placement_study(fe.normal_mode_model(["N3.x"], ["N3.x"], 3), fe, (1.0, 100.0), kv=50.0)
    _short(st, "2 candidates", "kv=50", "criterion='rms'")


def test_hybrid_table_carries_the_pairing_report():
    fe = sd.testbed()
    nm = fe.normal_mode_model(list(SHAKERS), list(SENSORS), 18)
    h = sd.hybrid(fe, nm, list(SENSORS))
    _short(h, "HybridModel(", "ns=31", "na=6", "shapes on 246 DOFs")
    md = h._repr_markdown_()
    assert "FE/test mode pairing" in md and "| test mode | test Hz |" in md
    assert len(md) < 20_000
