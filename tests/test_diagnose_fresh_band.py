"""Diagnosis on bands the family tests do not use: the plate over 25-58 Hz, the truss over
12-45 Hz (issue 23).

:mod:`test_diagnose_family` runs every member over its own band.  Over 25-58 Hz the plate's
first added dashpot (G1_3-G4_0) and first spring (G1_3-G3_0) of the family's recipe were
reported at another element (G2_3-G4_0, c 29.6 for 16.2; G0_3-G3_0 with a residual term
and an invented missing mode): the screen ranks the candidates with their local flexibility
projected on the test's static corrections, a bias of each candidate's own, and the right
elements came 23rd and 22nd of 182, out of the 16 screened again exactly.  Screening at
least one batch of candidates exactly (``EXACT_MIN``, :mod:`sdctrl.diagnosis._exact_screen`:
here all 182) finds both; the second spring (G1_0-G3_3) then needs its cost refined in size
between grid points (:func:`~sdctrl.diagnosis._exact_screen.rescreen`).  (Mirror elements
tie in the recipe's ranking, ``test_diagnose_family._ranked``: they rank in list order, so
the first of each kind is now G1_0-G4_3 and G1_0-G3_3, the mirrors above.)  All four pass the
family's checks (right kind, exactly the true element, size within 3% noise-free / 10% at
1% and within 3 std).

Over 12-45 Hz the truss's dashpot N8-N46 was found (c 6.39 for 6.38), then a second dashpot
at N5-N7 was accepted: c = 7813 +- 4871 noise-free, a rigid link absorbing the recipe's own
reduction error (2.5e-5 left after the right dashpot), which biased the first by 0.6%.  An
effect's size must now be determined: more than 3 standard deviations from zero
(``undetermined`` in :mod:`sdctrl.diagnosis._effect_statistics`).
"""

import dataclasses
import functools

import numpy as np
import pytest

import sdctrl as sd
import test_diagnose_family as T

BANDS = {"plate": (25.0, 58.0), "truss": (12.0, 45.0)}


@functools.cache
def _member(name):
    s = dataclasses.replace(sd.testbeds.structure(name), band=BANDS[name])
    fe = s.fe()
    f, _ = fe.modes(min(80, fe.N - 1))
    return s, fe, int(np.sum(f < 5 * s.band[1])), np.linspace(*s.band, T.N_LINES)


@pytest.fixture
def fresh_band(monkeypatch):
    """The family's recipe (nominal, planted effect, checks) over :data:`BANDS`."""
    _clear_caches()                  # results cached per member name belong to another band
    monkeypatch.setattr(T, "member", _member)
    yield
    _clear_caches()


def _clear_caches():
    for f in vars(T).values():
        if callable(getattr(f, "cache_clear", None)):
            f.cache_clear()


@pytest.mark.parametrize("kind, rank, where", [
    ("added_damper", 0, ("G1_0", "G4_3")), ("stiffness_change", 0, ("G1_0", "G3_3")),
    ("added_damper", 1, ("G1_3", "G4_0")), ("stiffness_change", 1, ("G1_3", "G3_0"))])
def test_each_element_is_found_on_a_fresh_band(fresh_band, kind, rank, where):
    c = T.case("plate", kind, rank)
    assert T._truth("plate", c)[0] == where
    clean = T.diagnosis("plate", (c,), 0.0)
    noisy = T.diagnosis("plate", (c,), 0.01)
    for d in (clean, noisy):
        print(f"\n{kind}: {d.effects[0].location} {d.effects[0].parameters} "
              f"error {d.error_before:.3g} -> {d.error_after:.3g}")
    assert len(clean.effects) == len(noisy.effects) == 1
    T._check("plate", c, clean.effects[0], 0.03, 0.0)
    T._check("plate", c, noisy.effects[0], 0.10, 0.01, clean.effects[0])
    assert clean.error_after <= 1e-8                             # 5e-12, 6e-10


def test_a_dashpot_driven_to_a_rigid_link_is_not_accepted(fresh_band):
    c = T.case("truss", "added_damper", 0)
    assert T._truth("truss", c)[0] == ("N8", "N46")
    clean = T.diagnosis("truss", (c,), 0.0)
    noisy = T.diagnosis("truss", (c,), 0.01)
    for d in (clean, noisy):
        e = d.effects[0]
        print(f"\n{e.location} {e.parameters} +- {e.std} error {d.error_before:.3g} -> "
              f"{d.error_after:.3g}")
        assert len(d.effects) == 1
        why = [r["reason"] for step in d.steps for r in step["rejected"]]
        assert any("not determined" in r for r in why)        # N5-N7, c 7813 +- 4871
    T._check("truss", c, clean.effects[0], 0.03, 0.0)          # c +0.2%
    T._check("truss", c, noisy.effects[0], 0.10, 0.01, clean.effects[0])
    assert clean.error_after <= 3e-5                           # the recipe's 2.5e-5
