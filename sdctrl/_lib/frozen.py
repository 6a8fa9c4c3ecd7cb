"""Pickling of sdctrl's immutable models and results (internal).

Models and results travel to other processes (``concurrent.futures.ProcessPoolExecutor``,
Dask workers) by ``pickle``.  Two things of theirs do not survive a plain pickle round trip:

- read-only numpy arrays come back writeable (numpy pickles the data, not the flag), which
  would make an unpickled model mutable;
- read-only mappings (``types.MappingProxyType``) cannot be pickled at all, nor can cached
  factorisations (``scipy.sparse.linalg.SuperLU``).

:class:`FrozenState` is the mixin that handles both: ``__getstate__`` encodes the read-only
arrays and mappings found in the attributes (also inside dicts, lists and tuples) and leaves
out the transient attributes a class names (its caches: rebuilt on first use);
``__setstate__`` sets the attributes of the fresh instance with ``object.__setattr__``
(nothing public mutates a model), read-only again.  The same state serves ``copy.copy`` and
``copy.deepcopy``.
"""

from __future__ import annotations

from types import MappingProxyType

import numpy as np

__all__ = ["FrozenState", "attribute_names"]


class _ReadOnly:
    """A read-only array in a pickled state."""

    __slots__ = ("a",)

    def __init__(self, a):
        self.a = a


class _Proxy:
    """A read-only mapping in a pickled state (its items encoded)."""

    __slots__ = ("d",)

    def __init__(self, d):
        self.d = d


def _encode(v):
    if isinstance(v, np.ndarray):
        return v if v.flags.writeable else _ReadOnly(v)
    if isinstance(v, MappingProxyType):
        return _Proxy({k: _encode(x) for k, x in v.items()})
    t = type(v)
    if t is dict:
        return {k: _encode(x) for k, x in v.items()}
    if t is list or t is tuple:
        if v and all(type(x) is str for x in v):      # labels: nothing to encode
            return v
        return t(_encode(x) for x in v)
    return v


def _decode(v):
    if isinstance(v, _ReadOnly):
        a = v.a
        if a.flags.writeable:
            a.setflags(write=False)
        return a
    if isinstance(v, _Proxy):
        return MappingProxyType({k: _decode(x) for k, x in v.d.items()})
    t = type(v)
    if t is dict:
        return {k: _decode(x) for k, x in v.items()}
    if t is list or t is tuple:
        if v and all(type(x) is str for x in v):
            return v
        return t(_decode(x) for x in v)
    return v


def attribute_names(obj) -> list:
    """Names of the instance attributes of ``obj`` (``__dict__`` and every ``__slots__``)."""
    names = list(getattr(obj, "__dict__", ()))
    for klass in type(obj).__mro__:
        slots = klass.__dict__.get("__slots__", ())
        names += [slots] if isinstance(slots, str) else list(slots)
    return [n for n in dict.fromkeys(names) if n not in ("__dict__", "__weakref__")]


class FrozenState:
    """Mixin: pickle (and copy) support for immutable models and results.

    A class lists in ``_transient`` the attributes (caches) that are not pickled; each
    comes back as an empty dict and is rebuilt on first use.  By default that is ``_cache``
    (where models keep their factorisations), when the class has one.
    """

    __slots__ = ()
    _transient: tuple = ("_cache",)

    def __getstate__(self) -> dict:
        """The attributes, read-only arrays and mappings marked, transient ones left out.

        Returns
        -------
        dict
            Attribute name -> encoded value.
        """
        skip = self._transient
        return {n: _encode(getattr(self, n)) for n in attribute_names(self)
                if n not in skip and hasattr(self, n)}

    def __setstate__(self, state: dict) -> None:
        """Set the attributes of a fresh instance (read-only again), transient ones empty.

        Parameters
        ----------
        state : dict
            From :meth:`__getstate__`.
        """
        for n, v in state.items():
            object.__setattr__(self, n, _decode(v))
        for n in self._transient:
            if n in attribute_names(self):
                object.__setattr__(self, n, {})
