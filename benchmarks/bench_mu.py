"""Benchmark: our D-G mixed-mu upper bound (``sdctrl.robust.mu.dg_upper``: BFGS on the certified
eigenvalue) against SLICOT's ``ab13md`` (Fan-Tits-Doyle), timed in the same run, on the
structures AB13MD accepts: 1x1 real blocks, complex scalars, full complex blocks.

Run:  python benchmarks/bench_mu.py [--cases N] [--sizes 4 8 16]

For each size and structure family, random complex matrices; the script prints both bounds,
their ratio and the mean time per frequency (one matrix), then the time ratio ours/AB13MD.
Acceptance: bounds within 1%, time per frequency within 10x.  BLAS is limited to one thread
for both.  ``slycot`` is in the test extra (``pip install ".[test]"``), not a runtime
dependency.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from sdctrl.robust.mu import BlockStructure, dg_upper


def structures(n):
    """(name, sizes, AB13MD types, sdctrl kinds) for a matrix of size ``n``."""
    half = n // 2
    out = [("real", [1] * n, [1] * n, ["real"] * n),
           ("real+complex", [1] * n, [1] * half + [2] * (n - half),
            ["real"] * half + ["complex"] * (n - half))]
    if n >= 4:
        sizes = [1] * (n - 2) + [2]
        out.append(("real+full2", sizes, [1] * (n - 2) + [2], ["real"] * (n - 2) + ["full"]))
    return out


def main(argv=None) -> None:
    from threadpoolctl import threadpool_limits
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=6)
    ap.add_argument("--sizes", type=int, nargs="+", default=[4, 8, 16])
    args = ap.parse_args(argv)
    try:
        import slycot
    except ImportError:
        print("slycot is not installed: pip install '.[test]' (AB13MD reference)")
        return
    rng = np.random.default_rng(0)
    dg_upper(np.eye(2, dtype=complex), BlockStructure((1, 1), ("real", "real")))
    print(f"{'n':>3} {'structure':>13} {'max |ours/ab-1|':>16} {'t_ab [ms]':>10} "
          f"{'t_ours [ms]':>11} {'ours/ab time':>12}")
    all_ratios, all_t = [], []
    with threadpool_limits(1):
        for n in args.sizes:
            for name, sizes, types, kinds in structures(n):
                st = BlockStructure(tuple(sizes), tuple(kinds))
                t_ab, t_us, dev = [], [], []
                for _ in range(args.cases):
                    M = rng.normal(size=(n, n)) + 1j * rng.normal(size=(n, n))
                    t0 = time.perf_counter()
                    ab = slycot.ab13md(M, np.array(sizes), np.array(types))[0]
                    t1 = time.perf_counter()
                    ours = dg_upper(M, st)[0]
                    t2 = time.perf_counter()
                    t_ab.append(t1 - t0)
                    t_us.append(t2 - t1)
                    dev.append(abs(ours / ab - 1))
                ratio = np.mean(t_us) / np.mean(t_ab)
                all_ratios.append(max(dev))
                all_t.append(ratio)
                print(f"{n:>3} {name:>13} {max(dev):16.2e} {1e3 * np.mean(t_ab):10.2f} "
                      f"{1e3 * np.mean(t_us):11.2f} {ratio:11.1f}x")
    print(f"bounds: largest relative difference to AB13MD {max(all_ratios):.1e} (1% required)")
    print(f"time per frequency ours/AB13MD: worst {max(all_t):.1f}x, best {min(all_t):.2f}x "
          "(10x required)")


if __name__ == "__main__":
    main()
