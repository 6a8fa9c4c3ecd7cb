"""Benchmark: vectorised sparse assembly and shift-invert eigensolution of a ~1e5-DOF
FE model (first 20 modes): ``FEModel(M, K)`` (validation, positive-definiteness check of
M) plus ``modes`` against a plain ``scipy.sparse.linalg.eigsh(K, M=M, sigma=...)`` of the
same matrices, alternated in one process (issue 14: ratio <= 1.5).

Run:  OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/bench_fe.py [--levels N]

The model is a 3-D lattice tower of aluminium tube beams (8 x 8 nodes per level, 6 DOFs
per node), clamped at its base.  Not part of the unit tests.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np
import scipy.sparse.linalg as spla

from sdctrl.fe import FEModel, assemble

MAT = {"al": {"E": 70e9, "rho": 2700.0, "nu": 0.33}}
SEC = {"tube": {"A": 1.4e-4, "Iy": 1.1e-8, "Iz": 1.1e-8, "J": 2.2e-8}}


def tower(nxy: int, levels: int, pitch: float = 0.25):
    """Nodes and beam elements of a lattice tower; level 0 is clamped."""
    ii, jj, kk = np.meshgrid(np.arange(nxy), np.arange(nxy), np.arange(levels + 1),
                             indexing="ij")
    ii, jj, kk = ii.ravel(), jj.ravel(), kk.ravel()
    names = [f"N{i}_{j}_{k}" for i, j, k in zip(ii, jj, kk)]
    nodes = dict(zip(names, np.stack([ii, jj, kk], axis=1) * pitch))
    idx = {(i, j, k): n for i, j, k, n in zip(ii, jj, kk, names)}
    els = []
    for (i, j, k), a in idx.items():
        for di, dj, dk in ((1, 0, 0), (0, 1, 0), (0, 0, 1)):
            b = idx.get((i + di, j + dj, k + dk))
            if b is not None:
                els.append(("beam", a, b, "al", "tube"))
    bc = [n for (i, j, k), n in idx.items() if k == 0]
    return nodes, els, bc


def _plain_eigsh(K, M, sigma, n_modes):
    """The reference: scipy's own shift-invert ``eigsh`` (its default LU), nothing else."""
    lam, _ = spla.eigsh(K.tocsc(), k=n_modes, M=M.tocsc(), sigma=sigma, which="LM")
    return np.sort(np.sqrt(np.abs(lam)) / (2 * np.pi))


def main(levels: int = 261, n_modes: int = 20, runs: int = 3) -> None:
    print(f"load average at start: {os.getloadavg()}")
    t0 = time.perf_counter()
    nodes, els, bc = tower(8, levels)
    t1 = time.perf_counter()
    fe = assemble(nodes, els, MAT, SEC, bc=bc)
    t2 = time.perf_counter()
    M, K = fe.M, fe.K
    sigma = -1e-6 * float(np.median(K.diagonal() / M.diagonal()))   # FEModel's default
    print(f"large model: {fe.N} DOFs, {len(els)} beams, nnz(K) = {K.nnz}")
    print(f"  element list built in Python : {t1 - t0:8.2f} s")
    print(f"  vectorised sparse assembly   : {t2 - t1:8.2f} s (includes FEModel validation)")
    t_ref, t_new, t_con = [], [], []
    for _ in range(runs):                       # alternate: the machine's load drifts
        t3, c3 = time.perf_counter(), time.process_time()
        f_ref = _plain_eigsh(K, M, sigma, n_modes)
        t4, c4 = time.perf_counter(), time.process_time()
        model = FEModel(M, K)
        t5, c5 = time.perf_counter(), time.process_time()
        f, _phi = model.modes(n_modes, method="sparse")
        t6, c6 = time.perf_counter(), time.process_time()
        t_ref.append((t4 - t3, c4 - c3))
        t_new.append((t6 - t4, c6 - c4))
        t_con.append((t5 - t4, c5 - c4))
    ref, new, con = (np.median(np.array(x), axis=0) for x in (t_ref, t_new, t_con))
    print(f"  {n_modes} modes, median of {runs} alternated runs (wall / CPU seconds):")
    print(f"    scipy eigsh(K, M=M, sigma) alone          : {ref[0]:8.2f} / {ref[1]:8.2f}")
    print(f"    FEModel(M, K) + .modes({n_modes}, 'sparse')     : {new[0]:8.2f} / {new[1]:8.2f} "
          f"(construction, M > 0 check included: {con[0]:.2f} / {con[1]:.2f})")
    print(f"    ratio sdctrl / eigsh                      : {new[0] / ref[0]:8.2f} / "
          f"{new[1] / ref[1]:8.2f}")
    print(f"    max freq. difference                      : "
          f"{np.max(np.abs(f / f_ref - 1)):.1e}")
    print(f"  first frequencies (Hz)       : {np.round(f[:4], 3)}")
    print(f"load average at end: {os.getloadavg()}")

    nodes, els, bc = tower(4, 20)
    small = assemble(nodes, els, MAT, SEC, bc=bc, sparse=False)
    t4 = time.perf_counter()
    fs, _ = small.modes(n_modes, method="dense")
    t5 = time.perf_counter()
    fsp, _ = small.modes(n_modes, method="sparse")
    t6 = time.perf_counter()
    print(f"small model: {small.N} DOFs (dense)")
    print(f"  dense eigh, {n_modes} modes        : {t5 - t4:8.3f} s")
    print(f"  sparse eigsh on the same model : {t6 - t5:8.3f} s "
          f"(max freq. difference {np.abs(fsp / fs - 1).max():.1e})")

    import sdctrl as sd
    from sdctrl import testbeds as tb

    t7 = time.perf_counter()
    fe_tb = sd.testbed()
    t8 = time.perf_counter()
    sd.testbed_frf(n=1000)
    t9 = time.perf_counter()
    sd.testbed_frf(n=1000, noise=0.01, seed=0)
    t10 = time.perf_counter()
    print(f"testbed: {fe_tb.N} DOFs built in {t8 - t7:.3f} s; testbed_frf 1000 lines x "
          f"{len(tb.SENSORS)} x {len(tb.SHAKERS)}: first call {t9 - t8:.3f} s (modes and "
          f"static modes, cached), next {t10 - t9:.3f} s")


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--levels", type=int, default=261, help="tower levels (261 -> ~1e5 DOFs)")
    ap.add_argument("--modes", type=int, default=20, help="number of modes")
    ap.add_argument("--runs", type=int, default=3, help="alternated runs (median)")
    args = ap.parse_args()
    main(args.levels, args.modes, args.runs)
