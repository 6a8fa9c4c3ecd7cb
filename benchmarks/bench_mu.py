"""Benchmark: our D-G scaled mixed-mu upper bound (cvxpy/Clarabel, re-certified) against
SLICOT's ``ab13md`` on the structures AB13MD can express, timed in the same run.

Run:  OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/bench_mu.py [--cases N]

Cases: random full-rank complex matrices with independent 1x1 real blocks (AB13MD's real
scalars, the structure of sdctrl's parametric uncertainty).  The first case includes cvxpy's
start-up.  For each case the script prints both bounds, their
ratio and the times; at the end, the ratio of the mean times.  ``slycot`` is in the test
extra (``pip install ".[test]"``); it is not a runtime dependency.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from sdctrl.robust import mu_upper


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=6)
    ap.add_argument("--size", type=int, default=4)
    args = ap.parse_args(argv)
    try:
        import slycot
    except ImportError:
        print("slycot is not installed: pip install '.[test]' (AB13MD reference)")
        return
    rng = np.random.default_rng(0)
    r = args.size
    t_ours, t_ab, ratios = [], [], []
    print(f"{'case':>4} {'blocks':>8} {'ab13md':>10} {'ours':>10} {'ours/ab':>8} "
          f"{'t_ab [ms]':>10} {'t_ours [ms]':>11}")
    for i in range(args.cases):
        M = rng.normal(size=(r, r)) + 1j * rng.normal(size=(r, r))
        ones = np.ones(r, dtype=int)
        t0 = time.perf_counter()
        ab = slycot.ab13md(M, ones, ones)[0]          # itype 1: real scalar blocks
        t1 = time.perf_counter()
        ours = mu_upper(M, list(ones), eps=0.0, rtol=1e-4)[0]
        t2 = time.perf_counter()
        t_ab.append(t1 - t0)
        t_ours.append(t2 - t1)
        ratios.append(ours / ab if ab > 0 else np.nan)
        print(f"{i:>4} {'real':>8} {ab:10.5f} {ours:10.5f} {ratios[-1]:8.4f} "
              f"{1e3 * t_ab[-1]:10.2f} {1e3 * t_ours[-1]:11.1f}")
    ok = np.array([x for x in ratios if np.isfinite(x)])
    print(f"bound ratio ours/AB13MD: min {ok.min():.4f}, max {ok.max():.4f} "
          "(<= 1.001 required: ours is never above AB13MD by more than 0.1%)")
    print(f"time ratio ours/AB13MD (mean): {np.mean(t_ours) / np.mean(t_ab):.0f}x "
          f"({1e3 * np.mean(t_ours):.1f} ms vs {1e3 * np.mean(t_ab):.2f} ms)")


if __name__ == "__main__":
    main()
