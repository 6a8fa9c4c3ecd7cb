"""The registry of storable types: name in files -> :class:`Codec` (internal to storage)."""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, fields, is_dataclass
from typing import Any

__all__ = ["CODECS", "Codec", "codec_of", "register", "register_attrs", "registered"]


@dataclass(frozen=True, eq=False)
class Codec:
    """How one type is stored.

    Parameters
    ----------
    name : str
        Type name written in files (stable forever).
    cls : str
        ``"module:qualname"`` of the class, imported only when needed.
    to_fields : callable
        ``obj -> dict`` of field values (arrays, labels, numbers, nested registered objects).
    from_fields : callable
        ``dict -> obj``; must validate what it is given (files may be hostile) and raise
        ``ValueError``/``TypeError`` on anything wrong.
    kinds : mapping of str to str, optional
        Allowed numpy dtype kinds (``"f"``, ``"c"``, ``"b"``...) of array fields; an array in
        another dtype is refused on load.
    lenient : tuple of str, optional
        Fields (diagnostic dicts) whose unstorable entries are dropped with a warning rather
        than refused.
    """

    name: str
    cls: str
    to_fields: Callable[[Any], dict]
    from_fields: Callable[[dict], Any]
    kinds: Mapping[str, str] = field(default_factory=dict)
    lenient: tuple[str, ...] = ("info",)

    def resolve(self, import_: bool = True) -> type | None:
        """The class, or None when its module is not imported and ``import_`` is False.

        Parameters
        ----------
        import_ : bool
            Import the class's module when needed.

        Returns
        -------
        type or None
        """
        module, _, qualname = self.cls.partition(":")
        if not import_ and module not in sys.modules:
            return None
        obj = importlib.import_module(module)
        for part in qualname.split("."):
            obj = getattr(obj, part)
        return obj

    def __reduce__(self):
        # pickled by name, like a function (its to_fields/from_fields are closures): the
        # unpickling process imports sdctrl.storage, which registers the built-in codecs
        return (_registered_codec, (self.name,))


CODECS: dict[str, Codec] = {}


def _registered_codec(name: str) -> Codec:
    """The codec registered under ``name`` (how a pickled :class:`Codec` comes back)."""
    if name not in CODECS:
        raise ValueError(f"codec {name!r} is not registered in this process: register it "
                         "before unpickling objects that refer to it")
    return CODECS[name]


def register(codec: Codec) -> Codec:
    """Add a type to the registry (replacing an entry of the same name).

    Parameters
    ----------
    codec : Codec
        The type's codec.

    Returns
    -------
    Codec
    """
    if not isinstance(codec, Codec):
        raise TypeError(f"codec must be a storage.Codec, got {type(codec).__name__}")
    CODECS[codec.name] = codec
    return codec


def register_attrs(name: str, cls: str, attrs: tuple[str, ...] | None = None,
                   kinds: Mapping[str, str] | None = None,
                   build: Callable[..., Any] | None = None,
                   lenient: tuple[str, ...] = ("info",)) -> Codec:
    """Register a type whose constructor takes its attributes as keyword arguments.

    Parameters
    ----------
    name : str
        Type name written in files.
    cls : str
        ``"module:qualname"`` of the class.
    attrs : tuple of str, optional
        Attribute names; default the dataclass's ``init`` fields.
    kinds : mapping of str to str, optional
        Allowed dtype kinds of array fields.
    build : callable, optional
        ``build(**fields) -> obj``; default the class itself (whose constructor validates).
    lenient : tuple of str
        Diagnostic fields whose unstorable entries are dropped with a warning.

    Returns
    -------
    Codec
    """
    def names(obj) -> tuple[str, ...]:
        if attrs is not None:
            return attrs
        return tuple(f.name for f in fields(obj) if f.init)

    def to_fields(obj) -> dict:
        return {k: getattr(obj, k) for k in names(obj)}

    def from_fields(values: dict):
        klass = codec.resolve()
        allowed = names(klass) if attrs is None and is_dataclass(klass) else attrs
        unknown = sorted(set(values) - set(allowed or values))
        if unknown:
            raise ValueError(f"unknown field(s) {unknown} for {name} (written by a newer "
                             "sdctrl?)")
        return (build or klass)(**values)

    codec = Codec(name, cls, to_fields, from_fields, dict(kinds or {}), tuple(lenient))
    return register(codec)


def registered() -> tuple[str, ...]:
    """Names of the storable types.

    Returns
    -------
    tuple of str
    """
    return tuple(CODECS)


def codec_of(obj) -> Codec | None:
    """The codec of ``obj``'s exact type (subclasses are not matched), or None.

    Parameters
    ----------
    obj : object
        Anything.

    Returns
    -------
    Codec or None
    """
    for codec in CODECS.values():
        try:
            cls = codec.resolve(import_=False)
        except (ImportError, AttributeError):
            continue
        if cls is not None and type(obj) is cls:
            return codec
    return None
