"""Benchmark of ``sd.diagnose`` and of ``sdctrl demo`` (issues 23 and 27), on one core.

Run::

    python benchmarks/bench_diagnose.py [--parts truss,lattice,demo] [--dofs 10000]

``truss``    the testbed's FE-derived normal-mode model (28 modes + static correction
             modes) against a second test with a 0.5 kg mass added at N20 (31 sensors x 6
             shakers x 600 lines, 8-60 Hz, noise-free and 1% noise; 389 node pairs, 49
             nodes, 147 DOFs scanned).  Timed in a fresh process (``import sdctrl`` and the
             first call, what a user's call costs) and warm (after a first call).  Target
             (issue 23): under 10 s on one core.
``lattice``  the scan at 10^4 DOFs: the scalable lattice plate's reduced model (modes below
             3 x the band top + static correction modes of the shakers) against its test with
             a 30% stiffness loss of one bar (24 x 3 x 600 lines); every element (16,474 bars)
             and every node (3,364) scanned.  Target (issue 27): under 120 s.
``demo``     ``sdctrl demo`` in a subprocess (wall and CPU seconds, and each step's own time as
             its terminal line gives it: the diagnosis step's 31 x 6 x 1000 lines among
             them).  Target: under 30 s.

Figures (branch dspeed, 2026-11-26, on this 2-core machine shared with four other
developers: load average 9-13 during every run, so that CPU seconds are inflated too; before =
main at babe7f9, after = dspeed, run back to back in separate processes under the same load):

==============================================  ===============  ===============
case                                            before (CPU s)   after (CPU s)
==============================================  ===============  ===============
truss 31x6x600 warm, noise-free (2 steps)       14.2 / 14.8      10.8 / 15.0
truss 31x6x600 warm, 1% noise (2 steps)         13.2 / 13.5      12.3 / 13.2
demo diagnosis step, 31x6x1000 (3 steps) [#]_   42.9 (load 9.7)  35.4 (load 9.1)
==============================================  ===============  ===============

.. [#] measured with a part that called the demo's private step functions; the benchmark uses
   public names only (tests/test_public_names.py): the demo part's step lines give it now.

The truss case is unchanged within the load's scatter (no refit there: one effect); the
demo's diagnosis gains from the complex-mode evaluation of its coupled models (each an
``n x n`` solve per line before) in the joint refit and the effects' finite differences.
The rest of the time is the screen's single-precision kernel (about half, near numpy's
speed for its passes: ``log`` alone is 3 ns per entry) and the finalists' fits.

Branch perf3 (2026-11-26, load 8-9 on 2 cores, before = main at 5cfee17 and after run
alternately, two runs each, CPU s): the finalists' size fits evaluate the cost of the ratio
``H / H_d`` they form directly (``_residual_map.ratio_cost``: no division by ones, no complex
residual array; 5.14 -> 4.61 s on the truss' own 26 fit tasks, same process); every effect,
size, error and step candidate is the same bit for bit (noise-free and 1%):

==============================================  ===============  ===============
case                                            before (CPU s)   after (CPU s)
==============================================  ===============  ===============
truss 31x6x600 fresh process, 1% noise          14.4 / 14.1      15.4 / 14.3
truss 31x6x600 warm, noise-free (2 steps)       15.9 / 16.8      15.6 / 15.9
truss 31x6x600 warm, 1% noise (2 steps)         15.3 / 14.4      14.3 / 13.4
demo (whole, CPU) / its diagnosis step (wall)   71.0 / 80.7      71.0 / 58.5
==============================================  ===============  ===============

(the demo's step times are wall seconds, load 8.4 before and 9.9 after: its CPU total is the
figure to read.)  Issue 23's "under 10 s on one core" is not met: under this load the gain
(4-7% on the warm truss) is within the scatter.  Where the time goes (cProfile on CPU time, truss
1%, 18 s under load): the single-precision screen 45-50% (its float32 passes measure 10-12 ns an
entry under load, 5 ns unloaded, ``log`` the largest; a float32-view variant of the kernel and
L2-sized blocks measured 6.12 vs 6.30 s on the screen's own 70 tasks, and exact pruning of the sizes
that cannot be a candidate's best -- partial costs as lower bounds, same minimum and column bit
for bit -- 6.97 vs 6.76 s: both dropped), the finalists' fits 20-25% (float64 ``arctan2``
and ``log`` of 111,600 entries an evaluation, ~16 evaluations of the bounded Brent search
per finalist, 26 finalists a step), the global effects (``_global_effects``: free mode,
non-proportional damping) 15-20%, transfers and set-up the rest.

Branch dspeed, 2026-11-27 (load 4.6-5.7 on 2 cores, CPU s; before = main at 32823c4 the same
morning at load 6): the scan after the last effect is not run when no effect could pass the
test's share rule any more (``_loop._exhausted``: an effect cannot remove the measurement
noise, so when the error left less 0.9 x a low estimate of the noise -- robust to lines
correlated by a window, three standard deviations below its estimate,
``_residual_map.noise_floor`` -- is below 0.1% of the initial error the search stops; the
result is the full run's bit for bit, tests/test_diagnose_exhausted.py).
A one-effect diagnosis is one scan instead of two:

==============================================  ===============  ===============
case                                            before (CPU s)   after (CPU s)
==============================================  ===============  ===============
truss 31x6x600 fresh process, 1% noise          14.0             7.5
truss 31x6x600 warm, noise-free (2 steps)       14.2             7.6
truss 31x6x600 warm, 1% noise (2 steps)         14.4             6.9
==============================================  ===============  ===============

Issue 23's "under 10 s on one core" is met on this case.  It is not where the last scan must
run: at 1% noise the bound holds when the initial error exceeds about 130 times the noise
level on 600 lines (0.013 here; the family's one-mass cases on 200 lines, 0.041-0.44: all
skipped), and a diagnosis that accepts several effects scans once more per effect (the
demo's four scans, 6.5-16 s each; its error left, 0.0086, is 85 times its noise).

Every figure is given as CPU seconds (``time.process_time``, BLAS limited to one thread by
threadpoolctl) and wall seconds: on a machine shared with other jobs the wall time follows
the load, the CPU time much less.  Not part of the unit tests.
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
import warnings

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.join(HERE, "..")
sys.path[:0] = [ROOT, os.path.join(ROOT, "tests")]

from threadpoolctl import threadpool_limits  # noqa: E402

ENV = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1",
           MPLBACKEND="Agg", PYTHONPATH=os.pathsep.join(filter(None, [
               ROOT, os.environ.get("PYTHONPATH")])))


def _clock(fn, *args, **kw):
    """``(result, cpu s, wall s)`` of one call."""
    c0, w0 = time.process_time(), time.perf_counter()
    out = fn(*args, **kw)
    return out, time.process_time() - c0, time.perf_counter() - w0


def truss_data(lines: int = 600):
    """(model, fe, noise-free data, 1% noise data) of the truss case."""
    import test_diagnose as T

    T.FREQ = np.linspace(8.0, 60.0, lines)
    clean = T.clean_data(T.CASES["mass"])
    return T.nominal(), T.FE, clean, T.noisy(clean, 0.01)


def _fresh_child() -> None:
    """In a fresh process: import sdctrl, build the data (not timed), one diagnosis."""
    c0, w0 = time.process_time(), time.perf_counter()
    import sdctrl as sd
    t_import = (time.process_time() - c0, time.perf_counter() - w0)
    model, fe, _, noisy = truss_data()
    with threadpool_limits(1):
        d, cpu, wall = _clock(sd.diagnose, model, noisy, fe, progress=False)
    e = d.effects[0]
    print(f"FRESH {t_import[0]:.2f} {t_import[1]:.2f} {cpu:.2f} {wall:.2f} {e.kind} "
          f"{e.location} {e.parameters['dm']:.5f}")


def bench_truss() -> None:
    import sdctrl as sd

    out = subprocess.run([sys.executable, __file__, "--fresh-child"], capture_output=True,
                         text=True, env=ENV, check=True).stdout
    line = next(x for x in out.splitlines() if x.startswith("FRESH"))
    ci, wi, cd, wd, kind, loc, dm = line.split()[1:]
    print(f"truss 31x6x600, fresh process: import sdctrl {ci} s CPU ({wi} s wall), first "
          f"diagnosis {cd} s CPU ({wd} s wall): {kind} at {loc}, dm = {dm} kg (true 0.5)")
    model, fe, clean, noisy = truss_data()
    with threadpool_limits(1):
        sd.diagnose(model, noisy.band(8, 20), fe, max_effects=1, progress=False)   # warm
        for name, data in (("noise-free", clean), ("1% noise", noisy)):
            d, cpu, wall = _clock(sd.diagnose, model, data, fe, progress=False)
            e = d.effects[0]
            print(f"truss 31x6x600 warm, {name}: {cpu:.2f} s CPU ({wall:.2f} s wall), "
                  f"{len(d.steps)} steps; {e.kind} at {e.location}, dm = "
                  f"{e.parameters['dm']:.5f} kg; error {d.error_before:.3g} -> "
                  f"{d.error_after:.3g}; candidates {d.info['candidates']}")


def _bar_stiffness(fe, bar) -> float:
    """``EA/L`` of the bar between the two nodes ``bar``, from the FE model's assembly."""
    A = fe.assembly
    for (_kind, mat, sec, _ori), conn in A.groups:
        for a, b in conn:
            if {A.names[a], A.names[b]} == set(bar):
                EA = float(A.materials[mat]["E"]) * float(A.sections[sec]["A"])
                return EA / float(np.linalg.norm(A.xyz[b] - A.xyz[a]))
    raise ValueError(f"bar {bar} is not an element of the assembly")


