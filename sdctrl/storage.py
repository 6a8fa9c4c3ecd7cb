"""Saving and loading models and results: :func:`save` and :func:`load`.

One ``.npz`` file holds plain arrays and one JSON document (member ``__sdctrl__``, UTF-8 bytes)
that names the type, the format version and every field; nothing is pickled and loading never
executes code (``allow_pickle=False``, readers in :mod:`sdctrl._npz`).  A round trip is exact:
arrays bit for bit with their dtypes, labels, tuples, floats (``nan``/``inf`` included) and the
``info`` dicts.

Values are encoded recursively: ``None``, ``bool``, ``int``, ``str`` and finite ``float`` as JSON;
every other value as a JSON object with one key naming its kind -- ``{"array": member}`` (an
ndarray stored as its own member), ``{"scalar": member}`` (a numpy scalar, stored as a 0-d
array), ``{"float": "nan" | "inf" | "-inf"}``, ``{"complex": [re, im]}``, ``{"tuple": [...]}``,
``{"dict": {...}}`` (string keys), ``{"csr": {...}}`` (a ``scipy.sparse`` matrix, stored in CSR
form) and ``{"object": [type_name, {field: value}]}`` (a registered type).  JSON lists are lists.

What cannot be stored: in an ``info`` dict (diagnostics), a value of another type (a callable, an
exception, a set, an object of an unregistered class) is dropped -- a dict entry is left out, a
list or tuple item becomes ``None`` -- with one warning at :func:`save` naming each.  Subclasses
of ``dict``, ``list`` and ``tuple`` come back as the base type.  Anywhere else (a model's own
fields) an unstorable value is a ``TypeError``.

Registry
--------
Each storable type has a :class:`Codec`: its name in files, the class (imported lazily), a
function giving its fields and a function building it from them (validating them like its
constructor does), and the dtype kinds allowed for its array fields.  A new result type registers
itself with one call, usually::

    register_attrs("UpdateResult", "sdctrl.updating.fit:UpdateResult",
                   kinds={"values_array": "f"})

(fields read from the dataclass; the constructor validates) or, for full control,
``register(Codec(name, cls, to_fields, from_fields, kinds))``.  Names are never reused for another
type: files written today must load tomorrow.
"""

from __future__ import annotations

import importlib
import json
import math
import os
import sys
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, fields, is_dataclass
from typing import Any

import numpy as np

from sdctrl._files import check_path, check_regular
from sdctrl._npz import read_arrays, write_arrays

__all__ = ["FORMAT_VERSION", "Codec", "StorageWarning", "load", "register", "register_attrs",
           "registered", "save"]

#: version of the file layout written by :func:`save`; :func:`load` reads this and older ones
FORMAT_VERSION = 1
_FORMAT = "sdctrl"
_META = "__sdctrl__"
_MAX_DEPTH = 64
_KINDS = "biufcSU"


class StorageWarning(UserWarning):
    """Part of an object (an ``info`` entry) could not be stored and was dropped."""


@dataclass(frozen=True)
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
        """The class, or None when its module is not imported and ``import_`` is False."""
        module, _, qualname = self.cls.partition(":")
        if not import_ and module not in sys.modules:
            return None
        obj = importlib.import_module(module)
        for part in qualname.split("."):
            obj = getattr(obj, part)
        return obj


_CODECS: dict[str, Codec] = {}


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
    _CODECS[codec.name] = codec
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
    return tuple(_CODECS)


def _codec_of(obj) -> Codec | None:
    for codec in _CODECS.values():
        try:
            cls = codec.resolve(import_=False)
        except (ImportError, AttributeError):
            continue
        if cls is not None and type(obj) is cls:
            return codec
    return None


# ------------------------------------------------------------------------------------------
# encoding
# ------------------------------------------------------------------------------------------
class _Unstorable(Exception):
    pass


