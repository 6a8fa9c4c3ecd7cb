"""The mass scale of a hybrid model's measured modes (:mod:`sdctrl.hybrids._mass_scale`): the
test's collocated scale and the FE modal mass of the expanded shape, combined by their
variances (a random-effects model whose offset and spread come from the modes themselves).

Measured on the family's cluster at 1% noise without the blade shaker T1.y (the hub shaker
H3.y is a near node of the four blade modes, their collocated residues within noise): the
test's scale of the blade modes is off by factors of 1.3-3.5 (``|c phi|`` 0.36-1.4 against
1.93 true, seeds 1 and 2); the
FE's modal mass brings each within 3-5% of the truth on seeds 1 and 2 (standard deviation
4.5%), the sensor residue of the four modes from 76-81% off to 49%, and the tested I/O are
unchanged to round-off.  The
untested shaker T1.y does not gain from it (0.06x / 0.11x -> 0.06x / 0.06x against the
wrong FE): what carries that error is the blade modes' damping coupling
(``test_family_hybrid.test_cluster_shaker_gap_what_carries_it``), which right scales expose
rather than hide.  Where it does carry the error -- a held-out aircraft model, not in the
repository, tested with two of its three shakers at 1% noise -- the untested shaker went from
1.57x to 15.7x better than the wrong FE on one seed, 0.95x -> 5.1x and 1.68x -> 8.5x on
the two others (the third once ``nm.std`` propagates through a nominal near the properness
limit, ``test_statistics``).  On the other members (1%, seeds
1-3, untested shaker) the figures move by -8% to +0% (ladder 34.7x -> 32.0x on seed 3, plate
41.3x -> 39.9x), the D-strut and broken-strut figures by less than 1% but the cluster's
broken strut on seed 2 (124x -> 24x); ``tests/test_family_hybrid*.py`` build without
statistics and are unchanged.
"""

from __future__ import annotations

import functools
import os
import tempfile
import warnings

import numpy as np
import pytest

import sdctrl as sd
from sdctrl.hybrids._mass_scale import fe_mass_scale, random_effects


def test_random_effects_recovers_offset_and_spread():
    rng = np.random.default_rng(0)
    sig = rng.uniform(0.01, 0.3, 4000)
    d = 0.1 + rng.normal(0.0, 0.05, sig.size) + rng.normal(0.0, sig)
    b, tau2 = random_effects(d, sig ** 2)
    assert b == pytest.approx(0.1, abs=0.004)
    assert np.sqrt(tau2) == pytest.approx(0.05, rel=0.1)
    b, tau2 = random_effects(np.full(5, -0.2), np.full(5, 1e-4))
    assert b == pytest.approx(-0.2) and tau2 == 0.0


def _draw(rng, sig, b, tau):
    """Expanded shapes (``M = I``) whose FE modal mass reads ``d = delta + b + e`` for a
    test scale error ``delta ~ N(0, sig^2)``; the true ``delta``."""
    delta = rng.normal(0.0, sig)
    d = delta + b + rng.normal(0.0, tau, sig.size)
    return np.diag(np.exp(-d)), delta


def _scatter(rng, n_good, draws=400):
    """z scatter (well-measured, unscaled) and rms errors of the combined log scale over
    ``draws`` draws of ``n_good`` modes scaled by the test to 1% and 4 it cannot scale
    (sigma 1); FE spread 5%, offset 8%."""
    sig = np.r_[np.full(n_good, 0.01), np.full(4, 1.0)]
    z, err = [], []
    for _ in range(draws):
        S, delta = _draw(rng, sig, 0.08, 0.05)
        ms = fe_mass_scale(np.eye(sig.size), S, sig, np.arange(sig.size))
        err.append(np.log(ms.factor) - delta)
        z.append(err[-1] / ms.std)
    z, err = np.array(z), np.array(err)
    rms = np.sqrt(np.mean(err ** 2, axis=0))
    return z[:, :n_good].std(), z[:, n_good:].std(), rms[:n_good].max(), rms[n_good:].max()


def test_combined_scale_is_calibrated_and_keeps_well_measured_modes():
    """With 30 well-measured modes the error of the combined log scale over its standard
    deviation has unit scatter in both groups; the well-measured modes keep the test's scale
    to within their own error, the others come within the FE's spread of the truth.  With 8
    the FE's spread is learnt from few modes and the standard deviation of the unscaled
    ones understates their error by a third (module notes; measured 1.31)."""
    good, poor, e_good, e_poor = _scatter(np.random.default_rng(3), 30)
    print(f"\n30 modes: z scatter {good:.3f} / {poor:.3f}, rms error {e_good:.4f} / {e_poor:.4f}")
    assert 0.85 <= good <= 1.15 and 0.85 <= poor <= 1.15
    assert e_good <= 0.011 and e_poor <= 0.06                      # the test's 1%, FE's 5%
    good, poor, e_good, e_poor = _scatter(np.random.default_rng(3), 8)
    print(f"8 modes: z scatter {good:.3f} / {poor:.3f}, rms error {e_good:.4f} / {e_poor:.4f}")
    assert 0.85 <= good <= 1.2 and 1.15 <= poor <= 1.5
    assert e_good <= 0.011 and e_poor <= 0.065


