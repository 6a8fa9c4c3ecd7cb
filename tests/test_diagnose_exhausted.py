"""The scan after the last effect is skipped when no effect could pass the share test
(sdctrl.diagnosis._loop._exhausted): the result is the full run's, bit for bit, on every member
of the family, noise-free and at 1% noise; the noise floor the bound rests on
(_residual_map.noise_floor) is checked below the truth for white noise, noise that varies by
line and noise correlated between neighbouring lines (windowed spectra)."""

from __future__ import annotations

import numpy as np
import pytest

import sdctrl as sd
import sdctrl.diagnosis._loop as loop
from sdctrl.diagnosis._residual_map import complex_residual, noise_floor, noise_level
from test_diagnose_family import case, member, noisy, planted


def _run(name, noise, skip, monkeypatch):
    c = case(name, "mass_change")
    model, data = planted(name, (c,))
    if noise:
        data = noisy(data, noise, 3)
    if not skip:
        monkeypatch.setattr(loop, "_exhausted", lambda *a: False)
    d = sd.diagnose(model, data, member(name)[1], max_effects=3, progress=False)
    monkeypatch.undo()
    return d


@pytest.mark.parametrize("noise", [0.0, 0.01])
@pytest.mark.parametrize("name", sd.testbeds.family())
def test_skipped_scan_changes_nothing(name, noise, monkeypatch):
    """A planted mass on each member: one effect, and the scan after it is skipped exactly
    when the bound says no effect could pass (noise-free: the error left is below 0.1% of
    the initial one; at 1%: the initial error exceeds ~130 x the noise level).
    Running that scan anyway adds nothing and changes no figure, and its best candidate
    removes less than the bound ``J - NOISE_SHARE sigma^2`` and less than the share an effect
    must remove."""
    fast = _run(name, noise, True, monkeypatch)
    full = _run(name, noise, False, monkeypatch)
    assert [e.kind for e in fast.effects] == [e.kind for e in full.effects] == ["mass_change"]
    assert fast.effects[0].location == full.effects[0].location == case(name, "mass_change")[1]
    assert fast.effects[0].parameters["dm"] == full.effects[0].parameters["dm"]
    assert fast.effects[0].std == full.effects[0].std
    assert fast.error_after == full.error_after and fast.noise == full.noise
    assert len(fast.steps) == len(full.steps) == 2
    last = full.steps[-1]
    assert not last["accepted"] and "skipped" not in last
    J, J0, s2 = full.error_after, full.error_before, full.noise
    r = complex_residual(full.model.frf(full.frf.freq, full.frf.quantity).H, full.frf.H)
    floor = min(s2, noise_floor(r))
    skipped = loop._exhausted(J, J0, s2, floor)
    assert skipped == bool(fast.steps[-1].get("skipped"))
    assert skipped or noise          # noise-free: always
    if skipped:
        assert "not scanned" in fast.steps[-1]["skipped"] and not fast.steps[-1]["candidates"]
        assert "not scanned" in fast.report()
        gain = J - last["candidates"][0]["cost"]
        assert gain < J - loop.NOISE_SHARE * floor
        assert gain < loop.MIN_SHARE * (J0 - s2)
    else:
        assert fast.steps[-1] == last
    if noise:     # at 1% the error left is the noise, the floor 6-8% below it (200 lines)
        assert J == pytest.approx(1e-4, rel=0.05) and 0.9 * J < floor < J
        assert skipped                          # the members' initial errors: 0.04 to 0.44


def test_not_skipped_while_a_second_effect_is_left():
    """Two effects planted (a mass, a dashpot): the scan after the first runs and finds the
    second (the bound never stops a diagnosis that has more to find)."""
    name = "ladder"
    cs = (case(name, "mass_change", 1), case(name, "added_damper", 0))
    model, data = planted(name, cs)
    d = sd.diagnose(model, noisy(data, 0.01, 4), member(name)[1], max_effects=3,
                    progress=False)
    assert {e.kind for e in d.effects} >= {"mass_change", "added_damper"}
    assert [bool(st.get("skipped")) for st in d.steps] == [False] * (len(d.steps) - 1) + [True]


KINDS = ("white", "varying", "hann", "neighbours")


def _noise(kind, rng, shape):
    """Complex noise of unit mean power per entry: independent lines, a level varying by line
    (log-uniform over a decade), or lines correlated as a Hann window correlates them
    (``(2 e_l - e_{l-1} - e_{l+1}) / sqrt(6)``, -2/3 between neighbours) or as a first
    difference does (-1/2)."""
    e = (rng.standard_normal((shape[0] + 2,) + shape[1:])
         + 1j * rng.standard_normal((shape[0] + 2,) + shape[1:])) / np.sqrt(2)
    if kind == "hann":
        return (2 * e[1:-1] - e[:-2] - e[2:]) / np.sqrt(6)
    if kind == "neighbours":
        return (e[1:-1] - e[:-2]) / np.sqrt(2)
    return e[1:-1]


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("kind", KINDS)
def test_noise_floor_below_the_truth(kind, seed):
    """On a smooth residual (a 1% stiffness error of a mode of 1% damping, whose error 47 times
    the noise's is far more than a skipped scan can leave: that is below 0.1% of the initial
    error plus the noise) plus noise of each kind, the floor is below the noise's true mean
    power, and within 15% of it where the lines are independent or neighbours only are
    correlated; the second-difference estimate doubles for the Hann window's correlation
    (what the floor guards against).  (With a 4% stiffness error, 660 times the noise, the
    neighbours' floor reaches the truth: 0.99-1.004.)"""
    rng = np.random.default_rng(seed)
    f = np.linspace(10, 60, 600)
    w, wn, z = 2 * np.pi * f, 2 * np.pi * 30.0, 0.01
    H = 1.0 / (wn**2 - w**2 + 2j * z * wn * w)
    Hm = 1.0 / ((1.005 * wn) ** 2 - w**2 + 2j * z * wn * w)
    level = (10 ** rng.uniform(np.log10(3e-3), np.log10(3e-2), f.size) if kind == "varying"
             else np.full(f.size, 0.01))
    n = np.log1p(level[:, None, None] * _noise(kind, rng, (600, 8, 2)))
    r = np.log(Hm / H)[:, None, None] - n
    truth = float(np.mean(np.abs(n) ** 2))
    floor = noise_floor(r)
    assert floor < truth, (floor, truth)
    if kind in ("white", "neighbours"):
        assert floor > 0.85 * truth
    if kind == "hann":
        assert floor > 0.7 * truth and noise_level(r) > 1.8 * truth
