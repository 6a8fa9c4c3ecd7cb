"""The file: :func:`save` and :func:`load` of one ``.npz`` of arrays + a JSON document."""

from __future__ import annotations

import json
import warnings

import numpy as np

from sdctrl._lib.files import check_path, npz_to_read, npz_to_write
from sdctrl._lib.npzfile import read_arrays, write_arrays
from sdctrl.storage._legacy import frf_from_arrays
from sdctrl.storage._registry import CODECS, codec_of
from sdctrl.storage._values import META, Decoder, Encoder, short

__all__ = ["FORMAT_VERSION", "StorageWarning", "load", "save"]

#: version of the file layout written by :func:`save`; :func:`load` reads this and older ones
FORMAT_VERSION = 1
_FORMAT = "sdctrl"


class StorageWarning(UserWarning):
    """Part of an object (an ``info`` entry) could not be stored and was dropped."""


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
    path = npz_to_write(check_path(path))
    codec = codec_of(model)
    if codec is None:
        raise TypeError(f"model must be one of the storable types {sorted(CODECS)}, got "
                        f"{type(model).__module__}.{type(model).__qualname__}")
    enc = Encoder()
    root = {"object": [codec.name, enc.fields(model, codec, "model", 0)]}
    if enc.dropped:
        warnings.warn(f"save: {len(enc.dropped)} value(s) not stored (not plain data): "
                      + "; ".join(enc.dropped[:10]) + (" ..." if len(enc.dropped) > 10 else ""),
                      StorageWarning, stacklevel=2)
    meta = {"format": _FORMAT, "version": FORMAT_VERSION, "sdctrl": _version(), "root": root}
    text = json.dumps(meta, allow_nan=False, ensure_ascii=True, separators=(",", ":"))
    arrays = {META: np.frombuffer(text.encode("ascii"), dtype=np.uint8), **enc.arrays}
    write_arrays(path, arrays)
    return path


def _version() -> str:
    from sdctrl import __version__
    return __version__


# ------------------------------------------------------------------------------------------
def load(path):
    """Load an object saved by :func:`save` (or an FRF saved by ``save_npz`` of sdctrl before 0.2).

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
    path = npz_to_read(check_path(path))
    arrays = read_arrays(path)
    if META not in arrays:
        if {"freq", "H"} <= set(arrays):       # an FRF written by save_npz (before 0.2)
            return frf_from_arrays(arrays, path)
        raise ValueError(f"file {path!r} is not an sdctrl archive (no {META!r} member; "
                         f"members {sorted(arrays)[:5]})")
    meta = _meta(arrays.pop(META), path)
    try:
        obj = Decoder(arrays).value(meta["root"])
    except ValueError as exc:
        raise ValueError(f"file {path!r}: {exc}") from exc
    return obj


def _no_constant(name: str):
    raise ValueError(f"non-standard JSON constant {name}")


def _meta(raw: np.ndarray, path: str) -> dict:
    if raw.dtype != np.uint8 or raw.ndim != 1:
        raise ValueError(f"file {path!r}: member {META!r} must be 1-D uint8 JSON bytes, got "
                         f"{raw.dtype} of shape {raw.shape}")
    try:
        meta = json.loads(raw.tobytes().decode("utf-8"), parse_constant=_no_constant)
    except (ValueError, RecursionError) as exc:       # UnicodeDecodeError is a ValueError
        raise ValueError(f"file {path!r}: metadata is not valid JSON ({exc})") from None
    if not isinstance(meta, dict) or meta.get("format") != _FORMAT:
        raise ValueError(f"file {path!r} is not an sdctrl archive (format "
                         f"{short(meta.get('format') if isinstance(meta, dict) else meta)})")
    version = meta.get("version")
    if not isinstance(version, int) or isinstance(version, bool) or version < 1:
        raise ValueError(f"file {path!r}: bad format version {short(version)}")
    if version > FORMAT_VERSION:
        raise ValueError(f"file {path!r} has format version {version}, newer than this sdctrl "
                         f"reads ({FORMAT_VERSION}); upgrade sdctrl")
    root = meta.get("root")
    if not (isinstance(root, dict) and set(root) == {"object"}):
        raise ValueError(f"file {path!r}: metadata holds no saved object")
    return meta
