"""Issue 23's acceptance on the family's two truss members (the built-in truss tested over
8-60 Hz, and over 20-60 Hz where six suspension and plate modes lie below the band: the
shape of a 33 x 6, 20-60 Hz test), with the places and sizes chosen by the family's rules
(:func:`test_diagnose_family.case`: the most visible places, a 0.5% added damping ratio, a
2% frequency shift by a mass, 3% by a spring, a tenth of a period's delay, the second
in-band mode removed), not the truss examples of ``tests/test_diagnose.py``.  In its own
file so that it runs beside ``test_diagnose_family.py``.

Measured (the first runs of these checks): every kind found at its place on both members,
noise-free and at 1%.  The missing mode on the truss (12.66 Hz, 0.056 Hz wide on 0.26 Hz
lines) left 1.41e-4 at 1% noise (1.41 x the noise) while its own fit stayed on its window:
its tail at the antiresonances near 32 Hz was not fitted; with its residue refitted on
every line (``fit_free_mode``'s second pass), 1.0e-4.  Two effects (the rules put the mass
and one end of the dashpot on the same node, N46): both found at their places, the error
left the noise plus the noise-free diagnosis's own floor (4.1e-5 truss, 5.2e-5 truss_high),
the dashpot biased by 0.7-1.2%, 17-28 of its noise's std at 1%: its std from the sensors'
scatter (:mod:`sdctrl._lib.sensor_scatter`) covers it (the last test below).  That
bias is the test data's, not the diagnosis's: the data are a reduction of the perturbed
structure on its own modes, the model's corrections a reduction on the nominal modes, and
the two truncations differ at the shared node.  Against the full model's response (with the
nominal reduction carrying the dashpots' load paths) the same two effects come out at -0.12%
(mass) and -0.15% (dashpot): :mod:`test_diagnose_exact_data`.
"""

from __future__ import annotations

import pytest

from test_diagnose_family import KINDS, case, check_one_effect, diagnosis

TRUSSES = ("truss", "truss_high")


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("name", TRUSSES)
def test_one_effect_on_the_trusses(name, kind):
    """Each effect, noise-free (3%, error / 30) and at 1% noise (10%, the truth within 3
    std, error down to the noise level): the family test's checks."""
    check_one_effect(name, kind)


#: noise-free relative error of the dashpot when the mass shares its node (N46): locked
DASHPOT_BIAS = {"truss": 0.0067, "truss_high": 0.0117}


def _sizes(d, cs):
    got = {e.kind: e for e in d.effects}
    assert set(got) >= {"mass_change", "added_damper"}
    out = {}
    for kind, where, size in cs:
        e = got[kind]
        assert e.location == where
        key = "dm" if kind == "mass_change" else "c"
        out[kind] = (e.parameters[key] / size - 1, e.std[key] / size)
    return out


@pytest.mark.parametrize("name", TRUSSES)
def test_two_effects_on_the_trusses(name):
    """A mass at one node and a dashpot between it and another (the family's rules pick N46
    for both: the mass at N46, the dashpot N8-N46) in one call: both found at their places,
    sizes within 3% noise-free and 10% at 1%, the mass's truth within 3 std at 1%; the error
    left noise-free below 6e-5 and at 1% the noise plus that floor.  The dashpot's size is
    biased by the shared node, noise-free: +0.67% (truss), +1.17% (truss_high), locked here;
    at 1% that bias is 17-28 of its noise's std, within 3 of its std (the test below)."""
    cs = (case(name, "mass_change", 1), case(name, "added_damper", 0))
    assert cs[0][1] in cs[1][1]                                  # the shared node
    clean = diagnosis(name, cs, 0.0, max_effects=3)
    noisy = diagnosis(name, cs, 0.01, max_effects=3)
    rc, rn = _sizes(clean, cs), _sizes(noisy, cs)
    assert abs(rc["mass_change"][0]) <= 0.03 and abs(rn["mass_change"][0]) <= 0.10
    assert abs(rn["mass_change"][0]) <= 3 * rn["mass_change"][1] + abs(rc["mass_change"][0])
    assert 0 < rc["added_damper"][0] <= 1.5 * DASHPOT_BIAS[name]
    assert abs(rn["added_damper"][0] - rc["added_damper"][0]) <= 3 * rn["added_damper"][1]
    assert clean.error_after <= min(clean.error_before / 30, 6e-5)
    assert noisy.error_after <= 1.1e-4 + clean.error_after


#: the dashpot's standard deviation at 1% noise (relative), from the sensors' scatter: locked
DASHPOT_STD = {"truss": 0.0130, "truss_high": 0.0198}


@pytest.mark.parametrize("name", TRUSSES)
def test_two_effects_sharing_a_node_truth_within_three_std(name):
    """Issue 23's criterion with the shared node's bias: the dashpot's truth within 3 std of
    its fitted size at 1% noise.  The noise alone gives it 0.036% (truss), 0.039%
    (truss_high), 17-28 times less than its bias; the sensors' leave-one-out scatter
    (:mod:`sdctrl._lib.sensor_scatter`) measures that model error from the data:
    1.30% and 1.98%, about twice the bias.  The mass, unbiased, keeps a small std (0.018%
    and 0.031% of its 0.128 kg)."""
    cs = (case(name, "mass_change", 1), case(name, "added_damper", 0))
    rn = _sizes(diagnosis(name, cs, 0.01, max_effects=3), cs)
    assert abs(rn["added_damper"][0]) <= 3 * rn["added_damper"][1]
    assert rn["added_damper"][1] == pytest.approx(DASHPOT_STD[name], rel=0.1)
    assert abs(rn["mass_change"][0]) <= 3 * rn["mass_change"][1] < 0.002
