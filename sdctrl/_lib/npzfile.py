"""Plain-array ``.npz`` archives read defensively and written deterministically (internal).

:func:`read_arrays` is the only way sdctrl reads an ``.npz``.  It never unpickles and refuses a
hostile or damaged file with a ``ValueError`` naming the file and what is wrong *before* any
large allocation:

- the zip directory is read first; members must be ``<name>.npy``, unique, stored or deflated,
  and the uncompressed sizes they declare may not exceed ``MAX_RATIO`` times the file's own size
  (plus ``SLACK`` bytes): a zip bomb is refused unread;
- each member's ``.npy`` header is parsed (numpy's literal parser, no code) and its dtype must be
  a plain boolean, integer, float, complex, bytes or unicode dtype (no object, structured or
  zero-size item), no dimension may exceed the file's size in bytes, and ``prod(shape) *
  itemsize`` must equal the member's declared size: a header claiming 1e12 elements in a small
  member is refused before its data are read;
- data are then read, the zip CRC checked, and the array built from exactly those bytes.

The resulting peak memory is at most about twice the declared sizes, hence a small multiple of
the file's size.
"""

from __future__ import annotations

import io
import math
import zipfile

import numpy as np

from sdctrl._lib.files import atomic_write, open_regular

__all__ = ["MAX_RATIO", "SLACK", "ArchiveError", "read_arrays", "write_arrays"]

#: deflated members may expand to at most this many times the file's size ...
MAX_RATIO = 16
#: ... plus this many bytes
SLACK = 1 << 16
#: at most this many members
MAX_MEMBERS = 100_000
_KINDS = "biufcSU"
_FIXED_TIME = (1980, 1, 1, 0, 0, 0)


class ArchiveError(ValueError):
    """A damaged or hostile archive (a ``ValueError``)."""


def _bad(path: str, what: str) -> ArchiveError:
    return ArchiveError(f"file {path!r} is not a valid .npz archive: {what}")


def _members(zf: zipfile.ZipFile, path: str, size: int) -> list[zipfile.ZipInfo]:
    infos = zf.infolist()
    if len(infos) > MAX_MEMBERS:
        raise _bad(path, f"{len(infos)} members (at most {MAX_MEMBERS})")
    names = [i.filename for i in infos]
    if len(set(names)) != len(names):
        dup = sorted({n for n in names if names.count(n) > 1})[:3]
        raise _bad(path, f"duplicated member(s) {dup}")
    total = 0
    for info in infos:
        if not info.filename.endswith(".npy"):
            raise _bad(path, f"member {info.filename!r} is not a .npy array")
        if info.compress_type not in (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED):
            raise _bad(path, f"member {info.filename!r} uses an unsupported compression "
                             f"(method {info.compress_type})")
        if info.flag_bits & 0x1:
            raise _bad(path, f"member {info.filename!r} is encrypted")
        total += info.file_size
    if total > MAX_RATIO * size + SLACK:
        raise _bad(path, f"members declare {total} bytes uncompressed in a {size}-byte file "
                         f"(more than {MAX_RATIO} times its size: refused unread)")
    return infos


def _header(fp, path: str, member: str, size: int):
    try:
        version = np.lib.format.read_magic(fp)
        if version == (1, 0):
            shape, fortran, dtype = np.lib.format.read_array_header_1_0(fp)
        elif version in ((2, 0), (3, 0)):
            shape, fortran, dtype = np.lib.format.read_array_header_2_0(fp)
        else:
            raise ValueError(f"unsupported .npy format version {version}")
    except Exception as exc:   # ValueError, SyntaxError, tokenize.TokenError, ...
        raise _bad(path, f"member {member!r} has a bad .npy header ({exc})") from exc
    if not isinstance(dtype, np.dtype) or dtype.hasobject:
        raise _bad(path, f"member {member!r} holds Python objects (dtype {dtype}); "
                         "pickles are never loaded")
    if dtype.fields is not None or dtype.subdtype is not None or dtype.kind not in _KINDS \
            or dtype.itemsize == 0:
        raise _bad(path, f"member {member!r} has dtype {dtype}, expected a plain boolean, "
                         "integer, float, complex or string dtype")
    if not all(isinstance(d, int) and 0 <= d <= size for d in shape):
        raise _bad(path, f"member {member!r} claims shape {shape} in a {size}-byte file")
    return tuple(shape), bool(fortran), dtype


def _read_member(zf, info, path: str, size: int) -> np.ndarray:
    member = info.filename
    with zf.open(info) as fp:
        shape, fortran, dtype = _header(fp, path, member, size)
        nbytes = math.prod(shape) * dtype.itemsize
        if nbytes != info.file_size - fp.tell():
            raise _bad(path, f"member {member!r} claims shape {shape} of {dtype} "
                             f"({nbytes} bytes) but holds {info.file_size - fp.tell()} bytes")
        data = fp.read(nbytes)
        if len(data) != nbytes or fp.read(1):
            raise _bad(path, f"member {member!r} is truncated")
    arr = np.frombuffer(data, dtype=dtype) if nbytes else np.empty(0, dtype)
    return arr.reshape(shape, order="F" if fortran else "C").copy(order="C")


def read_arrays(path: str, name: str = "path") -> dict[str, np.ndarray]:
    """All arrays of a ``.npz`` file, checked as described in the module docstring.

    Parameters
    ----------
    path : str
        The file (checked by :func:`sdctrl._lib.files.open_regular`).
    name : str
        The argument name used in messages.

    Returns
    -------
    dict of str to ndarray
        Member name (without ``.npy``) -> array, in archive order.
    """
    with open_regular(path, name) as fh:
        size = fh.seek(0, io.SEEK_END)
        fh.seek(0)
        try:
            with zipfile.ZipFile(fh) as zf:
                return {info.filename[:-4]: _read_member(zf, info, path, size)
                        for info in _members(zf, path, size)}
        except ArchiveError:
            raise
        except MemoryError:
            raise
        except Exception as exc:  # BadZipFile, EOFError, zlib.error, struct.error, ...
            raise _bad(path, f"{type(exc).__name__}: {exc}") from exc


def write_arrays(path: str, arrays: dict[str, np.ndarray], name: str = "path") -> None:
    """Write plain arrays to an uncompressed ``.npz`` at ``path`` (atomically).

    Members get a fixed timestamp so that equal content gives byte-identical files.  Object
    arrays are refused (``allow_pickle=False``).
    """
    with atomic_write(path, name) as tmp, zipfile.ZipFile(tmp, "w", zipfile.ZIP_STORED,
                                                          allowZip64=True) as zf:
        for key, arr in arrays.items():
            a = np.asarray(arr)
            info = zipfile.ZipInfo(f"{key}.npy", date_time=_FIXED_TIME)
            info.compress_type = zipfile.ZIP_STORED
            info.external_attr = 0o644 << 16
            with zf.open(info, "w", force_zip64=True) as fp:
                np.lib.format.write_array(fp, a, allow_pickle=False)