class _Encoder:
    def __init__(self):
        self.arrays: dict[str, np.ndarray] = {}
        self.dropped: list[str] = []

    def _member(self, arr: np.ndarray) -> str:
        if arr.dtype.kind not in _KINDS or arr.dtype.hasobject or arr.dtype.fields is not None \
                or arr.dtype.itemsize == 0:
            raise _Unstorable(f"an array of dtype {arr.dtype}")
        key = f"a{len(self.arrays)}"
        self.arrays[key] = arr
        return key

    def value(self, v, where: str, lenient: bool, depth: int = 0):
        if depth > _MAX_DEPTH:
            raise _Unstorable("a structure nested too deeply")
        try:
            return self._value(v, where, lenient, depth)
        except _Unstorable as exc:
            if not lenient:
                raise TypeError(f"{where} cannot be stored: {exc}") from None
            self.dropped.append(f"{where} ({exc})")
            return _DROP

    def _value(self, v, where, lenient, depth):
        import scipy.sparse as sp

        if v is None or isinstance(v, bool | str):
            return v
        if isinstance(v, np.ndarray):
            return {"array": self._member(v)}
        if isinstance(v, np.generic):
            return {"scalar": self._member(np.asarray(v))}
        if isinstance(v, int):
            return int(v)
        if isinstance(v, float):
            return float(v) if math.isfinite(v) else {"float": repr(float(v))}
        if isinstance(v, complex):
            return {"complex": [self._value(v.real, where, lenient, depth),
                                self._value(v.imag, where, lenient, depth)]}
        if sp.issparse(v):
            m = sp.csr_matrix(v)
            return {"csr": {"shape": list(m.shape), "data": self._member(m.data),
                            "indices": self._member(m.indices),
                            "indptr": self._member(m.indptr)}}
        codec = _codec_of(v)
        if codec is not None:
            return {"object": [codec.name, self.fields(v, codec, where, depth + 1)]}
        if isinstance(v, Mapping):
            if not all(isinstance(k, str) for k in v):
                raise _Unstorable("a mapping with non-string keys")
            out = {}
            for k, item in v.items():
                enc = self.value(item, f"{where}[{k!r}]", lenient, depth + 1)
                if enc is not _DROP:
                    out[k] = enc
            return {"dict": out}
        if isinstance(v, list | tuple):
            items = [self.value(item, f"{where}[{i}]", lenient, depth + 1)
                     for i, item in enumerate(v)]
            items = [None if item is _DROP else item for item in items]
            return {"tuple": items} if isinstance(v, tuple) else items
        raise _Unstorable(f"a {type(v).__module__}.{type(v).__qualname__}")

    def fields(self, obj, codec: Codec, where: str, depth: int) -> dict:
        out = {}
        for k, v in codec.to_fields(obj).items():
            enc = self.value(v, f"{where}.{k}", k in codec.lenient, depth)
            if enc is not _DROP:
                out[k] = enc
        return out


_DROP = object()


def _npz_path(path: str) -> str:
    return path if path.endswith(".npz") else path + ".npz"


def save(model, path) -> str:
    """Save a model or result to one ``.npz`` file of plain arrays and JSON metadata.

    Every registered type can be saved (:func:`registered`): ``FRF``, ``ComplexModeModel``,
    ``NormalModeModel``, ``HybridModel``, ``FEModel`` (dense or sparse), ``UncertainModel``,
    ``RobustResult``.  Nothing is pickled; ``load(save(model, path))`` gives back the same
    arrays bit for bit, the same labels and ``info``.  Entries of an ``info`` dict that are not
    plain data are dropped with a :class:`StorageWarning` (see the module docstring).  The file
    is written atomically (a failure leaves no partial file and keeps an older one).

    Parameters
    ----------
    model : object
        The object to save.
    path : str or os.PathLike
        Output file; ``.npz`` is appended when missing (as ``numpy.savez`` does).

    Returns
    -------
    str
        The path written.

    Raises
    ------
    TypeError
        ``model`` is not of a registered type, or one of its fields cannot be stored.
    """
    path = _npz_path(check_path(path))
    codec = _codec_of(model)
    if codec is None:
        raise TypeError(f"model must be one of the storable types {sorted(_CODECS)}, got "
                        f"{type(model).__module__}.{type(model).__qualname__}")
    enc = _Encoder()
    root = {"object": [codec.name, enc.fields(model, codec, "model", 0)]}
    if enc.dropped:
        warnings.warn(f"save: {len(enc.dropped)} value(s) not stored (not plain data): "
                      + "; ".join(enc.dropped[:10]) + (" ..." if len(enc.dropped) > 10 else ""),
                      StorageWarning, stacklevel=2)
    meta = {"format": _FORMAT, "version": FORMAT_VERSION, "sdctrl": _version(), "root": root}
    text = json.dumps(meta, allow_nan=False, ensure_ascii=True, separators=(",", ":"))
    arrays = {_META: np.frombuffer(text.encode("ascii"), dtype=np.uint8), **enc.arrays}
    write_arrays(path, arrays)
    return path


