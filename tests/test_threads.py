"""The BLAS thread scope without threadpoolctl: the package still imports and runs."""

import subprocess
import sys
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_identify_runs_when_threadpoolctl_is_missing():
    code = textwrap.dedent("""
        import sys
        sys.modules["threadpoolctl"] = None          # import fails as if not installed
        import numpy as np
        import sdctrl as sd
        names = [n for n in sd.__all__ if n != "diagnose"] + ["diagnose"]
        [getattr(sd, n) for n in names]              # every public name resolves
        from sdctrl._lib.threads import single_thread
        with single_thread():
            pass
        f = np.linspace(5, 15, 400)
        s = 2j * np.pi * f
        lam = -0.02 * 2 * np.pi * 10 + 2j * np.pi * 10
        H = (1 / (s - lam) + 1 / (s - np.conj(lam)))[:, None, None]
        cm = sd.identify(sd.FRF(f, H, sensors=["a.x"], actuators=["a.x"]), progress=False)
        print(float(abs(cm.poles[0]) / abs(lam) - 1))
    """)
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, check=False,
                         text=True, env={"PYTHONPATH": str(ROOT), "PATH": ""}, timeout=300)
    assert out.returncode == 0, out.stderr
    assert abs(float(out.stdout.strip().splitlines()[-1])) < 1e-8
