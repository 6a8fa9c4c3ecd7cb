"""Benchmark of ``sd.normal_modes(cm, passive=True)`` (the passive refit at the collocated
pairs, issue 22) against the default ``passive=False`` (the check alone), in one process.

Plain script::

    python benchmarks/bench_passive.py [--runs 3] [--members truss,truss_high,...]

For each family member, noise-free and at 1% noise (seed 1), the identified model is built
once; then ``normal_modes(cm, std=False)`` (the reference) and ``normal_modes(cm,
std=False, passive=True)`` are alternated ``--runs`` times (the machine's load drifts) and
the medians of their CPU times and the ratio are printed, with the refit's status and its
number of constraint frequencies.  One case is also timed in a fresh process (import and
first call: cvxpy's import and the solver's first compilation are paid there), beside the
warm figure.

Measured (``--runs 1``, one core, idle machine), passive refit against the default's check
alone, CPU seconds: 1% noise -- truss 2.1 (refit refused) against 0.07, ``truss_high`` 3.3
against 0.04 (6 pairs), ladder 0.42, plate 0.56, cluster 0.98 against 0.01-0.03;
noise-free -- truss 35 and ``truss_high`` 84 (14-20 residual terms, 95-99 constraint
frequencies), ladder 4.8, plate 2.5, cluster 0.6.  Fresh process, truss 1%: 2.5 s wall.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
import warnings

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

import sdctrl as sd

warnings.simplefilter("ignore")

MEMBERS = ("truss", "truss_high", "ladder", "plate", "cluster")


def _cpu(f):
    t0 = time.process_time()
    out = f()
    return time.process_time() - t0, out


def warm(name: str, noise: float, runs: int) -> str:
    frf = sd.testbeds.structure(name).frf(n=400, noise=noise, seed=1)
    cm = sd.identify(frf, progress=False)
    ref, new, rec = [], [], None
    for _ in range(runs):
        t, _ = _cpu(lambda: sd.normal_modes(cm, std=False))
        ref.append(t)
        t, nm = _cpu(lambda: sd.normal_modes(cm, std=False, passive=True))
        new.append(t)
        rec = nm.properness.passivity
    a, b = float(np.median(ref)), float(np.median(new))
    nfreq = 0 if rec.frequencies is None else rec.frequencies.size
    return (f"{name:10s} {noise:4.2f}  default {a:7.3f} s  passive {b:7.3f} s  "
            f"ratio {b / max(a, 1e-9):7.1f}  {rec.status[:40]:40s} {nfreq:3d} frequencies")


FRESH = """
import time, warnings
warnings.simplefilter("ignore")
t0 = time.perf_counter()
import sdctrl as sd
frf = sd.testbeds.structure({name!r}).frf(n=400, noise={noise}, seed=1)
cm = sd.identify(frf, progress=False)
t1 = time.perf_counter()
nm = sd.normal_modes(cm, std=False, passive=True)
print(f"{{time.perf_counter() - t1:.3f}}")
"""


def fresh(name: str, noise: float) -> float:
    code = FRESH.format(name=name, noise=noise)
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True,
                         text=True, cwd=ROOT).stdout
    return float(out.strip().splitlines()[-1])


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--members", default=",".join(MEMBERS))
    args = parser.parse_args(argv)
    for name in args.members.split(","):
        for noise in (0.0, 0.01):
            print(warm(name, noise, args.runs), flush=True)
    name = args.members.split(",")[0]
    print(f"fresh process, {name} 1%: passive refit {fresh(name, 0.01):.3f} s wall "
          "(first call: cvxpy imported and compiled there)")


if __name__ == "__main__":
    main()
