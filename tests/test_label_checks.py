"""``check_labels`` remembers the big label tuples it checked (a model rebuilt in a loop with
the FE model's DOF labels -- a diagnosis's joint refit at 10^5 DOFs -- is not checked anew)
and still refuses every wrong tuple, from any thread."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import pytest

from sdctrl._lib.validate import check_labels


def test_checked_label_tuples_are_remembered_and_wrong_ones_still_refused():
    tuples = [tuple(f"n{k}.{i}" for i in range(1500)) for k in range(12)]
    with ThreadPoolExecutor(4) as pool:
        outs = list(pool.map(lambda t: check_labels(t, 1500, "dofs", "q"), tuples * 3))
    for t, out in zip(tuples * 3, outs):
        assert out == t and check_labels(out, 1500, "dofs", "q") == t
    last = check_labels(tuples[0], 1500, "dofs", "q")
    assert check_labels(last, 1500, "dofs", "q") is last
    with pytest.raises(ValueError, match="1499 labels"):
        check_labels(last, 1499, "dofs", "q")
    with pytest.raises(ValueError, match="unique"):
        check_labels(last[:-1] + (last[0],), 1500, "dofs", "q")
    with pytest.raises(TypeError, match="strings"):
        check_labels(last[:-1] + (3,), 1500, "dofs", "q")
    with pytest.raises(TypeError, match="sequence"):
        check_labels(set(last), 1500, "dofs", "q")