def lattice_case(dofs: int):
    """(model, fe, data, bar, dk) of the lattice case (a stiffness loss of one bar)."""
    import scipy.sparse as sp

    import sdctrl as sd

    s = sd.testbeds.lattice(dofs)
    fe = s.fe()
    f, phi = fe.modes(40)
    n = int(np.sum(f < 3 * s.band[1]))
    B = fe.point(list(s.shakers))
    acts = list(s.shakers)
    model = fe.normal_mode_model(B, list(s.sensors), n, static=True,
                                 static_damping="projected", actuators=acts)
    inb = (f > s.band[0]) & (f < s.band[1])
    dofs = set(fe.dofs)
    els = [e for e in list(fe.elements)[::7]          # the most visible of every 7th bar
           if all(f"{n}.{ax}" in dofs for n in e for ax in "xyz")]
    w = 2 * np.pi * f[inb]
    eff = [np.max((fe.strut(a, b).T @ phi[:, inb])[0] ** 2 / (2 * w)) for a, b in els]
    bar = els[int(np.argmax(eff))]
    b = fe.strut(*bar)
    dk = -0.3 * _bar_stiffness(fe, bar)                             # a 30% loss of EA/L
    fe2 = sd.FEModel(fe.M, fe.K + sp.csr_matrix(dk * (b @ b.T)), fe.C, dofs=fe.dofs,
                     nodes=dict(fe.nodes), elements=fe.elements, assembly=fe.assembly)
    freq = np.linspace(*s.band, 600)
    data = fe2.normal_mode_model(np.hstack([B, b]), list(s.sensors), n, static=True,
                                 static_damping="projected", actuators=acts + ["bar"]
                                 ).frf(freq, "acceleration").select(actuators=acts)
    return model, fe, data, bar, dk


