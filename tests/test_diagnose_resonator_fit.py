"""The resonator finalists' fit on many lines (sdctrl.diagnosis._finalist_fit): a first fit on
every k-th line, then at most FINAL_NFEV evaluations on all the lines, none when the first fit
drove the mass onto its lower bound (the resonator vanished).  The truss at 600 lines (the
fit on all the lines runs only beyond PRE_FIT_LINES = 200)."""

from __future__ import annotations

import numpy as np
import pytest

import sdctrl as sd
import sdctrl.diagnosis._finalist_fit as ff
import test_diagnose as T

LINES = np.linspace(8.0, 60.0, 600)


def _spy(monkeypatch, calls):
    """Record ``(lines, evaluations, vanished)`` of every resonator fit."""
    orig = ff._least_squares

    def spy(s, A, P, Gkk, x0, lb, ub, max_nfev=100):
        r = orig(s, A, P, Gkk, x0, lb, ub, max_nfev)
        calls.append((s.size, r.nfev, bool(r.x[0] <= lb[0] + ff.VANISHED)))
        return r
    monkeypatch.setattr(ff, "_least_squares", spy)


def _diagnose(monkeypatch, case, noise, calls=None, **patch):
    monkeypatch.setattr(T, "FREQ", LINES)
    for k, v in patch.items():
        monkeypatch.setattr(ff, k, v)
    if calls is not None:
        _spy(monkeypatch, calls)
    data = T.clean_data.__wrapped__(case)      # not its cache: other files read it on FREQ
    d = sd.diagnose(T.nominal(), T.noisy(data, noise) if noise else data, T.FE,
                    progress=False)
    monkeypatch.undo()
    return d


def test_resonator_found_as_with_an_unbounded_final_fit(monkeypatch):
    """A 0.05 kg resonator at 30 Hz on N33.z, 1% noise: found (location, frequency 0.1%,
    damping and mass 3%), its parameters those of the fit without the evaluation limit to
    1e-6, and no fit on all the lines took more than FINAL_NFEV evaluations."""
    calls = []
    d = _diagnose(monkeypatch, T.CASES["resonator"], 0.01, calls)
    ref = _diagnose(monkeypatch, T.CASES["resonator"], 0.01, FINAL_NFEV=100, PRE_NFEV=100)
    e, r = d.effects[0], ref.effects[0]
    assert (e.kind, e.location) == (r.kind, r.location) == ("missing_mode", "N33.z")
    for k, truth, tol in (("frequency", 30.0, 1e-3), ("damping", 0.01, 0.03),
                          ("mass", 0.05, 0.03)):
        assert e.parameters[k] == pytest.approx(truth, rel=tol)
        assert e.parameters[k] == pytest.approx(r.parameters[k], rel=1e-6)
    assert d.error_after == pytest.approx(ref.error_after, rel=1e-9)
    full = [n for size, n, _ in calls if size == LINES.size]
    assert full and max(full) <= ff.FINAL_NFEV
    assert max(n for size, n, _ in calls if size < LINES.size) <= ff.PRE_NFEV


def test_vanished_resonator_not_fitted_on_all_lines(monkeypatch):
    """A 0.05 kg mass at N20 (1% noise): found within 3 std, and every resonator finalist's
    fit on all the lines stops within FINAL_NFEV evaluations (one ran to 100 before, 3 s of
    CPU); a first fit that drove the mass onto its lower bound is never followed by one on
    all the lines.  (Whether a finalist vanishes here depends on the free mode fitted to the
    noise, which tunes the resonators: the path itself is checked on a synthetic finalist
    below.)"""
    calls = []
    d = _diagnose(monkeypatch, ("mass_change", "N20", 0.05), 0.01, calls)
    e = d.effects[0]
    assert (e.kind, e.location) == ("mass_change", "N20")
    assert abs(e.parameters["dm"] - 0.05) <= 3 * e.std["dm"]
    assert d.error_after == pytest.approx(1e-4, rel=0.05)
    pre = [(i, vanished) for i, (size, _, vanished) in enumerate(calls) if size < LINES.size]
    assert pre
    for i, vanished in pre:
        follows = i + 1 < len(calls) and calls[i + 1][0] == LINES.size
        assert follows != vanished
    assert max(n for size, n, _ in calls if size == LINES.size) <= ff.FINAL_NFEV


def _finalist(resonator):
    """A synthetic resonator finalist on 600 lines: ``H / H_d = A - g(D) P`` with the data
    the model's own response (``A = 1``) or the model with a resonator (0.05 kg, 30 Hz, 1%)
    on a load path of transfer ``G_kk``."""
    rng = np.random.default_rng(0)
    s = 2j * np.pi * LINES
    P = (rng.standard_normal((s.size, 3, 2)) + 1j * rng.standard_normal((s.size, 3, 2))) * 1e-3
    Gkk = 1.0 / (0.5 * s**2 + 2.0 * s + 4e4)
    A = np.ones((s.size, 3, 2), complex)
    if resonator:
        D = ff._resonator_D(s, np.log([0.05, 2 * np.pi * 30.0, 0.01]))[0]
        A = A + (D / (1.0 + D * Gkk))[:, None, None] * P
    grid = np.array([0.01, 0.03, 0.1])
    t = {"s": s, "grid": grid, "best": 1, "omega": 2 * np.pi * 29.0, "zeta": 0.01,
         "bounds": (1e-4, 1.0)}
    return t, A, P, Gkk


@pytest.mark.parametrize("resonator", [False, True])
def test_finalist_fit_on_all_lines_unless_vanished(monkeypatch, resonator):
    """Data without a resonator: the first fit (every 3rd line) drives the mass onto its
    lower bound and no fit on all the lines follows; data with one: found (mass, frequency
    and damping to 1e-4) by the fit on all the lines within FINAL_NFEV evaluations."""
    calls = []
    _spy(monkeypatch, calls)
    J, m, w, z = ff._fit_resonator(*_finalist(resonator))
    assert calls[0][0] == 200
    if not resonator:
        assert calls == [(200, calls[0][1], True)] and m == pytest.approx(1e-4, rel=0.01)
        assert J < 1e-4                  # what a 0.1 g resonator leaves
        return
    assert [c[0] for c in calls] == [200, LINES.size] and calls[1][1] <= ff.FINAL_NFEV
    assert (m, w / (2 * np.pi), z) == pytest.approx((0.05, 30.0, 0.01), rel=1e-4)
    assert J < 1e-12
