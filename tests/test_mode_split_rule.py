"""Which poles stay residual when properness cannot be enforced on the whole set (3.3, 3.54):
the fewest poles are left out, and of the removals of that many poles that allow it, the one
whose kept modes need the smallest correction (``delta_radius``).

The rule's logic is checked on a table of outcomes (an ``attempt`` that succeeds on given
sets with a given ``delta_radius``), so that the tests state it exactly.  Where it decides
a prediction (a close trio tested with two collocated shakers on a held-out structure at 1%
noise, figures in the change's closing note): the removal with the smallest correction kept
the modes whose ``cphi`` is nearest the truth on each of three test variants, and the
untested shaker's prediction rose 5.1x -> 10.8x and 8.5x -> 17.9x better than the wrong FE.
"""

import warnings
from types import SimpleNamespace

import numpy as np
import pytest

from sdctrl.identification._mode_split import LEAVE_OUT_MAX, split_modes


def _attempt_from(table, single=None):
    """``attempt(idx)``: a model whose ``properness`` holds ``delta_radius`` (and the
    single-pole ``properness_before``) when ``frozenset(idx)`` is in ``table``, else
    ``ValueError``; every single pole succeeds (with ``single[j]`` as its properness)."""
    calls = []

    def attempt(idx):
        key = frozenset(int(i) for i in idx)
        calls.append(key)
        if len(key) == 1:
            j = next(iter(key))
            before = 0.01 * (j + 1) if single is None else single[j]
            return SimpleNamespace(properness=SimpleNamespace(properness_before=before,
                                                              delta_radius=0.0))
        if key not in table:
            raise ValueError("cm: the identified mass is not positive definite")
        return SimpleNamespace(properness=SimpleNamespace(delta_radius=table[key]))

    return attempt, calls


def test_the_whole_set_is_kept_when_it_can_be_made_proper():
    attempt, _ = _attempt_from({frozenset(range(5)): 0.3})
    sel, reasons = split_modes(np.arange(5), 10, attempt)
    assert sel.tolist() == list(range(5)) and reasons == {}


def test_one_pole_left_out_the_smallest_correction_among_those_that_allow_it():
    """Poles 1, 3 and 4 each allow the rest; 3 needs the smallest correction. The former
    rule took the least proper single mode first (pole 4 here)."""
    full = frozenset(range(5))
    table = {full - {1}: 0.40, full - {3}: 0.12, full - {4}: 0.25}
    attempt, _ = _attempt_from(table)
    sel, reasons = split_modes(np.arange(5), 10, attempt)
    assert sel.tolist() == [0, 1, 2, 4]
    assert list(reasons) == [3]
    assert "properness cannot be enforced with the other modes" in reasons[3]
    assert "smallest correction" in reasons[3]


def test_two_poles_left_out_only_when_no_single_removal_allows_it():
    """No single removal works; of the pairs that do, (2, 5) needs the smallest correction
    (a close trio 2, 5, 6: which two of it go is decided by the correction, not by the
    order of the single-mode properness)."""
    full = frozenset(range(7))
    table = {full - {5, 6}: 0.37, full - {2, 5}: 0.14, full - {0, 5}: 0.30,
             full - {2, 6}: 0.16}
    single = {0: 0.005, 1: 0.001, 2: 0.27, 3: 0.002, 4: 0.38, 5: 0.58, 6: 0.17}
    attempt, calls = _attempt_from(table, single)
    sel, reasons = split_modes(np.arange(7), 10, attempt)
    assert sel.tolist() == [0, 1, 3, 4, 6]
    assert sorted(reasons) == [2, 5]
    assert all("2-pole removals" in reasons[j] for j in (2, 5))
    # every single and every pair of the 7 was tried, nothing beyond
    tried = {k for k in calls if len(k) >= 5}
    assert len(tried) == 1 + 7 + 21


def test_beyond_the_removals_tried_the_poles_are_added_one_at_a_time():
    """When no removal of up to ``LEAVE_OUT_MAX`` poles allows the rest, the poles are added
    one at a time, most nearly proper first, each kept when the set stays proper."""
    assert LEAVE_OUT_MAX == 2
    single = {j: 0.01 * (j + 1) for j in range(6)}               # 0 the most nearly proper
    table = {frozenset({0, 1}): 0.1, frozenset({0, 1, 3}): 0.2}
    attempt, _ = _attempt_from(table, single)
    sel, reasons = split_modes(np.arange(6), 10, attempt)
    assert sel.tolist() == [0, 1, 3]
    assert sorted(reasons) == [2, 4, 5]


