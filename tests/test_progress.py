"""Progress bars follow one policy (sdctrl/config.py): never in logs, pipes or CI unless asked,
on with ``sdctrl.config.progress = True``, and a call's own ``progress=`` wins."""

import sys

import control
import numpy as np
import pytest

import sdctrl as sd
from sdctrl.closedloop._placement import placement_study
from sdctrl.robust._stability import robust_stability, worst_case_gain


def _chain_fe():
    """Three masses on springs along x, ground - N1 - N2 - N3, with node coordinates."""
    k, m = 1e4, 1.0
    K = k * np.array([[2.0, -1, 0], [-1, 2, -1], [0, -1, 1]])
    nodes = {"N0": (0.0, 0, 0), "N1": (1.0, 0, 0), "N2": (2.0, 0, 0), "N3": (3.0, 0, 0)}
    return sd.FEModel(m * np.eye(3), K, 1e-4 * K, dofs=["N1.x", "N2.x", "N3.x"], nodes=nodes,
                      elements=[("N1", "N2"), ("N2", "N3")])


def _um():
    nm = sd.NormalModeModel(np.diag([1.0]), np.diag([0.02]), [[1.0]], [[1.0]])
    return nm.uncertain(dGamma=[[0.05]])


#: (description shown in the bar, the long call)
CALLS = {
    "mu upper bound": lambda **kw: robust_stability(_um(), control.ss([], [], [], [[0.0]]),
                                                    n_directions=2, **kw),
    "D-strut placement": lambda **kw: placement_study(
        _chain_fe().normal_mode_model(["N3.x"], ["N3.x", "N1.x"], 3), _chain_fe(), (1.0, 100.0),
        kv=50.0, **kw),
    "worst-case gain": lambda **kw: worst_case_gain(_um(), control.ss([], [], [], [[0.0]]),
                                                    freq=[0.1, 0.16, 0.2], n_samples=3, **kw),
}


@pytest.mark.parametrize("desc", sorted(CALLS))
def test_no_progress_output_when_not_a_terminal(desc, capfd):
    assert sd.config.progress is None
    assert not sys.stderr.isatty()
    CALLS[desc]()
    out, err = capfd.readouterr()
    assert "\r" not in err and desc not in err and "it/s" not in err
    assert out == ""


@pytest.mark.parametrize("desc", sorted(CALLS))
def test_config_progress_turns_bars_on(desc, capfd, monkeypatch):
    monkeypatch.setattr(sd.config, "progress", True)        # restored after the test
    CALLS[desc]()
    assert desc in capfd.readouterr().err
    CALLS[desc](progress=False)                              # the call's own argument wins
    assert desc not in capfd.readouterr().err


def test_results_do_not_depend_on_the_bar(monkeypatch):
    quiet = CALLS["D-strut placement"]()
    monkeypatch.setattr(sd.config, "progress", True)
    loud = CALLS["D-strut placement"]()
    assert [c.bar for c in quiet.candidates] == [c.bar for c in loud.candidates]
    assert [c.score for c in quiet.candidates] == [c.score for c in loud.candidates]
