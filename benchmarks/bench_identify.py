"""Benchmark of complex-mode identification (issue 4).

Plain script: ``python benchmarks/bench_identify.py [--quick]``.  Prints

1. the two pole optimisers (thesis sign-gradient 3.19 vs variable projection) from the
   same initial poles: wall time, cost evaluations, pole errors;
2. sdctrl ``identify`` (no poles given) vs sdypy-EMA LSCF + LSFD (given the true
   frequencies to pick its stable poles, which favours it) on the same data in one run:
   a single-reference set, and a MIMO set fitted by us at once and by EMA once per
   actuator; wall times and pole errors, as ratios;
3. scale: 250/500/1000 sensors x 3 references x 4000 lines, 20 modes (data compressed
   to a real basis before the pole search): wall time and time per sensor;
4. automatic pole selection on noisy data (no poles given): the package demo chain
   (accelerations with a noise floor), the 10-mode set at 1% noise and the testbed at
   1%/3% noise, per noise draw: in-band poles found, missed and spurious, wall time.

sdypy-EMA (``pip install sdypy-ema``) is only needed here, not by sdctrl or its tests.
"""

from __future__ import annotations

import os
import sys
import time
import warnings

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tests"))

import sdctrl as sd
from sdctrl.identification import IdentificationWarning
from sdctrl.identification.complex_modes import frf_array

warnings.simplefilter("ignore", IdentificationWarning)


def ten_mode(noise, seed, df=0.05):
    from test_identify import ten_mode as tm

    return tm(noise=noise, seed=seed, df=df)


def pole_errors(freq_est, zeta_est, f_true, z_true):
    """Relative frequency and damping errors of the estimate closest to each true mode."""
    freq_est = np.asarray(freq_est, float)
    fe, ze = [], []
    for f, z in zip(f_true, z_true):
        if freq_est.size == 0:
            fe.append(np.inf)
            ze.append(np.inf)
            continue
        i = int(np.argmin(np.abs(freq_est - f)))
        fe.append(abs(freq_est[i] / f - 1))
        ze.append(abs(zeta_est[i] / z - 1))
    return np.array(fe), np.array(ze)


def bench_optimizers():
    from test_identify import F_TRUE, IN_BAND, Z_TRUE, _truth

    lam, _ = _truth()
    lam0 = (lam.real * 1.3) + 1j * lam.imag * (1 + 1e-3)      # 0.1% and 30% off
    strong = IN_BAND & (np.arange(10) != 6)                     # in band, not the local mode
    for noise in (0.0, 0.01):
        print(f"\n== pole optimisers from the same initial poles (0.1% / 30% off), 10-mode "
              f"MIMO set (10 x 3, 801 lines, {noise:.0%} noise) ==")
        frf, _, _ = ten_mode(noise, 0)
        res = {}
        for opt in ("gradient", "varpro"):
            t0 = time.perf_counter()
            cm = sd.identify(frf, poles=lam0, band=(20, 60), optimizer=opt, progress=False)
            dt = time.perf_counter() - t0
            fe, ze = pole_errors(cm.frequency, cm.damping, F_TRUE[strong], Z_TRUE[strong])
            fl, zl = pole_errors(cm.frequency, cm.damping, F_TRUE[[6]], Z_TRUE[[6]])
            res[opt] = dt
            print(f"{opt:9s} time {dt:6.3f} s  evaluations {cm.info['nfev']:5d}  strong modes: "
                  f"max freq err {fe.max():.1e}, max damping err {ze.max():.1e};  local mode: "
                  f"{fl[0]:.1e}, {zl[0]:.1e};  cost {cm.cost:.3e}")
        print(f"time ratio gradient/varpro: {res['gradient'] / res['varpro']:.1f}")


def _ema_fit(H_out_by_freq, freq, band, approx, form="receptance", order=40, f_window=4):
    from sdypy import EMA

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = EMA.Model(frf=H_out_by_freq, freq=freq, lower=band[0], upper=band[1],
                      pol_order_high=order, frf_form=form)
        m.get_poles(method="lscf", show_progress=False)
        m.select_closest_poles(list(approx), f_window=f_window)
        m.get_constants(method="lsfd")
    return np.asarray(m.nat_freq), np.asarray(m.nat_xi)


