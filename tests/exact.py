"""Exact equality of saved and loaded objects (shared by the storage and mutation tests)."""

import dataclasses
from types import MappingProxyType

import numpy as np
import scipy.sparse as sp

import sdctrl as sd

_FRF_ATTRS = ("freq", "H", "quantity", "sensors", "actuators", "collocated", "coherence", "units")
_FE_ATTRS = ("M", "K", "C", "dofs", "nodes", "elements", "assembly")


def assert_same(a, b, where="obj"):
    """Exact equality: same types, arrays bit for bit with dtype and shape, same labels/info."""
    assert type(a) is type(b), f"{where}: {type(a).__name__} != {type(b).__name__}"
    if isinstance(a, np.ndarray | np.generic):
        assert (a.dtype, a.shape) == (b.dtype, b.shape), where
        assert np.asarray(a).tobytes() == np.asarray(b).tobytes(), where
    elif sp.issparse(a):
        assert a.format == b.format and a.shape == b.shape, where
        for k in ("data", "indices", "indptr"):
            assert_same(getattr(a, k), getattr(b, k), f"{where}.{k}")
    elif isinstance(a, float):
        assert a.hex() == b.hex(), f"{where}: {a!r} != {b!r}"
    elif isinstance(a, complex):
        assert_same(a.real, b.real, where)
        assert_same(a.imag, b.imag, where)
    elif isinstance(a, dict | MappingProxyType):
        assert list(a) == list(b), f"{where}: keys {list(a)} != {list(b)}"
        for k in a:
            assert_same(a[k], b[k], f"{where}[{k!r}]")
    elif isinstance(a, list | tuple):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b)):
            assert_same(x, y, f"{where}[{i}]")
    elif dataclasses.is_dataclass(a):
        for f in dataclasses.fields(a):
            assert_same(getattr(a, f.name), getattr(b, f.name), f"{where}.{f.name}")
    elif isinstance(a, sd.FRF | sd.FEModel):
        for k in _FRF_ATTRS if isinstance(a, sd.FRF) else _FE_ATTRS:
            assert_same(getattr(a, k), getattr(b, k), f"{where}.{k}")
    else:
        assert a == b, f"{where}: {a!r} != {b!r}"
