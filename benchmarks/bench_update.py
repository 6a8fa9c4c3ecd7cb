"""Benchmark: FE model update (thesis 4.4) on the testbed and on a ~1e5-DOF sparse model.

Run:  OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/bench_update.py [--levels N]

1. testbed: the wrong model ``sd.testbed(link_stiffness=0.5, plate_mass=1.25)`` updated
   against ``sd.testbed_frf`` (31 sensors x 6 shakers x 600 lines), two parameters, damping
   from ``fe.C``; target under 5 s on 2 cores.  Reference measured in the same run:
   ``sd.identify`` on the same data (the update identifies the test's modes once).
2. sparse: the lattice tower of ``bench_fe.py`` (8 x 8 nodes per level, 261 levels:
   ~1e5 DOFs) with three parameters (the verticals of the lower quarter, the horizontals of
   the upper half, a top mass; their identifiability is printed first); the "test"
   is the reduced model of the true structure (24 sensors x 3 shakers, 2% modal damping,
   lines finer than the first mode's half-power bandwidth).  Reference: one shift-invert
   eigensolution of the nominal model.

Not part of the unit tests.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
import warnings

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))

import sdctrl as sd
from sdctrl.fe import assemble
from sdctrl.updating import apply_parameters

ZETA = 0.02                     # modal damping of the sparse case's simulated test
PLATES = [f"N{k}" for k in (31, 32, 33, 34, 35, 38, 39, 40, 41, 42, 45, 46, 47, 48, 49)]


def testbed_case() -> None:
    frf = sd.testbed_frf(n=600)
    fe = sd.testbed(link_stiffness=0.5, plate_mass=1.25)
    pars = [fe.stiffness_parameter("links", section=["post_AB", "post_C"]),
            fe.mass_parameter("plates", PLATES)]
    sd.update(fe, sd.testbed_frf(n=60), pars, progress=False)       # imports, caches
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sd.identify(frf.band(8, 60), progress=False)
    t_id = time.perf_counter() - t0
    t0 = time.perf_counter()
    res = sd.update(fe, frf, pars, progress=False)
    t_up = time.perf_counter() - t0
    err = [(1 + res.values["links"]) * 0.5 - 1, (1 + res.values["plates"]) * 1.25 - 1]
    print(f"testbed update (2 parameters, 31 x 6 x 600 lines): {t_up:.2f} s "
          f"(identify alone on the same data: {t_id:.2f} s, ratio {t_up / t_id:.2f})")
    print(f"  logLS {res.cost_before:.3g} -> {res.cost_after:.3g}; recovered link stiffness "
          f"and plate mass errors {err[0]:+.2%}, {err[1]:+.2%}; basis {res.info['basis']}")
    for s in res.stages:
        print(f"  {s['stage']:<36s} cost {s['cost']:.3g}  evaluations {s['nfev']}")


def tower(nxy: int, levels: int, pitch: float = 0.25):
    """Lattice tower of bench_fe with named sections: the verticals of the lower quarter
    ("low"), the horizontals of the upper half ("upper"); also the top nodes."""
    from bench_fe import tower as base

    nodes, els, bc = base(nxy, levels, pitch)
    out = []
    for kind, a, b, mat, sec in els:
        ka, kb = int(a.rsplit("_", 1)[1]), int(b.rsplit("_", 1)[1])
        if kb == ka + 1 and ka < levels // 4:
            sec = "low"
        elif kb == ka and ka > levels // 2:
            sec = "upper"
        out.append((kind, a, b, mat, sec))
    top = [n for n in nodes if int(n.rsplit("_", 1)[1]) == levels]
    return nodes, out, bc, top


def sparse_case(levels: int) -> None:
    from bench_fe import MAT, SEC

    nodes, els, bc, top = tower(8, levels)
    secs = {**SEC, "low": SEC["tube"], "upper": SEC["tube"]}
    t0 = time.perf_counter()
    fe = assemble(nodes, els, MAT, secs, bc=bc)
    t_asm = time.perf_counter() - t0
    pars = [fe.stiffness_parameter("low verticals", section="low"),
            fe.stiffness_parameter("upper horizontals", section="upper"),
            fe.mass_parameter("top mass", top, mass=200.0)]
    p_true = np.array([-0.4, 0.5, 0.3])
    t0 = time.perf_counter()
    f_nom, _ = fe.modes(20)
    t_eig = time.perf_counter() - t0
    true = apply_parameters(fe, pars, p_true)
    rng = np.random.default_rng(0)
    names = list(nodes)
    pick = [names[i] for i in rng.choice(len(names), 24, replace=False)]
    sensors = [f"{n}.{'xy'[k % 2]}" for k, n in enumerate(pick) if f"{n}.x" in fe.dofs][:24]
    shakers = [f"{top[0]}.x", f"{top[9]}.y", f"{names[len(names) // 3]}.x"]
    shakers = [s for s in shakers if s in fe.dofs]
    nm = true.normal_mode_model(shakers, sensors, 20, damping=ZETA, static=True)
    band = (0.5 * f_nom[0], 0.9 * nm.frequency[9])
    # lines finer than the half-power bandwidth 2 zeta f of the first mode
    n_lines = int(np.clip(2 * (band[1] - band[0]) / (2 * ZETA * nm.frequency[0]), 300, 2000))
    frf = nm.frf(np.linspace(*band, n_lines))
    ident = sd.identifiability(fe, frf, pars, damping=ZETA, noise=1e-4)
    t0 = time.perf_counter()
    res = sd.update(fe, frf, pars, damping=ZETA, progress=False)
    t_up = time.perf_counter() - t0
    got = np.array([res.values[p.name] for p in pars])
    print(f"sparse model: {fe.N} DOFs (assembly {t_asm:.1f} s), {len(sensors)} x {len(shakers)} "
          f"x {n_lines} lines, band {band[0]:.2f}-{band[1]:.2f} Hz, 3 parameters")
    print(f"  update {t_up:.1f} s = {t_up / t_eig:.1f} x one eigensolution of 20 modes "
          f"({t_eig:.1f} s); logLS {res.cost_before:.3g} -> {res.cost_after:.3g}")
    print("  identifiability: logLS change for +100%: " + ", ".join(
        f"{k} {v:.3g}" for k, v in ident.sensitivity.items())
        + f"; max |correlation| {np.abs(ident.correlation - np.eye(3)).max():.2f}")
    print(f"  recovered {np.round(got, 4).tolist()} for {p_true.tolist()} "
          f"(max error {np.abs(got - p_true).max():.1e}); basis {res.info['basis']}")


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--levels", type=int, default=261, help="tower levels (261 -> ~1e5 DOFs)")
    ap.add_argument("--skip-sparse", action="store_true", help="testbed only")
    args = ap.parse_args()
    testbed_case()
    if not args.skip_sparse:
        sparse_case(args.levels)
