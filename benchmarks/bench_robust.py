"""Benchmark: robust stability at the size of a real model (issue 13 acceptance timing).

The built-in testbed identified from its simulated test (identify -> normal_modes, 12 in-band
modes), the whole damping matrix uncertain at 30% of |Gamma| (78 parameters, 144 Delta
channels), a collocated rate feedback on the 6 shakers; then the README's line
``nm.uncertain(dGamma=0.2 * abs(nm.Gamma))`` on the 6 modes below 20 Hz (21 parameters).

Run:  python benchmarks/bench_robust.py [--executor]

Prints the time of ``robust_stability`` (identification excluded), the bracket
``margin <= margin_lower``, the frequencies used, and as references measured in the same run:
the time of one nominal closed-loop eigenvalue problem x 1000 (a machine-speed yardstick) and
the 60 s target.  ``--executor`` also runs the sweep on a 2-process pool (same numbers).
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tests"))


def main(argv=None) -> None:
    import control
    from test_robust_testbed import rate_feedback

    import sdctrl as sd

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--executor", action="store_true")
    args = ap.parse_args(argv)
    cases = []
    for band, frac in ((None, 0.3), ((8, 20), 0.2)):
        frf = sd.testbed_frf() if band is None else sd.testbed_frf().band(*band)
        cm = sd.identify(frf, progress=False)
        nm = sd.normal_modes(cm, modes=cm.in_band).replace(F=None)
        cases.append((f"{nm.n} modes, dGamma={frac}|Gamma|",
                      nm.uncertain(dGamma=frac * abs(nm.Gamma)),
                      rate_feedback(nm)))
    for name, um, K in cases:
        cl = control.feedback(um.nominal, K)
        t0 = time.perf_counter()
        for _ in range(1000):
            np.linalg.eigvals(cl.A)
        t_ref = time.perf_counter() - t0
        t0 = time.perf_counter()
        r = sd.robust_stability(um, K, progress=False)
        t = time.perf_counter() - t0
        nb, nch = len(um.blocks), sum(b for _, b in um.blocks)
        print(f"{name}: {nb} parameters, {nch} channels")
        print(f"  robust_stability {t:.2f} s = {t / t_ref:.0f} x (1000 eigenvalue problems, "
              f"{t_ref:.2f} s) = {t / 60:.3f} x the 60 s target")
        print(f"  margin {r.margin:.4f} <= margin_lower {r.margin_lower:.4f} "
              f"(gap {100 * (r.margin_lower / r.margin - 1):.2f}%), critical {r.frequency:.2f} Hz,"
              f" {r.info['n_freq']} frequencies ({r.info['n_dg']} D-G), certified "
              f"{r.certified}")
        if args.executor:
            from concurrent.futures import ProcessPoolExecutor
            with ProcessPoolExecutor(2) as ex:
                t0 = time.perf_counter()
                rp = sd.robust_stability(um, K, progress=False, executor=ex)
                tp = time.perf_counter() - t0
            same = rp.margin == r.margin and np.array_equal(rp.mu, r.mu)
            print(f"  2 processes: {tp:.2f} s ({tp / t:.2f} x serial), identical: {same}")


if __name__ == "__main__":
    main()