def _version() -> str:
    from sdctrl import __version__
    return __version__


# ------------------------------------------------------------------------------------------
# decoding
# ------------------------------------------------------------------------------------------
class _Decoder:
    def __init__(self, arrays: dict[str, np.ndarray]):
        self.arrays = arrays

    def _array(self, key) -> np.ndarray:
        if not isinstance(key, str) or key not in self.arrays or key == _META:
            raise ValueError(f"refers to a missing array member {key!r}")
        return self.arrays[key]

    def value(self, v, depth: int = 0):
        if depth > _MAX_DEPTH:
            raise ValueError("values nested too deeply")
        if v is None or isinstance(v, bool | int | str):
            return v
        if isinstance(v, float):
            return v
        if isinstance(v, list):
            return [self.value(item, depth + 1) for item in v]
        if not isinstance(v, dict) or len(v) != 1:
            raise ValueError(f"malformed value {_short(v)}")
        (tag, x), = v.items()
        handler = getattr(self, f"_tag_{tag}", None)
        if handler is None:
            raise ValueError(f"unknown value kind {tag!r}")
        return handler(x, depth)

    def _tag_array(self, x, depth):
        return self._array(x)

    def _tag_scalar(self, x, depth):
        arr = self._array(x)
        if arr.ndim != 0:
            raise ValueError(f"scalar member {x!r} has shape {arr.shape}")
        return arr[()]

    def _tag_float(self, x, depth):
        if x not in ("nan", "inf", "-inf"):
            raise ValueError(f"malformed float {_short(x)}")
        return float(x)

    def _tag_complex(self, x, depth):
        if not isinstance(x, list) or len(x) != 2:
            raise ValueError(f"malformed complex {_short(x)}")
        re, im = (self.value(p, depth + 1) for p in x)
        if not all(isinstance(p, float | int) and not isinstance(p, bool) for p in (re, im)):
            raise ValueError(f"malformed complex {_short(x)}")
        return complex(re, im)

    def _tag_tuple(self, x, depth):
        if isinstance(x, list):
            return tuple(self.value(item, depth + 1) for item in x)
        raise ValueError(f"malformed tuple {_short(x)}")

    def _tag_dict(self, x, depth):
        if isinstance(x, dict):
            return {k: self.value(item, depth + 1) for k, item in x.items()}
        raise ValueError(f"malformed dict {_short(x)}")

    def _tag_csr(self, x, depth):
        return _csr(x, self._array)

    def _tag_object(self, x, depth):
        if not (isinstance(x, list) and len(x) == 2 and isinstance(x[0], str)
                and isinstance(x[1], dict)):
            raise ValueError(f"malformed object {_short(x)}")
        name, raw = x
        codec = _CODECS.get(name)
        if codec is None:
            raise ValueError(f"unknown type {name!r} (storable types: {sorted(_CODECS)})")
        values = {k: self.value(item, depth + 1) for k, item in raw.items()}
        for k, kinds in codec.kinds.items():
            _check_kind(values.get(k), kinds, f"{name}.{k}")
        try:
            return codec.from_fields(values)
        except (ValueError, TypeError) as exc:
            raise ValueError(f"stored {name} is invalid: {exc}") from exc
        except Exception as exc:  # a constructor choking on hostile values
            raise ValueError(f"stored {name} is invalid: {type(exc).__name__}: {exc}") from exc


def _short(v) -> str:
    text = repr(v)
    return text if len(text) <= 60 else text[:57] + "..."


def _check_kind(v, kinds: str, where: str) -> None:
    import scipy.sparse as sp

    arr = v.data if sp.issparse(v) else v
    if isinstance(arr, np.ndarray) and arr.dtype.kind not in kinds:
        raise ValueError(f"{where} has dtype {arr.dtype}, expected kind {kinds!r}")


