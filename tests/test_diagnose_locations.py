"""``diagnose(locations=...)``: the caller's own candidate locations (issue 27: a scan that
grows with the locations listed, not with the FE model).  Listing every default location
builds exactly the default candidates; listing the true places among decoys finds the same
effects with the same sizes and standard deviations as the full scan, on every member of the
family; an effect is never placed where the list does not allow; bad lists are refused with
the argument named and the caller's list is left as it was."""

from __future__ import annotations

import numpy as np
import pytest

import sdctrl as sd
from sdctrl.diagnosis._candidates import candidate_groups
from test_diagnose_family import MEMBERS, case, diagnosis, member, noisy, planted

TWO = ("mass_change", "added_damper")


def _default_locations(fe):
    """Every location the default scan covers, elements first, in its own order."""
    _, groups, _ = candidate_groups(fe)
    return list(groups["pairs"].locations) + list(groups["nodes"].locations)


@pytest.mark.parametrize("name", MEMBERS)
def test_every_default_location_listed_gives_the_default_candidates(name):
    """The groups (locations, DOF indices, load shapes) and the element count are the
    default's, bit for bit: one code path for both."""
    fe = member(name)[1]
    d_idx, d_groups, d_nel = candidate_groups(fe)
    locs = tuple(_default_locations(fe))
    l_idx, l_groups, l_nel = candidate_groups(fe, None, locs)
    assert l_nel == d_nel and np.array_equal(l_idx, d_idx)
    assert set(l_groups) == set(d_groups)
    for key, g in d_groups.items():
        h = l_groups[key]
        assert h.locations == g.locations, key
        assert np.array_equal(h.idx, g.idx) and np.array_equal(h.val, g.val), key


def _decoys(fe, cs, step=4):
    """The true places of ``cs`` among every ``step``-th default pair and node."""
    locs = _default_locations(fe)[::step]
    return [c[1] for c in cs] + [x for x in locs if x not in {c[1] for c in cs}]


@pytest.mark.parametrize("name", MEMBERS)
def test_listed_true_places_among_decoys_give_the_full_scans_effects(name):
    """A mass and a dashpot planted (1% noise): with a quarter of the default locations
    listed, the true two among them, both effects are found at their places with the full
    scan's sizes and standard deviations (the joint refit of the same effects on the same
    data), and the scan counts only the listed locations."""
    cs = (case(name, "mass_change", 1), case(name, "added_damper", 0))
    full = diagnosis(name, cs, 0.01, max_effects=3)
    model, data = planted(name, cs)
    fe = member(name)[1]
    locs = _decoys(fe, cs)
    d = sd.diagnose(model, noisy(data, 0.01, 0), fe, locations=locs, max_effects=3,
                    progress=False)
    got, ref = ({e.kind: e for e in x.effects if e.kind in TWO} for x in (d, full))
    assert set(got) == set(ref) == set(TWO)
    for kind, where, _size in cs:
        assert got[kind].location == ref[kind].location == where
        for key, v in ref[kind].parameters.items():
            assert got[kind].parameters[key] == pytest.approx(v, rel=1e-6)
            assert got[kind].std[key] == pytest.approx(ref[kind].std[key], rel=1e-3)
    n_pairs = sum(not isinstance(x, str) for x in locs)
    assert d.scanned["pairs"] == n_pairs
    assert d.scanned["nodes"] == len(locs) - n_pairs
    assert d.scanned["dofs"] == 3 * (len(locs) - n_pairs)


@pytest.mark.parametrize("name", ["truss", "plate"])
def test_nothing_placed_outside_the_list(name):
    """The planted mass's node is not listed (its neighbours' elements are): no physical
    effect is reported anywhere but at a listed location."""
    c = case(name, "mass_change", 1)
    model, data = planted(name, (c,))
    fe = member(name)[1]
    locs = [x for x in _default_locations(fe)
            if x != c[1] and (isinstance(x, str) or c[1] not in x)][::2]
    d = sd.diagnose(model, noisy(data, 0.01, 1), fe, locations=locs, max_effects=2,
                    progress=False)
    allowed = {x if isinstance(x, str) else frozenset(x) for x in locs}
    for e in d.effects:
        if e.kind in ("mass_change", "added_damper", "stiffness_change"):
            key = e.location if isinstance(e.location, str) else frozenset(e.location)
            assert key in allowed, (e.kind, e.location)
        assert e.location != c[1]