def bench_ema():
    from test_identify import F_TRUE, IN_BAND, Z_TRUE

    print("\n== sdctrl identify vs sdypy-EMA LSCF+LSFD (10-mode set, 1% noise) ==")
    try:
        import sdypy.EMA  # noqa: F401
    except ImportError as exc:
        print(f"sdypy-EMA not available ({exc}); install it with `pip install sdypy-ema` "
              "to run this comparison")
        return
    frf, _, _ = ten_mode(0.01, 0)
    band = (20.0, 60.0)
    ft, zt = F_TRUE[IN_BAND], Z_TRUE[IN_BAND]
    rows = []
    # single reference: actuator 0 only (10 x 1)
    one = frf.select(actuators=[0])
    t0 = time.perf_counter()
    cm = sd.identify(one, band=band, progress=False)
    t_ours = time.perf_counter() - t0
    fe_o, ze_o = pole_errors(cm.frequency, cm.damping, ft, zt)
    t0 = time.perf_counter()
    f_e, z_e = _ema_fit(one.H[:, :, 0].T, one.freq, band, ft)
    t_ema = time.perf_counter() - t0
    fe_e, ze_e = pole_errors(f_e, z_e, ft, zt)
    rows.append(("single reference 10x1", t_ours, t_ema, fe_o, fe_e, ze_o, ze_e, cm.n))
    # MIMO: ours at once, EMA one fit per actuator (errors: worst over the three fits)
    t0 = time.perf_counter()
    cm = sd.identify(frf, band=band, progress=False)
    t_ours = time.perf_counter() - t0
    fe_o, ze_o = pole_errors(cm.frequency, cm.damping, ft, zt)
    t_ema = 0.0
    fe_e = np.zeros(ft.size)
    ze_e = np.zeros(ft.size)
    for a in range(frf.H.shape[2]):
        t0 = time.perf_counter()
        f_e, z_e = _ema_fit(frf.H[:, :, a].T, frf.freq, band, ft)
        t_ema += time.perf_counter() - t0
        fa, za = pole_errors(f_e, z_e, ft, zt)
        fe_e, ze_e = np.maximum(fe_e, fa), np.maximum(ze_e, za)
    rows.append(("MIMO 10x3 (EMA x3)", t_ours, t_ema, fe_o, fe_e, ze_o, ze_e, cm.n))
    print("(EMA is given the true frequencies to pick its stable poles; sdctrl is given "
          "no poles; errors over the 8 in-band modes, 'local' is the 44 Hz local mode)")
    for name, to, te, fo, fe, zo, ze, n in rows:
        loc = 5                                   # index of 44 Hz among in-band modes
        print(f"{name:22s} time sdctrl {to:6.2f} s  EMA {te:6.2f} s  ratio EMA/sdctrl "
              f"{te / to:5.2f}   ({n} poles found)")
        print(f"{'':22s} median freq err sdctrl {np.median(fo):.1e} EMA {np.median(fe):.1e}"
              f"  ratio {np.median(fe) / np.median(fo):.1f};  max: {fo.max():.1e} vs "
              f"{fe.max():.1e}")
        print(f"{'':22s} median damp err sdctrl {np.median(zo):.1e} EMA {np.median(ze):.1e}"
              f"  ratio {np.median(ze) / np.median(zo):.1f};  max: {zo.max():.1e} vs "
              f"{ze.max():.1e};  local mode damping err {zo[loc]:.1e} vs {ze[loc]:.1e}")