def _csr(x, array):
    import scipy.sparse as sp

    if not (isinstance(x, dict) and set(x) == {"shape", "data", "indices", "indptr"}):
        raise ValueError(f"malformed sparse matrix {_short(x)}")
    shape = x["shape"]
    data, indices, indptr = (array(x[k]) for k in ("data", "indices", "indptr"))
    if not (isinstance(shape, list) and len(shape) == 2 and all(
            isinstance(d, int) and not isinstance(d, bool) and d >= 0 for d in shape)):
        raise ValueError(f"malformed sparse shape {_short(shape)}")
    n, m = shape
    if any(a.ndim != 1 for a in (data, indices, indptr)) or indices.dtype.kind not in "iu" \
            or indptr.dtype.kind not in "iu" or data.dtype.kind not in "biufc":
        raise ValueError("sparse matrix members must be 1-D, integer indices")
    if indptr.size != n + 1 or indices.size != data.size or indptr[0] != 0 \
            or indptr[-1] != data.size or np.any(np.diff(indptr) < 0):
        raise ValueError(f"inconsistent sparse matrix of shape {tuple(shape)} "
                         f"({data.size} entries, {indptr.size} row pointers)")
    if indices.size and (indices.min() < 0 or indices.max() >= m):
        raise ValueError(f"sparse column index out of range [0, {m})")
    out = sp.csr_matrix((data, indices, indptr), shape=(n, m))
    out.check_format(full_check=True)
    return out


def _resolve_load_path(path: str) -> str:
    if os.path.exists(path) or path.endswith(".npz") or not os.path.exists(path + ".npz"):
        return path
    return path + ".npz"


def load(path):
    """Load an object saved by :func:`save` (or an FRF saved by :func:`sdctrl.save_npz`).

    The file is checked before anything large is allocated and nothing in it is executed: a
    damaged or hostile file (not a zip, missing members, absurd shapes, object or unexpected
    dtypes, inconsistent values) raises ``ValueError`` naming the file and the fault.

    Parameters
    ----------
    path : str or os.PathLike
        The ``.npz`` file; ``path + ".npz"`` is tried when ``path`` does not exist.

    Returns
    -------
    object
        The saved object, of its saved type.

    Raises
    ------
    ValueError
        A damaged, hostile or foreign file, or one written by a newer sdctrl.
    OSError
        The path cannot be opened (missing, a directory, no permission), named in the message.
    """
    path = _resolve_load_path(check_path(path))
    check_regular(path)
    arrays = read_arrays(path)
    if _META not in arrays:
        if {"freq", "H"} <= set(arrays):       # an FRF written by save_npz
            from sdctrl.io import load_npz
            return load_npz(path)
        raise ValueError(f"file {path!r} is not an sdctrl archive (no {_META!r} member; "
                         f"members {sorted(arrays)[:5]})")
    meta = _meta(arrays.pop(_META), path)
    try:
        obj = _Decoder(arrays).value(meta["root"])
    except ValueError as exc:
        raise ValueError(f"file {path!r}: {exc}") from exc
    return obj


def _meta(raw: np.ndarray, path: str) -> dict:
    if raw.dtype != np.uint8 or raw.ndim != 1:
        raise ValueError(f"file {path!r}: member {_META!r} must be 1-D uint8 JSON bytes, got "
                         f"{raw.dtype} of shape {raw.shape}")
    try:
        meta = json.loads(raw.tobytes().decode("utf-8"))
    except (ValueError, RecursionError) as exc:       # UnicodeDecodeError is a ValueError
        raise ValueError(f"file {path!r}: metadata is not valid JSON ({exc})") from None
    if not isinstance(meta, dict) or meta.get("format") != _FORMAT:
        raise ValueError(f"file {path!r} is not an sdctrl archive (format "
                         f"{_short(meta.get('format') if isinstance(meta, dict) else meta)})")
    version = meta.get("version")
    if not isinstance(version, int) or isinstance(version, bool) or version < 1:
        raise ValueError(f"file {path!r}: bad format version {_short(version)}")
    if version > FORMAT_VERSION:
        raise ValueError(f"file {path!r} has format version {version}, newer than this sdctrl "
                         f"reads ({FORMAT_VERSION}); upgrade sdctrl")
    root = meta.get("root")
    if not (isinstance(root, dict) and set(root) == {"object"}):
        raise ValueError(f"file {path!r}: metadata holds no saved object")
    return meta