def test_mode_frequency_error_widens_the_fe_reading():
    """A mode the FE gets wrong in frequency (its own error beyond the common ``kappa``) has
    a less certain modal mass: over 400 draws whose FE errors scale with it, the combined
    scale stays calibrated, and a well-measured mode with a large frequency error keeps the
    test's scale although its FE reading is far off."""
    rng = np.random.default_rng(5)
    sig = np.r_[np.full(20, 0.01), np.full(4, 1.0)]
    eps = np.r_[np.full(10, 0.005), np.full(10, 0.06), np.full(2, 0.005), np.full(2, 0.06)]
    z, moved = [], []
    for _ in range(400):
        delta = rng.normal(0.0, sig)
        d = delta + 0.03 + rng.normal(0.0, 0.01, sig.size) + rng.normal(0.0, eps)
        ms = fe_mass_scale(np.eye(sig.size), np.diag(np.exp(-d)), sig, np.arange(sig.size),
                           eps)
        z.append((np.log(ms.factor) - delta) / ms.std)
        moved.append(np.abs(np.log(ms.factor[10:20])))
    z = np.array(z)
    print(f"\nz scatter: {z[:, :20].std():.3f} / {z[:, 20:].std():.3f}")
    assert 0.85 <= z[:, :20].std() <= 1.15 and 0.85 <= z[:, 20:].std() <= 1.2
    assert np.mean(moved) <= 0.003                   # the test's 1% kept, not the FE's 6%


def test_without_statistics_nothing_is_rescaled():
    assert fe_mass_scale(np.eye(3), np.eye(3), None, np.arange(3)) is None
    one = fe_mass_scale(np.eye(3), np.eye(3)[:, :1], np.array([0.1]), np.arange(1))
    assert one is None                                          # no spread to learn


@functools.cache
def _cluster(seed):
    """The cluster at 1% without T1.y: nm with statistics, its hybrid and the same hybrid
    from nm without them."""
    st = sd.testbeds.structure("cluster")
    SH, SE = list(st.shakers), list(st.sensors)
    frf = st.frf(n=400, noise=0.01, seed=seed)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        nm = sd.normal_modes(sd.identify(frf.select(actuators=SH[:-1]), progress=False))
        h = sd.hybrid(st.wrong(), nm, SE, SH[:-1])
        h0 = sd.hybrid(st.wrong(), nm.replace(std=None), SE, SH[:-1])
    return st, nm, h, h0


@pytest.mark.parametrize("seed", [1, 2])
def test_cluster_blade_modes_take_the_fe_scale(seed):
    st, nm, h, h0 = _cluster(seed)
    assert h0.construction.mass_scale is None
    ms = h.construction.mass_scale
    true = st.fe()
    c = true.point(list(st.sensors)).T
    _, phi = true.modes(4)                                      # the four blade modes
    fh = np.sqrt(np.diag(h.Omega)) / (2 * np.pi)
    blade = np.flatnonzero((h.kind == "measured") & (fh < 11))
    assert blade.size == 4
    # the test cannot scale them; the well-measured 36.98 Hz mode keeps its scale
    assert np.all(ms.test_std[:4] >= 1.0) and ms.test_std[4] <= 0.02
    assert abs(ms.factor[4] - 1) <= 0.01
    for j, k in zip(blade, range(4)):
        before = np.log(np.linalg.norm(c @ h0.shapes[:, j]) / np.linalg.norm(c @ phi[:, k]))
        after = np.log(np.linalg.norm(c @ h.shapes[:, j]) / np.linalg.norm(c @ phi[:, k]))
        assert abs(before) >= 0.25 and abs(after) <= 0.08       # 0.3-1.25 -> 0.03-0.05
        assert abs(after) <= 2 * ms.std[list(blade).index(j)]    # std 0.045

    def residue(m):
        return sum(np.outer(c @ m.shapes[:, j], c @ m.shapes[:, j]) for j in blade)

    Rt = c @ phi @ phi.T @ c.T
    e0, e1 = (np.linalg.norm(residue(m) - Rt) / np.linalg.norm(Rt) for m in (h0, h))
    print(f"\nseed {seed}: blade residue error {e0:.3f} -> {e1:.3f}, factors "
          f"{np.round(ms.factor, 3)}")
    assert e0 >= 0.7 and e1 <= 0.55                             # 0.76 / 0.81 -> 0.49
    f = np.linspace(*st.band, 200)
    H, H0 = h.frf(f).H, h0.frf(f).H
    assert np.max(np.abs(H - H0)) <= 1e-10 * np.max(np.abs(H0))  # tested I/O unchanged


