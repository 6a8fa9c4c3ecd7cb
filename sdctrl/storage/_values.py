"""Values <-> JSON + arrays: the encoding of fields described in :mod:`sdctrl.storage`."""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from sdctrl.storage._registry import CODECS, Codec, codec_of

__all__ = ["DROP", "Decoder", "Encoder", "short"]

_MAX_DEPTH = 64
_KINDS = "biufcSU"
#: name of the metadata member; never an array reference
META = "__sdctrl__"


class Unstorable(Exception):
    """A value that has no encoding (internal signal of :class:`Encoder`)."""


class Encoder:
    """Turns values into JSON-able data, collecting their arrays (members ``a0``, ``a1``...).

    ``dropped`` lists what lenient fields could not store.
    """

    def __init__(self):
        self.arrays: dict[str, np.ndarray] = {}
        self.dropped: list[str] = []

    def _member(self, arr: np.ndarray) -> str:
        if arr.dtype.kind not in _KINDS or arr.dtype.hasobject or arr.dtype.fields is not None \
                or arr.dtype.itemsize == 0:
            raise Unstorable(f"an array of dtype {arr.dtype}")
        key = f"a{len(self.arrays)}"
        self.arrays[key] = arr
        return key

    def value(self, v, where: str, lenient: bool, depth: int = 0):
        """Encoding of ``v``.

        Parameters
        ----------
        v : object
            The value.
        where : str
            Its place in the saved object, for messages (``"model.info['x']"``).
        lenient : bool
            Drop what cannot be stored (returning :data:`DROP`) instead of raising.
        depth : int
            Nesting depth so far.

        Returns
        -------
        object
            JSON-able data, or :data:`DROP`.
        """
        if depth > _MAX_DEPTH:
            raise Unstorable("a structure nested too deeply")
        try:
            return self._value(v, where, lenient, depth)
        except Unstorable as exc:
            if not lenient:
                raise TypeError(f"{where} cannot be stored: {exc}") from None
            self.dropped.append(f"{where} ({exc})")
            return DROP

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
        codec = codec_of(v)
        if codec is not None:
            return {"object": [codec.name, self.fields(v, codec, where, depth + 1)]}
        if isinstance(v, Mapping):
            if not all(isinstance(k, str) for k in v):
                raise Unstorable("a mapping with non-string keys")
            out = {}
            for k, item in v.items():
                enc = self.value(item, f"{where}[{k!r}]", lenient, depth + 1)
                if enc is not DROP:
                    out[k] = enc
            return {"dict": out}
        if isinstance(v, list | tuple):
            items = [self.value(item, f"{where}[{i}]", lenient, depth + 1)
                     for i, item in enumerate(v)]
            items = [None if item is DROP else item for item in items]
            return {"tuple": items} if isinstance(v, tuple) else items
        raise Unstorable(f"a {type(v).__module__}.{type(v).__qualname__}")

    def fields(self, obj, codec: Codec, where: str, depth: int) -> dict:
        """Encoded fields of a registered object.

        Parameters
        ----------
        obj : object
            The object.
        codec : Codec
            Its codec.
        where : str
            Its place in the saved object, for messages.
        depth : int
            Nesting depth so far.

        Returns
        -------
        dict
        """
        out = {}
        for k, v in codec.to_fields(obj).items():
            enc = self.value(v, f"{where}.{k}", k in codec.lenient, depth)
            if enc is not DROP:
                out[k] = enc
        return out


DROP = object()


class Decoder:
    """Rebuilds values from JSON data and the archive's arrays, refusing anything malformed.

    Parameters
    ----------
    arrays : dict of str to ndarray
        The archive's members (checked by :func:`sdctrl._lib.npzfile.read_arrays`).
    """

    def __init__(self, arrays: dict[str, np.ndarray]):
        self.arrays = arrays

    def _array(self, key) -> np.ndarray:
        if not isinstance(key, str) or key not in self.arrays or key == META:
            raise ValueError(f"refers to a missing array member {key!r}")
        return self.arrays[key]

    def value(self, v, depth: int = 0):
        """The value encoded by ``v``; ValueError when malformed.

        Parameters
        ----------
        v : object
            JSON data.
        depth : int
            Nesting depth so far.

        Returns
        -------
        object
        """
        if depth > _MAX_DEPTH:
            raise ValueError("values nested too deeply")
        if v is None or isinstance(v, bool | int | str):
            return v
        if isinstance(v, float):
            return v
        if isinstance(v, list):
            return [self.value(item, depth + 1) for item in v]
        if not isinstance(v, dict) or len(v) != 1:
            raise ValueError(f"malformed value {short(v)}")
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
            raise ValueError(f"malformed float {short(x)}")
        return float(x)

    def _tag_complex(self, x, depth):
        if not isinstance(x, list) or len(x) != 2:
            raise ValueError(f"malformed complex {short(x)}")
        re, im = (self.value(p, depth + 1) for p in x)
        if not all(isinstance(p, float | int) and not isinstance(p, bool) for p in (re, im)):
            raise ValueError(f"malformed complex {short(x)}")
        return complex(re, im)

    def _tag_tuple(self, x, depth):
        if isinstance(x, list):
            return tuple(self.value(item, depth + 1) for item in x)
        raise ValueError(f"malformed tuple {short(x)}")

    def _tag_dict(self, x, depth):
        if isinstance(x, dict):
            return {k: self.value(item, depth + 1) for k, item in x.items()}
        raise ValueError(f"malformed dict {short(x)}")

    def _tag_csr(self, x, depth):
        return _csr(x, self._array)

    def _tag_object(self, x, depth):
        if not (isinstance(x, list) and len(x) == 2 and isinstance(x[0], str)
                and isinstance(x[1], dict)):
            raise ValueError(f"malformed object {short(x)}")
        name, raw = x
        codec = CODECS.get(name)
        if codec is None:
            raise ValueError(f"unknown type {name!r} (storable types: {sorted(CODECS)})")
        values = {k: self.value(item, depth + 1) for k, item in raw.items()}
        for k, kinds in codec.kinds.items():
            _check_kind(values.get(k), kinds, f"{name}.{k}")
        try:
            return codec.from_fields(values)
        except (ValueError, TypeError) as exc:
            raise ValueError(f"stored {name} is invalid: {exc}") from exc
        except Exception as exc:  # a constructor choking on hostile values
            raise ValueError(f"stored {name} is invalid: {type(exc).__name__}: {exc}") from exc


def short(v) -> str:
    """``repr(v)`` cut to 60 characters, for messages.

    Parameters
    ----------
    v : object
        Anything.

    Returns
    -------
    str
    """
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
        raise ValueError(f"malformed sparse matrix {short(x)}")
    shape = x["shape"]
    data, indices, indptr = (array(x[k]) for k in ("data", "indices", "indptr"))
    if not (isinstance(shape, list) and len(shape) == 2 and all(
            isinstance(d, int) and not isinstance(d, bool) and d >= 0 for d in shape)):
        raise ValueError(f"malformed sparse shape {short(shape)}")
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
