"""Benchmark: one diagnosis (sd.diagnose) of the testbed, single thread.

Run:  OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/bench_diagnose.py [--lines N]

The model is the FE-derived normal-mode model of the nominal testbed (28 modes + static
correction modes, the model sd.testbed_frf simulates with); the data (31 sensors x 6 shakers x
600 lines, accelerance, noise-free and 1% noise) are the same reduction of the testbed with a
0.5 kg mass added at node N20 (its static correction kept).  Target (issue 12): under 10 s
on one core.  Reference measured in the same run: ``sd.identify`` on the same data, and one
evaluation of the model's FRF on the lines (what a naive scan pays per candidate and size).

Not part of the unit tests.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
import warnings

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path[:0] = [os.path.join(HERE, ".."), os.path.join(HERE, "..", "tests")]

from threadpoolctl import threadpool_limits

import sdctrl as sd


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--lines", type=int, default=600)
    args = ap.parse_args()
    import test_diagnose as T  # the acceptance's data builders

    T.FREQ = np.linspace(8.0, 60.0, args.lines)
    case = T.CASES["mass"]
    model, fe = T.nominal(), T.FE
    clean = T.clean_data(case)
    noisy = T.noisy(clean, 0.01)
    n_cand = None
    with threadpool_limits(1):
        sd.diagnose(model, T.noisy(clean, 0.01, seed=9).band(8, 20), fe, max_effects=1,
                    progress=False)                        # imports, caches
        t0 = time.perf_counter()
        for _ in range(5):
            model.frf(clean.freq, "acceleration")
        t_frf = (time.perf_counter() - t0) / 5
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            sd.identify(noisy, progress=False)
        t_id = time.perf_counter() - t0
        for name, data in (("noise-free", clean), ("1% noise", noisy)):
            t0 = time.perf_counter()
            d = sd.diagnose(model, data, fe, progress=False)
            t = time.perf_counter() - t0
            n_cand = d.info["candidates"]
            e = d.effects[0]
            print(f"{name}: {t:.2f} s for {len(d.steps)} steps "
                  f"({', '.join(f'{s:.2f}' for s in d.info['step_times'])} s); "
                  f"{t / t_id:.2f} x identify ({t_id:.2f} s), "
                  f"{t / t_frf:.0f} x one model FRF ({1e3 * t_frf:.1f} ms)")
            print(f"  top effect {e.kind} at {e.location}: dm = {e.parameters['dm']:.5g} kg "
                  f"(true 0.5, {e.parameters['dm'] / 0.5 - 1:+.2%}); error "
                  f"{d.error_before:.3g} -> {d.error_after:.3g} "
                  f"(ratio {d.error_after / d.error_before:.2g})")
    shape = clean.H.shape
    print(f"data {shape[1]} x {shape[2]} x {shape[0]} lines; candidates per step: {n_cand} "
          f"(+ global ones); load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")


if __name__ == "__main__":
    main()
