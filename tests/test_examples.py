"""Examples and notebooks run in the test suite so that they never rot."""

import os
import pathlib
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
EXAMPLES = sorted((ROOT / "examples").glob("*.py"))
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))


def _env():
    env = dict(os.environ, MPLBACKEND="Agg", OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    env["SDCTRL_QUIET"] = "1"
    # the code under test, even from a checkout other than the installed one
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    return env


@pytest.mark.parametrize("script", EXAMPLES, ids=[p.name for p in EXAMPLES])
def test_example_runs(script, tmp_path):
    proc = subprocess.run([sys.executable, str(script), str(tmp_path)], check=False,
                          cwd=tmp_path, env=_env(), capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, f"{script.name} failed:\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"


@pytest.mark.parametrize("notebook", NOTEBOOKS, ids=[p.name for p in NOTEBOOKS])
def test_notebook_runs(notebook, tmp_path, monkeypatch):
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    for k, v in _env().items():
        monkeypatch.setenv(k, v)
    nb = nbformat.read(notebook, as_version=4)
    client = nbclient.NotebookClient(nb, timeout=600, kernel_name="python3",
                                     resources={"metadata": {"path": str(tmp_path)}})
    client.execute()


def test_cli_demo(tmp_path):
    from sdctrl.cli import main

    out = tmp_path / "demo"
    assert main(["demo", "--out", str(out), "--quiet"]) == 0
    report = (out / "report.md").read_text()
    assert "# sdctrl demo report" in report and (out / "bode.png").stat().st_size > 10_000
    assert "![Bode plot](bode.png)" in report
    # the identification section: the 3 true modes found from noisy data, no initial guess
    sec = report.split("## Identification")[1].split("##")[0]
    rows = [r.split("|") for r in sec.splitlines() if r.startswith("| ") and r[2].isdigit()]
    assert len(rows) == 3
    assert max(abs(float(r[4])) for r in rows) < 1e-4          # relative frequency error
    assert max(abs(float(r[7])) for r in rows) < 1e-3          # absolute damping error
    assert "Identified `Gamma`" in report


def test_cli_console_script_and_info(tmp_path):
    import numpy as np

    import sdctrl as sd

    frf = sd.FRF(np.linspace(1, 10, 10), np.ones((10, 2, 1)), sensors=["N1.x", "N2.x"],
                 actuators=["N1.x"], collocated=[(0, 0)])   # stored: never guessed from labels
    sd.write_uff(frf, tmp_path / "t.uff")
    exe = pathlib.Path(sys.executable).with_name("sdctrl")
    cmd = [str(exe)] if exe.exists() else [sys.executable, "-m", "sdctrl.cli"]
    proc = subprocess.run(cmd + ["info", str(tmp_path / "t.uff")], check=False,
                          capture_output=True, text=True, env=_env(), timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "2 sensors x 1 actuators" in proc.stdout and "N1.x/N1.x" in proc.stdout
    bad = subprocess.run(cmd + ["info", str(tmp_path / "missing.uff")], check=False,
                         capture_output=True, text=True, env=_env(), timeout=120)
    assert bad.returncode == 2 and "does not exist" in bad.stderr
