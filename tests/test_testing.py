"""Closed-loop RMS snapshots (sdctrl.testing): record, compare with a readable per-output
diff, and the rms_snapshot pytest fixture as a user's suite sees it."""

import json

import control
import numpy as np
import pytest

from sdctrl.closedloop._loops import feedback, rms
from sdctrl.testing import assert_rms_matches, load_snapshot, record_rms

pytest_plugins = ["pytester"]


def _plant(zeta=0.01):
    w = np.array([3.0, 7.0])
    A = np.zeros((4, 4))
    for k in range(2):
        A[2 * k:2 * k + 2, 2 * k:2 * k + 2] = [[0, 1], [-w[k] ** 2, -2 * zeta * w[k]]]
    B = np.array([[0.0], [1.0], [0.0], [0.5]])
    C = np.array([[1.0, 0.0, 0.5, 0.0], [0.0, 0.0, 2.0, 0.0]])      # x1 collocated with f
    return control.ss(A, B, C, 0, inputs=["f"], outputs=["x1", "x2"])


def _controller(g=2.0):
    """Washout velocity feedback g s / (s + 20) on x1 (adds damping)."""
    return control.ss([[-20.0]], [[1.0, 0.0]], [[-20.0 * g]], [[g, 0.0]], inputs=["x1", "x2"],
                      outputs=["f"])


def test_record_and_match_roundtrip(tmp_path):
    P, K = _plant(), _controller()
    path = tmp_path / "snap" / "loop.json"
    snap = record_rms(P, (0.1, 2.0), psd=0.3, path=path, controller=K, name="loop",
                      note="two-mode plant, lag compensator")
    data = json.loads(path.read_text())
    assert data == snap and data["band_hz"] == [0.1, 2.0] and data["psd"] == 0.3
    closed = feedback(P, K)
    expected = rms(closed, (0.1, 2.0), 0.3)
    assert list(data["rms"]) == ["x1", "x2"]
    assert np.allclose(list(data["rms"].values()), expected, rtol=1e-14)
    assert data["controller"] == {"inputs": ["x1", "x2"], "outputs": ["f"], "nstates": 1}
    # the closed loop matches, given either closed or as plant + controller, dict or file
    got = assert_rms_matches(closed, path, rtol=1e-12)
    assert np.allclose(got, expected, rtol=1e-14)
    assert_rms_matches(P, snap, rtol=1e-12, controller=K)
    # infinite band is stored as "inf"
    whole = record_rms(closed, (0.0, np.inf))
    assert whole["band_hz"] == [0.0, "inf"]
    assert_rms_matches(closed, whole, rtol=1e-12)
    assert load_snapshot(path)["name"] == "loop"


def test_mismatch_gives_a_per_output_diff():
    P = _plant()
    snap = record_rms(feedback(P, _controller(2.0)), (0.1, 2.0))
    with pytest.raises(AssertionError) as err:
        assert_rms_matches(feedback(P, _controller(2.5)), snap, rtol=1e-6)
    msg = str(err.value)
    assert "closed-loop RMS differs from the snapshot" in msg and "rtol=1e-06" in msg
    lines = [ln for ln in msg.splitlines() if ln.strip().startswith(("x1", "x2"))]
    assert len(lines) == 2 and all(ln.rstrip().endswith("FAIL") for ln in lines)
    # loose enough tolerance passes; the relative difference shown is the real one
    r0 = np.array(list(snap["rms"].values()))
    r1 = rms(feedback(P, _controller(2.5)), (0.1, 2.0))
    rel = (r1 - r0) / r0
    assert f"{rel[0]:+10.3e}" in msg
    assert_rms_matches(feedback(P, _controller(2.5)), snap, rtol=1.01 * np.abs(rel).max())
    # a renamed output is reported as missing / new
    G = feedback(P, _controller(2.0))
    G2 = control.ss(G.A, G.B, G.C, G.D, inputs=G.input_labels, outputs=["x1", "y2"])
    with pytest.raises(AssertionError, match=r"(?s)x2 .*missing.*y2 .*new output"):
        assert_rms_matches(G2, snap)


def test_bad_snapshot_input(tmp_path):
    G = _plant()
    with pytest.raises(TypeError, match="snapshot must be"):
        assert_rms_matches(G, 3.0)
    with pytest.raises(ValueError, match="snapshot: no such file"):
        assert_rms_matches(G, tmp_path / "nope.json")
    with pytest.raises(ValueError, match="not an sdctrl RMS snapshot"):
        assert_rms_matches(G, {"rms": {}})
    with pytest.raises(ValueError, match="rtol"):
        assert_rms_matches(G, record_rms(G, (0.1, 1.0)), rtol=-1.0)
    with pytest.raises(ValueError, match="band"):
        record_rms(G, (1.0, 0.5))


USER_TEST = '''
import control
import numpy as np
from sdctrl import feedback

GAIN = {gain}


def test_loop(rms_snapshot):
    P = control.ss([[0, 1], [-4, -0.04]], [[0], [1]], [[1, 0]], 0, inputs=["f"],
                   outputs=["x"])
    K = control.ss([], [], [], [[GAIN]], inputs=["x"], outputs=["f"])
    rms_snapshot.check(feedback(P, K), band=(0.05, 2.0), psd=1e-2, rtol=1e-6)
'''


def test_fixture_in_a_user_suite(pytester, monkeypatch):
    """A user's suite, run by pytest itself (the fixture comes from the pytest11 entry
    point; nothing to configure)."""
    def run(gain, *args):
        pytester.makepyfile(test_user=USER_TEST.format(gain=gain))
        return pytester.runpytest("-q", "-rs", "-p", "no:cacheprovider", *args)

    snap = pytester.path / "rms_snapshots" / "test_user" / "test_loop.json"
    monkeypatch.delenv("CI", raising=False)
    first = run(1.0)
    first.assert_outcomes(skipped=1)                    # recorded: skipped with the reason
    first.stdout.fnmatch_lines(["*RMS snapshot recorded: *test_loop.json (check it in*"])
    assert "Compare with the stored snapshot" not in first.stdout.str()   # no docstring dump
    assert snap.exists()
    snap.unlink()
    monkeypatch.setenv("CI", "true")
    under_ci = run(1.0)
    under_ci.assert_outcomes(failed=1)
    under_ci.stdout.fnmatch_lines(["*missing under CI*"])
    assert "Compare with the stored snapshot" not in under_ci.stdout.str()
    assert snap.exists()
    monkeypatch.delenv("CI")
    run(1.0).assert_outcomes(passed=1)
    changed = run(1.5)
    changed.assert_outcomes(failed=1)
    changed.stdout.fnmatch_lines(["*closed-loop RMS differs from the snapshot*",
                                  "*x *FAIL*"])
    run(1.5, "--sdctrl-update-rms").assert_outcomes(passed=1)
    run(1.5).assert_outcomes(passed=1)
    assert json.loads(snap.read_text())["psd"] == 0.01
