"""The scan after the last effect is skipped when no effect could pass the share test
(sdctrl.diagnosis._loop._exhausted): the result is the full run's, bit for bit, on every member
of the family, noise-free and at 1% noise; the noise estimate the bound trusts within a factor
2 is checked against the truth, with noise that varies by line."""

from __future__ import annotations

import numpy as np
import pytest

import sdctrl as sd
import sdctrl.diagnosis._loop as loop
from sdctrl.diagnosis._residual_map import noise_level
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
    when the bound says no effect could pass (noise-free always: the error left is below
    0.1% of the initial one; at 1% when the initial error exceeds ~500 x the noise level).
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
    skipped = loop._exhausted(J, J0, s2)
    assert skipped == bool(fast.steps[-1].get("skipped"))
    assert skipped or noise          # noise-free: always
    if skipped:
        assert "not scanned" in fast.steps[-1]["skipped"] and not fast.steps[-1]["candidates"]
        assert "not scanned" in fast.report()
        gain = J - last["candidates"][0]["cost"]
        assert gain < J - loop.NOISE_SHARE * s2
        assert gain < loop.MIN_SHARE * (J0 - s2)
    else:
        assert fast.steps[-1] == last
    if noise:     # at 1% the error left is the noise
        assert J == pytest.approx(1e-4, rel=0.05)
        assert skipped == (J0 > 0.1)            # the members' initial errors: 0.04 to 0.3


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


@pytest.mark.parametrize("seed", range(3))
def test_noise_estimate_within_the_bounds_factor(seed):
    """The bound trusts ``noise_level`` within ``1 / NOISE_SHARE`` = 2: on a smooth residual
    (a 2% stiffness error of a lightly damped mode) plus complex noise whose level varies by
    line (0.3% to 3%, log-uniform), the estimate lies within [0.5, 2] of the noise's true
    mean power, and below twice it."""
    rng = np.random.default_rng(seed)
    f = np.linspace(10, 60, 600)
    w, wn, z = 2 * np.pi * f, 2 * np.pi * 30.0, 0.01
    H = 1.0 / (wn**2 - w**2 + 2j * z * wn * w)
    Hm = 1.0 / ((1.02 * wn) ** 2 - w**2 + 2j * z * wn * w)
    level = 10 ** rng.uniform(np.log10(3e-3), np.log10(3e-2), f.size)
    e = (rng.standard_normal((600, 8, 2)) + 1j * rng.standard_normal((600, 8, 2))) / np.sqrt(2)
    r = np.log(Hm / H)[:, None, None] - np.log1p(level[:, None, None] * e)
    truth = float(np.mean(level**2))
    est = noise_level(r)
    assert 0.5 * truth <= est <= 2 * truth, (est, truth)