def test_bad_locations_are_refused_and_the_list_is_not_modified():
    name = "truss"
    model, data = planted(name, (case(name, "mass_change", 1),))
    fe = member(name)[1]
    node = next(iter(fe.nodes))
    for bad, err, words in (
            (["nowhere"], ValueError, "locations[0]"), ([node, (node, node)], ValueError,
                                                        "locations[1]"),
            ([3.0], TypeError, "locations[0]"), (node, TypeError, "locations"),
            ([], ValueError, "empty"), ([(node, "nowhere")], ValueError, "nowhere")):
        with pytest.raises(err, match=words.replace("[", r"\[").replace("]", r"\]")):
            sd.diagnose(model, data, fe, locations=bad)
    with pytest.raises(ValueError, match="reach"):
        sd.diagnose(model, data, fe, locations=[node], reach=1.0)
    with pytest.raises(ValueError, match="fe"):
        sd.diagnose(model, data, locations=[node])
    locs = [node, [node, list(fe.nodes)[1]], node]
    before = [list(x) if isinstance(x, list) else x for x in locs]
    d = sd.diagnose(model, data, fe, locations=locs, max_effects=1, progress=False)
    assert locs == before
    assert d.scanned == {"pairs": 1, "nodes": 1, "dofs": 3}
    assert "scanned (the caller's list): 1 pairs, 1 nodes, 3 dofs" in d.report()


@pytest.mark.parametrize("name", ["ladder", "plate"])
def test_one_pair_listed_alone(name):
    """Only the planted dashpot's pair listed (no node, so the node families are empty): the
    dashpot found there with the full scan's size (this crashed in the exact re-screen,
    which stacked the empty families' static corrections)."""
    c = case(name, "added_damper", 0)
    full = diagnosis(name, (c,), max_effects=2)
    model, data = planted(name, (c,))
    d = sd.diagnose(model, data, member(name)[1], locations=[c[1]], max_effects=1,
                    progress=False)
    assert d.scanned == {"pairs": 1, "nodes": 0, "dofs": 0}
    e, ref = d.effects[0], full.effects[0]
    assert (e.kind, e.location) == (ref.kind, ref.location) == ("added_damper", c[1])
    assert e.parameters["c"] == pytest.approx(ref.parameters["c"], rel=1e-6)


def _lengths(fe):
    return np.array([np.linalg.norm(np.subtract(fe.nodes[a], fe.nodes[b]))
                     for a, b in fe.elements])


@pytest.mark.parametrize("name", [*sd.testbeds.family(), "lattice"])
def test_default_reach_is_the_meshs_scale(name):
    """The default ``reach``: 1.5 times the longest element no longer than 4 times the median
    one.  On the family it is 1.5 times the longest element (the same candidates as before the
    rule); on the lattice plate, whose two elements across the plate (0.80 m against 0.10 m)
    made every pair of its 342 nodes a candidate (46,817 pairs at 972 DOFs), the pairs stay
    within 1.5 times its bars' length (5,752), as an explicit ``reach`` gives them."""
    from sdctrl.diagnosis._candidates import OUTLIER_LENGTH, default_reach

    fe = sd.testbeds.lattice(1000).fe() if name == "lattice" else member(name)[1]
    L = _lengths(fe)
    r = default_reach(L)
    pairs = candidate_groups(fe)[1]["pairs"].locations
    assert pairs == candidate_groups(fe, r)[1]["pairs"].locations
    far = max(np.linalg.norm(np.subtract(fe.nodes[a], fe.nodes[b])) for a, b in pairs)
    if name == "lattice":
        assert L.max() > OUTLIER_LENGTH * np.median(L)
        assert r == pytest.approx(1.5 * np.sort(L)[-3]) and far <= max(r, L.max())
        assert len(pairs) == 5752 and len(fe.nodes) == 342
    else:
        assert r == 1.5 * L.max()
        assert pairs == candidate_groups(fe, 1.5 * L.max())[1]["pairs"].locations