# ------------------------------------------------------------------------------------------
# the built-in types
# ------------------------------------------------------------------------------------------
def _build_uncertain(model, dGamma, dOmega, db, dc, params=()):
    """UncertainModel from stored fields, checked as :func:`sdctrl.uncertainty.uncertain` builds
    them (the dataclass itself does not validate)."""
    from sdctrl.modal import NormalModeModel
    from sdctrl.uncertainty import UncertainModel

    if not isinstance(model, NormalModeModel):
        raise TypeError(f"model must be a NormalModeModel, got {type(model).__name__}")
    n, ns, na = model.n, model.ns, model.na
    shapes = {"dGamma": (n, n), "dOmega": (n, n), "db": (n, na), "dc": (ns, n)}
    bounds = {"dGamma": dGamma, "dOmega": dOmega, "db": db, "dc": dc}
    for k, a in bounds.items():
        if not isinstance(a, np.ndarray) or a.shape != shapes[k] or a.dtype.kind != "f" \
                or not np.all(np.isfinite(a)) or np.any(a < 0):
            raise ValueError(f"{k} must be finite non-negative bounds of shape {shapes[k]}")
    if not isinstance(params, list):
        raise TypeError("params must be a list")
    limits = {"Omega": (n, n), "Gamma": (n, n), "b": (n, na), "c": (ns, n)}
    for p in params:
        ok = isinstance(p, tuple) and len(p) == 4 and isinstance(p[0], str) \
            and isinstance(p[1], tuple) and len(p[1]) == 3 and p[1][0] in limits \
            and p[2] in (1, 2) and not isinstance(p[2], bool) and isinstance(p[3], float) \
            and math.isfinite(p[3]) and p[3] >= 0
        ok = ok and all(isinstance(i, int) and not isinstance(i, bool) and 0 <= i < lim
                        for i, lim in zip(p[1][1:], limits[p[1][0]]))
        if not ok:
            raise ValueError(f"malformed uncertain parameter {_short(p)}")
    return UncertainModel(model, dGamma, dOmega, db, dc, params)


def _build_robust(**values):
    from sdctrl.robust import RobustResult

    for k in ("margin", "margin_lower", "frequency"):
        if k in values and (isinstance(values[k], bool) or not isinstance(values[k], int | float)):
            raise TypeError(f"{k} must be a number")
    if "stable" in values and not isinstance(values["stable"], bool):
        raise TypeError("stable must be a bool")
    return RobustResult(**values)


_MODAL = {k: "f" for k in ("Omega", "Gamma", "cphi", "phib", "E", "F", "shapes")}
register_attrs("FRF", "sdctrl.frf:FRF",
               ("freq", "H", "quantity", "sensors", "actuators", "collocated", "coherence",
                "units"), kinds={"freq": "f", "H": "c", "coherence": "f"})
register_attrs("ComplexModeModel", "sdctrl.identification.complex_modes:ComplexModeModel",
               kinds={"poles": "c", "residues": "c", "E": "f", "F": "f", "in_band": "b"})
register_attrs("NormalModeModel", "sdctrl.modal:NormalModeModel", kinds=_MODAL)
register_attrs("HybridModel", "sdctrl.hybridmodel:HybridModel", kinds=_MODAL)
register_attrs("FEModel", "sdctrl.fe.model:FEModel",
               ("M", "K", "C", "dofs", "nodes", "elements"), kinds={"M": "f", "K": "f", "C": "f"})
register_attrs("UncertainModel", "sdctrl.uncertainty:UncertainModel",
               kinds={"dGamma": "f", "dOmega": "f", "db": "f", "dc": "f"},
               build=_build_uncertain, lenient=())
register_attrs("RobustResult", "sdctrl.robust:RobustResult",
               kinds={"worst_delta": "f", "mu_freq": "f", "mu": "f"}, build=_build_robust)
