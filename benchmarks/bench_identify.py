"""Benchmark of ``sd.identify`` against sdypy-EMA (LSCF + LSFD) and against a previous
version of sdctrl, in one process (issue 14).

Plain script::

    python benchmarks/bench_identify.py [--runs 5] [--before main] [--cases ema,10x1,...]

Cases (``--cases``, default all):

``ema``      EMA's own ground: 28 outputs x 1 input x 2000 lines, 10 modes, noise-free
             receptance;
``10x1``     the 10-mode set of the tests, first actuator, 1% noise (band 20-60 Hz);
``10x3``     the same set, three actuators (EMA: one fit per actuator, times summed);
``10x1n3``   the 10 x 1 set with 3% noise (the partner of the close pair);
``testbed``  ``sd.testbed_frf(n=1500, noise=0.01)``, all sensors x 6 shakers (EMA x 6);
``testbed600`` the same with 600 lines (the 9.52 Hz mode is 0.45 line wide);
``scale``    1000 sensors x 3 references x 4000 lines, 20 modes, 0.5% noise (EMA x 3);
``survey``   the plate's simulated roving-hammer survey, 3 accelerometers x 46 hit points,
             impact H1 through an exponential window (EMA: the accelerometers as
             references by reciprocity, its decay rates corrected for the window).

For every case the three fits (previous sdctrl, this sdctrl, EMA) are alternated run by
run (the machine's load drifts) and the medians over ``--runs`` runs are printed: wall
and CPU times, the ratios sdctrl/EMA and sdctrl/before, and the worst relative frequency
and damping errors over the true in-band modes.  EMA is given the true frequencies to
pick its stable poles (which favours it); sdctrl is given no poles.  EMA uses polynomial
order 40 (10-mode cases) or 60 (testbed, scale), and is run ``--ema-runs`` times on the
scale case (its LSCF loops over outputs and orders in Python).

``--before REF`` imports the package of git revision ``REF`` (e.g. ``main``) under the
name ``sdctrl_before`` (``git archive`` into a temporary directory, names rewritten), so
that both versions run in the same process on the same data.

sdypy-EMA (``pip install sdypy-ema``) is only needed here, not by sdctrl or its tests.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import io
import os
import re
import subprocess
import sys
import tempfile
import time
import warnings

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
sys.path.insert(0, os.path.join(ROOT, "tests"))

import sdctrl as sd

warnings.simplefilter("ignore")


# --- the previous version of the package, imported under another name -------------------
def load_before(ref: str):
    """sdctrl of git revision ``ref`` imported as ``sdctrl_before``."""
    tmp = tempfile.mkdtemp(prefix="sdctrl_before_")
    arch = subprocess.run(["git", "-C", ROOT, "archive", ref, "sdctrl"], check=True,
                          capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", tmp], input=arch, check=True)
    src = os.path.join(tmp, "sdctrl")
    dst = os.path.join(tmp, "sdctrl_before")
    os.rename(src, dst)
    pat = re.compile(r"\bsdctrl\b")
    for base, _dirs, files in os.walk(dst):
        for fn in files:
            if fn.endswith(".py"):
                path = os.path.join(base, fn)
                with open(path) as fh:
                    text = fh.read()
                with open(path, "w") as fh:
                    fh.write(pat.sub("sdctrl_before", text))
    sys.path.insert(0, tmp)
    return importlib.import_module("sdctrl_before")


# --- data: arrays, wrapped into each package's FRF -----------------------------------------
class Case:
    def __init__(self, name, freq, H, band, lam_true, quantity="displacement",
                 ema_form="receptance", ema_order=40, collocated=None, tau=None):
        self.name, self.freq, self.H, self.band = name, freq, H, band
        self.lam = lam_true
        self.quantity, self.ema_form, self.ema_order = quantity, ema_form, ema_order
        self.collocated = collocated
        self.tau = tau              # exponential window of the records (s), or None

    def frf(self, pkg):
        ns, na = self.H.shape[1:]
        kw = {} if self.tau is None else {"exponential_tau": self.tau}
        return pkg.FRF(self.freq, self.H, quantity=self.quantity,
                       sensors=[f"S{i}" for i in range(ns)],
                       actuators=[f"A{j}" for j in range(na)], collocated=self.collocated,
                       **kw)

    def ema_data(self):
        """``H`` as EMA fits it, one reference per last-axis column: a roving-hammer survey
        (more actuators than sensors) transposed by reciprocity, the accelerometers as the
        references and the hit points as the outputs, as a test engineer runs EMA on it."""
        return self.H if self.H.shape[2] <= self.H.shape[1] else np.swapaxes(self.H, 1, 2)


def ema_case():
    rng = np.random.default_rng(7)
    f = np.array([31.0, 58.0, 97.0, 133.0, 171.0, 214.0, 252.0, 301.0, 347.0, 402.0])
    z = np.array([0.01, 0.006, 0.012, 0.008, 0.015, 0.005, 0.01, 0.009, 0.02, 0.007])
    w = 2 * np.pi * f
    lam = -z * w + 1j * w * np.sqrt(1 - z**2)
    c = rng.standard_normal((10, 28)) + 0.1j * rng.standard_normal((10, 28))
    b = rng.standard_normal((10, 1)) + 0.1j * rng.standard_normal((10, 1))
    R = np.einsum("ji,jk->jik", c, b) / (2j * lam.imag)[:, None, None]
    freq = 0.25 * np.arange(1, 2001)                     # 0.25 .. 500 Hz
    H = sd.ComplexModeModel(lam, R).frf(freq).H
    return Case("EMA case 28x1x2000, noise-free", freq, H, None, lam)


def ten_mode_case(n_act, noise=0.01):
    from test_identify import BAND, IN_BAND, ten_mode

    frf, lam, _ = ten_mode(noise=noise, seed=0)
    H = frf.H[:, :, :n_act]
    return Case(f"10x{n_act} {100 * noise:g}% noise", frf.freq, H, BAND, lam[IN_BAND],
                collocated=[(0, 0)])


def testbed_case(n=1500):
    from sdctrl import testbeds as tb

    frf = sd.testbed_frf(n=n, noise=0.01, seed=0)
    # the model testbed_frf simulates: modes up to 5x the band top and static correction
    fe = sd.testbed()
    f_fe, _ = fe.modes(60)
    n_modes = max(int(np.searchsorted(f_fe, 5 * tb.TESTBED_BAND[1])), 16)
    lam = np.asarray(fe.normal_mode_model(list(tb.SHAKERS), list(tb.SENSORS), n_modes,
                                          static=True, static_damping="projected").poles)
    lam = lam[lam.imag > 0]
    f = np.abs(lam) / (2 * np.pi)
    lam = lam[(f > tb.TESTBED_BAND[0]) & (f < tb.TESTBED_BAND[1])]
    ns, na = frf.H.shape[1:]
    return Case(f"testbed {ns}x{na}x{n} 1% noise", frf.freq, frf.H, tb.TESTBED_BAND, lam,
                quantity="acceleration", ema_form="accelerance", ema_order=60)


def survey_case(name="plate"):
    """A simulated roving-hammer survey of a family member (3 accelerometers, every hit
    point hit three times, impact H1 through force and exponential windows, 1% noise):
    sdctrl is given the FRF with its window (it corrects the damping for it, issue 26);
    EMA, which does not know the window, has ``1/tau`` added back to its decay rates."""
    sv = sd.testbeds.survey(name, noise=0.01, seed=1)
    f = sv.frf.band(0.5 * sv.band[0], min(2 * sv.band[1], sv.frf.freq[-1]))
    col = [(f.sensors.index(sv.driving_point), f.actuators.index(sv.driving_point))]
    ns, na = f.H.shape[1:]
    return Case(f"{name} survey {ns}x{na}x{f.freq.size} 1% noise (impact, windowed)", f.freq,
                f.H, sv.band, np.asarray(sv.poles), quantity="acceleration",
                ema_form="accelerance", ema_order=40, collocated=col, tau=f.exponential_tau)


def scale_case(ns=1000, nf=4000, n_modes=20, seed=0, noise=0.005):
    rng = np.random.default_rng(seed)
    f = np.linspace(15, 105, n_modes) * (1 + 0.01 * rng.standard_normal(n_modes))
    z = rng.uniform(0.005, 0.02, n_modes)
    w = 2 * np.pi * f
    lam = -z * w + 1j * w * np.sqrt(1 - z**2)
    c = rng.standard_normal((n_modes, ns)) + 0.1j * rng.standard_normal((n_modes, ns))
    b = rng.standard_normal((n_modes, 3)) + 0.1j * rng.standard_normal((n_modes, 3))
    R = np.einsum("ji,jk->jik", c, b) / (2j * lam.imag)[:, None, None]
    freq = np.linspace(10, 110, nf)
    H = sd.ComplexModeModel(lam, R).frf(freq).H
    H *= 1 + noise * (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape))
    return Case(f"scale {ns}x3x{nf}, 20 modes, 0.5% noise", freq, H, None, lam,
                ema_order=60)


# --- the fits -------------------------------------------------------------------------
def pole_errors(lam_est, lam_true):
    """Worst relative frequency and damping errors of the estimates closest to each true
    pole, and the number of estimates not matched to a true pole (spurious)."""
    fe, ze = np.abs(lam_est) / (2 * np.pi), -lam_est.real / np.abs(lam_est)
    ft, zt = np.abs(lam_true) / (2 * np.pi), -lam_true.real / np.abs(lam_true)
    if fe.size == 0:
        return np.inf, np.inf, 0
    i = np.argmin(np.abs(fe[None, :] - ft[:, None]), axis=1)
    ef = np.max(np.abs(fe[i] / ft - 1))
    ez = np.max(np.abs(ze[i] / zt - 1))
    return ef, ez, fe.size - np.unique(i).size


def fit_sdctrl(pkg, case):
    frf = case.frf(pkg)
    cm = pkg.identify(frf, band=case.band, progress=False)
    lam = np.asarray(cm.poles)[np.asarray(cm.in_band)]
    return lam


def fit_ema(case):
    from sdypy import EMA

    band = case.band or (case.freq[0], case.freq[-1])
    approx = np.abs(case.lam) / (2 * np.pi)
    lam = []
    H = case.ema_data()
    for a in range(H.shape[2]):                  # EMA is single-reference
        with warnings.catch_warnings(), contextlib.redirect_stderr(io.StringIO()):
            warnings.simplefilter("ignore")                 # and EMA's progress bars
            m = EMA.Model(frf=H[:, :, a].T, freq=case.freq, lower=band[0],
                          upper=band[1], pol_order_high=case.ema_order,
                          frf_form=case.ema_form)
            m.get_poles(method="lscf", show_progress=False)
            m.select_closest_poles(list(approx), f_window=4)
            m.get_constants(method="lsfd")
        w = 2 * np.pi * np.asarray(m.nat_freq)
        z = np.asarray(m.nat_xi)
        shift = 0.0 if case.tau is None else 1.0 / case.tau    # the window's decay removed
        lam.append(-z * w + 1j * w * np.sqrt(1 - z**2) + shift)
    return lam


def timed(fn, *args):
    t0, c0 = time.perf_counter(), time.process_time()
    out = fn(*args)
    return out, time.perf_counter() - t0, time.process_time() - c0


def run_case(case, impls, runs, ema_runs):
    times = {k: [] for k in impls}
    cpu = {k: [] for k in impls}
    errs = {}
    for r in range(runs):
        order = list(impls) if r % 2 == 0 else list(impls)[::-1]
        for k in order:
            if k == "EMA" and r >= ema_runs:
                continue
            out, dt, dc = timed(impls[k], case)
            times[k].append(dt)
            cpu[k].append(dc)
            if k == "EMA":
                ef = [pole_errors(lam, case.lam) for lam in out]
                errs[k] = (max(e[0] for e in ef), max(e[1] for e in ef), 0,
                           min(lam.size for lam in out))
            else:
                e = pole_errors(out, case.lam)
                errs[k] = e + (out.size,)
    med = {k: float(np.median(v)) for k, v in times.items() if v}
    cmed = {k: float(np.median(v)) for k, v in cpu.items() if v}
    print(f"\n== {case.name} ({case.lam.size} true modes in band) ==")
    for k in impls:
        if k not in med:
            continue
        ef, ez, spur, n = errs[k]
        print(f"  {k:7s} wall {med[k]:7.3f} s  cpu {cmed[k]:7.3f} s   max freq err {ef:8.1e}  "
              f"max damp err {ez:8.1e}  poles {n:3d}  unmatched {spur}")
    if "sdctrl" in med and "EMA" in med:
        print(f"  ratio sdctrl/EMA   wall {med['sdctrl'] / med['EMA']:6.2f}  "
              f"cpu {cmed['sdctrl'] / cmed['EMA']:6.2f}")
    if "sdctrl" in med and "before" in med:
        print(f"  ratio sdctrl/before wall {med['sdctrl'] / med['before']:6.2f}  "
              f"cpu {cmed['sdctrl'] / cmed['before']:6.2f}")
    return med


CASES = {"ema": ema_case, "10x1": lambda: ten_mode_case(1), "10x3": lambda: ten_mode_case(3),
         "10x1n3": lambda: ten_mode_case(1, 0.03), "testbed": testbed_case,
         "testbed600": lambda: testbed_case(600), "scale": scale_case,
         "survey": survey_case}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--ema-runs", type=int, default=None,
                    help="EMA runs on the testbed and scale cases (default: 1; --runs elsewhere)")
    ap.add_argument("--before", default=None, help="git revision to compare with (e.g. main)")
    ap.add_argument("--cases", default=",".join(CASES))
    ap.add_argument("--no-ema", action="store_true")
    args = ap.parse_args()
    print(f"load average at start: {os.getloadavg()}  (2 cores)")
    impls = {}
    if args.before:
        before = load_before(args.before)
        impls["before"] = lambda case: fit_sdctrl(before, case)
    impls["sdctrl"] = lambda case: fit_sdctrl(sd, case)
    if not args.no_ema:
        try:
            import sdypy.EMA  # noqa: F401
            impls["EMA"] = fit_ema
        except ImportError as exc:
            print(f"sdypy-EMA not available ({exc}): `pip install sdypy-ema`")
    for name in args.cases.split(","):
        case = CASES[name]()
        ema_runs = args.runs if not name.startswith(("scale", "testbed", "survey")) else \
            (args.ema_runs or 1)
        run_case(case, impls, args.runs, ema_runs)
        print(f"  load average: {os.getloadavg()}")


if __name__ == "__main__":
    main()
