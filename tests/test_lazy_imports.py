"""``import sdctrl`` is lazy, and identification pays only for what it needs (issue 27: a
user's fresh-process call).  Each check runs in a new interpreter and reads ``sys.modules``.
The identification path imports no scipy at all (its pole search, triangular solves and
chi-square quantiles are numpy: ``sdctrl._lib.trustregion``, ``triangular``, ``chisquare``):
scipy.optimize, scipy.special and scipy.linalg were about 0.2 s of a fresh ``identify``.
"""

import json
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

#: heavy packages the identification path must not import
HEAVY = ("cvxpy", "matplotlib", "control", "scipy.stats", "scipy.signal", "pyuff", "tqdm",
         "distributed", "dask", "scipy.optimize", "scipy.special", "scipy.linalg")


def _loaded(code: str) -> dict:
    """``{module: loaded}`` for :data:`HEAVY` (and ``sdctrl``'s file) after ``code`` runs in
    a fresh interpreter."""
    probe = (code + "\nimport json, sys\nprint(json.dumps({'file': sdctrl.__file__, 'mods': "
             f"{{m: m in sys.modules for m in {HEAVY!r}}}}}))")
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                         env=env, cwd=ROOT, check=True).stdout
    res = json.loads(out.strip().splitlines()[-1])
    assert os.path.dirname(os.path.dirname(res["file"])) == ROOT      # this copy of sdctrl
    return res["mods"]


def test_import_sdctrl_imports_no_heavy_package():
    mods = _loaded("import sdctrl")
    assert not any(mods.values()), [m for m, v in mods.items() if v]


def test_identification_in_a_fresh_process_imports_only_what_it_needs():
    code = """
import numpy as np
import sdctrl
f = np.linspace(5.0, 40.0, 400)
w, s = 2 * np.pi * f, 1j * 2 * np.pi * f
poles = [-0.5 + 2j * np.pi * 12.0, -0.8 + 2j * np.pi * 25.0]
R = [np.array([[1.0], [0.6]]), np.array([[0.4], [-0.9]])]
H = sum(r[None] / (s - p)[:, None, None] + r[None].conj() / (s - np.conj(p))[:, None, None]
        for r, p in zip(R, poles))
frf = sdctrl.FRF(f, H, sensors=["a", "b"], actuators=["u"])
cm = sdctrl.identify(frf, progress=False)
found = np.sort(cm.frequency[cm.in_band])
assert found.size == 2 and np.allclose(found, [12.0, 25.0], rtol=1e-3), found
"""
    mods = _loaded(code)
    assert not any(mods.values()), [m for m, v in mods.items() if v]