def bench_lattice(dofs: int) -> None:
    import sdctrl as sd

    with threadpool_limits(1):
        (model, fe, data, bar, dk), cpu_b, wall_b = _clock(lattice_case, dofs)
        print(f"lattice N = {fe.N}: case built in {cpu_b:.1f} s CPU ({wall_b:.1f} s wall)")
        d, cpu, wall = _clock(sd.diagnose, model, data, fe, reach=1e-9, max_effects=1,
                              progress=False)
    e = d.effects[0] if d.effects else None
    n_loc = sum(d.info["candidates"].values())
    print(f"lattice N = {fe.N}, {data.H.shape[1]}x{data.H.shape[2]}x{data.H.shape[0]}: "
          f"diagnosis over {n_loc} candidate locations {d.info['candidates']}: {cpu:.1f} s "
          f"CPU ({wall:.1f} s wall); planted dk = {dk:.4g} N/m (30% of EA/L) on {bar}, found "
          f"{e and (e.kind, e.location, e.parameters)}")
    top = d.steps[0]["candidates"][:2] if d.steps else []
    print("  error after the two best candidates (exact fits): " + "; ".join(
        f"{c['kind']} at {c['location']}: {c['cost']:.3g}" for c in top)
        + f" (error before {d.error_before:.3g})")


def bench_demo() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        w0 = time.perf_counter()
        proc = subprocess.run([sys.executable, "-m", "sdctrl.cli", "demo", "--out",
                               os.path.join(tmp, "out")], capture_output=True, text=True,
                              env=ENV, check=False)
        wall = time.perf_counter() - w0
        r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    steps = [x for x in proc.stdout.splitlines() if x.startswith("[")]
    print(f"sdctrl demo: {wall:.1f} s wall, {cpu:.1f} s CPU (exit {proc.returncode}); "
          f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    for x in steps:
        print("   ", x[:60], "...", x[x.rfind("("):])


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--parts", default="truss,lattice,demo")
    ap.add_argument("--dofs", type=int, default=10000)
    ap.add_argument("--fresh-child", action="store_true")
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    if args.fresh_child:
        _fresh_child()
        return
    parts = args.parts.split(",")
    if "truss" in parts:
        bench_truss()
    if "lattice" in parts:
        bench_lattice(args.dofs)
    if "demo" in parts:
        bench_demo()
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")


if __name__ == "__main__":
    main()