@pytest.mark.parametrize("ns", [3, 4])
def test_at_most_ns_modes_before_any_removal(ns):
    """Fewer sensors than poles: the ``ns`` most nearly proper poles are the candidates
    (3.46); the others are named with that reason and never tried together."""
    single = {0: 0.5, 1: 0.1, 2: 0.3, 3: 0.2, 4: 0.4}
    keep = sorted(single, key=single.get)[:ns]
    attempt, calls = _attempt_from({frozenset(keep): 0.2}, single)
    sel, reasons = split_modes(np.arange(5), ns, attempt)
    assert sel.tolist() == sorted(keep)
    assert all("fewer sensors" in reasons[j] for j in set(range(5)) - set(keep))
    assert all(k <= set(keep) for k in calls if len(k) > 1)


def _cphi_error(model, fe, sensors):
    """Mean over the model's modes of ``||cphi_j - c phi_j|| / ||c phi_j||`` against the FE
    mode nearest in frequency (mass-normalised, sign aligned)."""
    f, phi = fe.modes(60)
    Ct = fe.point(sensors).T @ phi
    out = []
    for j in range(model.n):
        t = int(np.argmin(np.abs(f - model.frequency[j])))
        c = model.cphi[:, j]
        s = np.sign(c @ Ct[:, t]) or 1.0
        out.append(np.linalg.norm(s * c - Ct[:, t]) / np.linalg.norm(Ct[:, t]))
    return float(np.mean(out))


#: the truss at 1% noise (seed 2) tested with one shaker: the pole the rule leaves out, the
#: kept modes' mean ``cphi`` error against the truth by the rule, by the former rule (the
#: least proper single mode, 15.87 Hz, of the close pair 15.79 / 15.87 Hz), and by the best
#: single removal that allows the rest
TRUSS_ONE_SHAKER = {"N33.x": (54.72, 0.1302, 0.3288, 0.1302),
                    "N41.y": (9.52, 0.3505, 0.5044, 0.3442)}


@pytest.mark.parametrize("shaker", sorted(TRUSS_ONE_SHAKER))
def test_truss_one_shaker_keeps_the_modes_nearest_the_truth(shaker):
    """Measured against the truth on a family member: with one shaker the truss's close pair
    cannot be made proper with the other modes; of the single poles whose removal allows it,
    the smallest correction keeps modes whose ``cphi`` is nearest the FE's (N33.x) or within
    2% of the nearest (N41.y), where the former rule's were 2.5x / 1.4x further."""
    import sdctrl as sd
    from sdctrl.identification._collocated_scaling import unscaled_poles
    from sdctrl.identification._mode_split import _try
    from sdctrl.identification._proper import _transform

    pole, err, former, best = TRUSS_ONE_SHAKER[shaker]
    st = sd.testbeds.structure("truss")
    fe, sensors = st.fe(), list(st.sensors)
    frf = st.frf(n=400, noise=0.01, seed=2).select(actuators=[shaker])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cm = sd.identify(frf, progress=False)
        nm = sd.normal_modes(cm, std=False)
        pairs, cand = tuple(cm.collocated), np.flatnonzero(cm.in_band)
        free = unscaled_poles(cm, pairs, cand)
    left = [f for f, why in zip(nm.residual.frequency, nm.residual.reasons)
            if "properness cannot be enforced" in why]
    assert np.round(left, 2).tolist() == [pole]
    assert _cphi_error(nm, fe, sensors) == pytest.approx(err, rel=0.02)
    options = {}
    for j in cand:
        m = _try(lambda idx: _transform(cm, idx, pairs, 1e-13, 50, False, free=free),
                 [i for i in cand if i != j])[0]
        if m is not None:
            options[round(float(cm.frequency[j]), 2)] = _cphi_error(m, fe, sensors)
    assert min(options.values()) == pytest.approx(best, rel=0.02)
    assert options[15.87] == pytest.approx(former, rel=0.02)
    assert _cphi_error(nm, fe, sensors) <= 1.02 * min(options.values()) < 0.8 * former