def _shaker(st, h):
    """logLS of the wrong FE over that of ``h`` at the untested shaker (T1.y)."""
    from sdctrl.updating._costs import logls
    u, SE = st.shakers[-1], list(st.sensors)
    freq = np.linspace(*st.band, 300)
    ref = st.fe().frf(freq, [u], SE, "acceleration")
    return (logls(st.wrong().frf(freq, [u], SE, "acceleration"), ref)
            / logls(h.with_io(b=[u]).frf(freq, "acceleration"), ref))


@pytest.mark.parametrize("seed, before, after", [(1, 0.06, 0.06), (2, 0.11, 0.06)])
def test_cluster_untested_shaker_does_not_gain(seed, before, after):
    """The trade, locked: the right blade scales do not carry the untested shaker (module
    notes); on seed 2 the figure falls from 0.11x to 0.06x (both far below 12x)."""
    st, nm, h, h0 = _cluster(seed)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        got = [_shaker(st, m) for m in (h0, h)]
    print(f"\nseed {seed}: untested shaker {got[0]:.3f}x -> {got[1]:.3f}x")
    assert got[0] == pytest.approx(before, abs=0.015)
    assert got[1] == pytest.approx(after, abs=0.015)


def test_mass_scale_is_stored():
    _, _, h, _ = _cluster(2)
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "h.npz")
        sd.save(h, path)
        back = sd.load(path).construction.mass_scale
    ms = h.construction.mass_scale
    for name in ("test_mode", "test_std", "fe_log", "factor", "std"):
        assert np.array_equal(getattr(back, name), getattr(ms, name))
    assert back.bias == ms.bias and back.spread == ms.spread


def test_pairing_report_shows_the_scale():
    _, _, h, h0 = _cluster(1)
    rows = sd.hybrids.pairing_report(h).splitlines()
    assert rows[0].endswith("| MAC | scale |") and len(rows) == 2 + 5
    assert rows[2].endswith("| 2.805 +- 0.045 |")             # 10.15 Hz, the FE's scale
    assert rows[-1].endswith("| 1.000 +- 0.010 |")            # 36.98 Hz, the test's
    assert sd.hybrids.pairing_report(h0).splitlines()[0].endswith("| MAC |")


def test_cluster_scale_std_over_noise_draws():
    """The stated standard deviation of the blade modes' combined scale against their true
    scale, over 15 noise draws (1%, without T1.y; two draws resolve only two blade modes and
    are left out): it understates the error by 1.7x (rms of error / std, measured 1.70 over
    52 modes; 3 beyond 3 std).  On the 6 draws where the identification separates the blade
    modes cleanly the scale is within 3-5% and 1.2 std of the truth; on the other 7 the
    test's ``nm.std`` understates the blade modes' own scale error (0.6 for an error of
    1.4, log), the random-effects model reads the excess as FE spread (``spread`` 0.26-1.0)
    and keeps them 0.3-1.8 (log) too small.  Locked so that a change of the rule shows here.
    """
    true = sd.testbeds.structure("cluster").fe()
    st = sd.testbeds.structure("cluster")
    c = true.point(list(st.sensors)).T
    _, phi = true.modes(4)
    z, clean = [], []
    for seed in range(1, 16):
        _, _, h, _ = _cluster(seed)
        fh = np.sqrt(np.diag(h.Omega)) / (2 * np.pi)
        blade = np.flatnonzero((h.kind == "measured") & (fh < 11))
        if blade.size != 4:
            continue
        err = np.log(np.linalg.norm(c @ h.shapes[:, blade], axis=0)
                     / np.linalg.norm(c @ phi, axis=0))
        z.append(err / h.construction.mass_scale.std[:4])
        if h.construction.mass_scale.spread < 0.1:
            clean.append(np.abs(err).max())
    z = np.concatenate(z)
    rms = float(np.sqrt(np.mean(z ** 2)))
    print(f"\n{z.size} blade modes: rms z {rms:.2f}, beyond 3 std {np.sum(np.abs(z) > 3)}; "
          f"clean draws {len(clean)}, worst error {max(clean):.3f}")
    assert z.size == 52 and 1.4 <= rms <= 2.0 and np.sum(np.abs(z) > 3) <= 4
    assert len(clean) == 6 and max(clean) <= 0.06