def scale_data(ns, nf=4000, n_modes=20, seed=0, noise=0.005):
    rng = np.random.default_rng(seed)
    f = np.linspace(15, 105, n_modes) * (1 + 0.01 * rng.standard_normal(n_modes))
    z = rng.uniform(0.005, 0.02, n_modes)
    w = 2 * np.pi * f
    lam = -z * w + 1j * w * np.sqrt(1 - z**2)
    c = rng.standard_normal((n_modes, ns)) + 0.1j * rng.standard_normal((n_modes, ns))
    b = rng.standard_normal((n_modes, 3)) + 0.1j * rng.standard_normal((n_modes, 3))
    R = np.einsum("ji,jk->jik", c, b) / (2j * lam.imag)[:, None, None]
    freq = np.linspace(10, 110, nf)
    H = frf_array(lam, R, np.zeros((ns, 3)), np.zeros((ns, 3)), 2j * np.pi * freq)
    H *= 1 + noise * (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape))
    return sd.FRF(freq, H), f, z


def bench_scale(sizes):
    print("\n== scale: ns sensors x 3 references x 4000 lines, 20 modes, 0.5% noise ==")
    per = []
    for ns in sizes:
        t0 = time.perf_counter()
        frf, f, z = scale_data(ns)
        t_gen = time.perf_counter() - t0
        t0 = time.perf_counter()
        cm = sd.identify(frf, progress=False)
        dt = time.perf_counter() - t0
        fe, ze = pole_errors(cm.frequency, cm.damping, f, z)
        per.append(dt / ns)
        print(f"ns={ns:5d}: identify {dt:6.2f} s (data generation {t_gen:5.1f} s), "
              f"{cm.n} poles (20 true), compressed to rank {cm.info['compress_rank']}, "
              f"max freq err {fe.max():.1e}, max damping err {ze.max():.1e}, "
              f"time per sensor {1e3 * dt / ns:.2f} ms")
    if len(sizes) > 1:
        print(f"time ratio largest/smallest: {per[-1] * sizes[-1] / (per[0] * sizes[0]):.2f} "
              f"for a sensor ratio of {sizes[-1] / sizes[0]:.0f}")


def _count(cm, f_true, rtol):
    f = cm.frequency[cm.in_band]
    missed = [ft for ft in f_true if f.size == 0 or np.min(np.abs(f - ft)) > rtol * ft]
    spurious = [x for x in f if np.min(np.abs(np.asarray(f_true) - x)) > rtol * x]
    return f.size, missed, spurious


def bench_noisy_auto(seeds):
    from test_identify import BAND, F_TRUE, IN_BAND, _chain_demo
    from test_identify import ten_mode as tm

    from sdctrl.testbeds import TESTBED_BAND

    print("\n== automatic pole selection on noisy data (no poles given) ==")
    cases = []
    for seed in seeds:
        frf, lam = _chain_demo(seed)
        cases.append((f"demo chain 1% + floor, seed {seed}", frf, None,
                      np.abs(lam) / (2 * np.pi), 2e-3))
    for seed in seeds:
        cases.append((f"10-mode set 1%, seed {seed}", tm(noise=0.01, seed=seed)[0], BAND,
                      F_TRUE[IN_BAND], 2e-3))
    f_tb = [9.518, 12.66, 15.786, 15.872, 18.135, 18.63, 27.60, 43.83, 48.42, 52.90,
            54.73, 56.40]
    for noise in (0.01, 0.03):
        for seed in seeds[:2]:
            cases.append((f"testbed {noise:.0%}, seed {seed}",
                          sd.testbed_frf(noise=noise, seed=seed), TESTBED_BAND, f_tb, 2e-3))
    for name, frf, band, f_true, rtol in cases:
        t0 = time.perf_counter()
        cm = sd.identify(frf, band=band, progress=False)
        dt = time.perf_counter() - t0
        n, missed, spurious = _count(cm, f_true, rtol)
        print(f"{name:34s}: {n:2d} in-band poles ({len(f_true)} true), missed "
              f"{[round(x, 2) for x in missed]}, spurious {[round(x, 2) for x in spurious]}, "
              f"{dt:5.1f} s")


if __name__ == "__main__":
    quick = "--quick" in sys.argv
    bench_optimizers()
    bench_ema()
    bench_scale([100, 250] if quick else [250, 500, 1000])
    bench_noisy_auto(range(2) if quick else range(6))
