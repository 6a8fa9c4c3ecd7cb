"""Examples, notebooks and the README's python blocks run in the test suite so that they
never rot."""

import os
import pathlib
import re
import runpy
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]

EXAMPLES = sorted((ROOT / "examples").glob("*.py"))
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))
NOT_RUN = "# not executed"


def _env():
    env = dict(os.environ, MPLBACKEND="Agg", OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    env["SDCTRL_QUIET"] = "1"
    # the code under test, even from a checkout other than the installed one
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    return env


#: the example run as a user runs it (a fresh interpreter, ``python example.py outdir``); the
#: others run in this process (:func:`test_example_runs`): a fresh interpreter costs the
#: imports of sdctrl, python-control, scipy and matplotlib again (about 4 s of CPU each)
AS_A_USER = ROOT / "examples" / "two_mode_study.py"


def test_example_runs_as_a_user_runs_it(tmp_path):
    proc = subprocess.run([sys.executable, str(AS_A_USER), str(tmp_path)], check=False,
                          cwd=tmp_path, env=_env(), capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, \
        f"{AS_A_USER.name} failed:\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"


@pytest.mark.parametrize("script", [p for p in EXAMPLES if p != AS_A_USER],
                         ids=lambda p: p.name)
def test_example_runs(script, tmp_path, monkeypatch):
    """Each example as ``__main__`` in this process, with the subprocess's arguments, working
    directory and environment (its own asserts check its numbers); BLAS limited to one
    thread as ``OMP_NUM_THREADS=1`` does there; figures closed after."""
    import matplotlib
    import matplotlib.pyplot as plt
    from threadpoolctl import threadpool_limits

    matplotlib.use("Agg")
    for k, v in _env().items():
        monkeypatch.setenv(k, v)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "argv", [str(script), str(tmp_path)])
    monkeypatch.syspath_prepend(str(script.parent))      # as sys.path[0] of `python script`
    try:
        with threadpool_limits(1):
            runpy.run_path(str(script), run_name="__main__")
    except SystemExit as exc:                             # sys.exit(0) is a success
        assert exc.code in (None, 0), f"{script.name} exited with {exc.code}"
    finally:
        plt.close("all")


@pytest.mark.parametrize("notebook", NOTEBOOKS, ids=lambda p: p.name)
def test_notebook_runs(notebook, tmp_path, monkeypatch):
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    for k, v in _env().items():
        monkeypatch.setenv(k, v)
    monkeypatch.delenv("MPLBACKEND")          # the kernel's own inline backend, as in Jupyter
    nb = nbformat.read(notebook, as_version=4)
    client = nbclient.NotebookClient(nb, timeout=600, kernel_name="python3",
                                     resources={"metadata": {"path": str(tmp_path)}})
    client.execute()
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])]
    # a story with narrative and figures: each figure shown once (no repeated image)
    images = [o["data"]["image/png"] for o in outputs if "image/png" in o.get("data", {})]
    assert len(set(images)) == len(images)
    if notebook.name[0].isdigit():            # the numbered stories each show figures
        assert images
    assert nb.cells[0].cell_type == "markdown" and nb.cells[0].source.startswith("# ")
    # progress bars in a notebook without ipywidgets: plain text, no "IProgress not found"
    text = "\n".join(o.get("text", "") for o in outputs if o.get("output_type") == "stream")
    assert "IProgress not found" not in text and "TqdmWarning" not in text


def readme_blocks(text: str) -> list[str]:
    """The python blocks of the README that run, in order.

    Rule: every fenced block opened with ```python is executed, in order, in one
    namespace (a fresh interpreter, a temporary folder as working directory, the Agg
    backend), except a block whose first line is a comment starting with
    ``# not executed`` -- an illustrative block that needs the reader's own files.
    """
    blocks = re.findall(r"^```python\n(.*?)^```", text, re.DOTALL | re.MULTILINE)
    return [b for b in blocks if not b.lstrip().startswith(NOT_RUN)]


def test_readme_blocks_recognised():
    text = (ROOT / "README.md").read_text()
    run = readme_blocks(text)
    assert len(run) >= 4 and "sd.identify(frf)" in run[0]
    assert len(re.findall(r"^```python", text, re.MULTILINE)) == len(run) + 1   # one illustrative
    assert readme_blocks("```python\n# not executed: x\nfoo()\n```\n") == []
    assert readme_blocks("```python\nx = 1\n```\n```sh\nls\n```\n") == ["x = 1\n"]


def test_readme_first_session_runs_as_written(tmp_path):
    code = "\n".join(readme_blocks((ROOT / "README.md").read_text()))
    script = tmp_path / "readme_session.py"
    script.write_text(code)
    proc = subprocess.run([sys.executable, str(script)], check=False, cwd=tmp_path, env=_env(),
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, f"README failed:\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    for fig in ("stabilisation.png", "bode.png", "envelope.png"):
        assert (tmp_path / fig).stat().st_size > 10_000
    assert (tmp_path / "hybrid.npz").exists()
    # the numbers the comments announce
    assert "12 modes" in proc.stdout or "12 in band" in proc.stdout
    m = re.search(r"UpdateResult\(links=([-\d.]+), plates=([-\d.]+)", proc.stdout)
    assert m and abs(float(m.group(1)) - 1 / 3) < 0.01 and abs(float(m.group(2)) + 0.2) < 0.01
    # issue 25: the blocks agree with each other -- the state count the prose explains, and
    # the printed RMS reduction is the placement table's first row (same bar, same measure)
    # 78 before weighting="auto" (its weighted fit: five improper parts, not one; README)
    assert re.search(r"^126$", proc.stdout, re.M)
    first = re.search(r"^\| 1 \| (N\d+)-(N\d+) \| ([\d.]+) % \|", proc.stdout, re.M)
    line = re.search(r"^\('(N\d+)', '(N\d+)'\): plate RMS reduced by ([\d.]+)%$", proc.stdout,
                     re.M)
    assert first and line and first.groups() == line.groups(), proc.stdout[-2000:]


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


def test_readme_lists_every_example_and_notebook():
    text = (ROOT / "README.md").read_text()
    named = set(re.findall(r"`(?:\w+/)?([\w.]+\.(?:py|ipynb))`", text))
    files = {p.name for p in (ROOT / "examples").glob("*.py")}
    files |= {p.name for p in (ROOT / "notebooks").glob("*.ipynb")}
    assert files <= named, files - named                 # each one is introduced
    known = files | {p.name for d in ("sdctrl", "tests", "benchmarks", ".ci")
                     for p in (ROOT / d).rglob("*")}
    assert named <= known, named - known                 # no stale name


def test_readme_opens_with_the_two_commands_ci_runs():
    """.ci/run executes the first ```sh block: line 1 installs and runs the demo, line 2
    installs the test extra and runs the suite."""
    text = (ROOT / "README.md").read_text()
    block = re.search(r"^```sh\n(.*?)^```", text, re.DOTALL | re.MULTILINE).group(1)
    lines = block.splitlines()
    assert len(lines) == 2 and all(x.strip() for x in lines)
    assert "pip install ." in lines[0] and lines[0].rstrip().endswith("sdctrl demo")
    assert '".[test]"' in lines[1] and "pytest" in lines[1]
    assert text.index("```sh") < text.index("```python")
