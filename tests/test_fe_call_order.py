"""FEModel results depend only on the model and the request, never on the calls made before
(the modes cache is keyed on the request; rigid-body modes come from a fixed ladder)."""

import numpy as np
import pytest
from test_fe import _free_beam

from sdctrl.fe import FEModel


def _fresh(fe):
    return FEModel(fe.M, fe.K, fe.C, dofs=fe.dofs, nodes=fe.nodes, elements=fe.elements)


def _results(fe, order):
    out = {}
    calls = {
        "modes20": lambda: fe.modes(20),
        "modes8": lambda: fe.modes(8),
        "sparse10": lambda: fe.modes(10, method="sparse"),
        "rigid": fe.rigid_modes,
        "factorise": lambda: fe.factorise() is fe,
        "static": lambda: fe.static_response(["N12.y", "N6.z"]),
        "nmm": lambda: fe.normal_mode_model(["N12.y"], ["N12.y", "N0.z"], 9, static=True),
    }
    for name in order:
        out[name] = calls[name]()
    return out


def _same(a, b):
    if hasattr(a, "Omega"):
        return all(np.array_equal(getattr(a, f), getattr(b, f))
                   for f in ("Omega", "Gamma", "cphi", "phib", "shapes"))
    if isinstance(a, tuple):
        return all(np.array_equal(x, y) for x, y in zip(a, b))
    return np.array_equal(a, b)


@pytest.mark.parametrize("first", [["modes20", "sparse10", "modes8"], ["sparse10"], [],
                                   ["factorise"]])
def test_results_do_not_depend_on_call_order(first):
    fe = _free_beam(12)                                 # 6 rigid-body modes
    order = ["rigid", "static", "nmm", "modes8", "modes20", "sparse10"]
    ref = _results(_fresh(fe), order)
    assert ref["rigid"].shape == (fe.N, 6)
    other = _fresh(fe)
    _results(other, first)                              # warm the caches differently
    got = _results(other, order[::-1])                  # and call in the reverse order
    for name in order:
        assert _same(ref[name], got[name]), name
    # repeated calls return equal, independent copies
    R = other.rigid_modes()
    R[:] = 0.0
    assert np.array_equal(other.rigid_modes(), ref["rigid"])
