"""File paths for the readers and writers (internal): checked, opened without blocking, written
atomically.

Every reader opens its file through :func:`open_regular`, which refuses what is not a regular
file (a FIFO, a device, a directory) *before* reading a byte, so that no reader can block on a
named pipe or read ``/dev/zero`` forever.  Every writer goes through :func:`atomic_write`: the
data goes to a temporary file next to the target, which replaces the target only once complete,
so a failure never leaves a truncated file or destroys the previous one.
"""

from __future__ import annotations

import contextlib
import errno
import os
import secrets
import stat

__all__ = ["MissingFileError", "atomic_write", "check_path", "npz_to_read", "npz_to_write",
           "open_regular"]


class MissingFileError(FileNotFoundError, ValueError):
    """A file to read does not exist: both a ``FileNotFoundError`` (an ``OSError``) and a
    ``ValueError``, so either ``except`` clause catches it."""

    def __str__(self) -> str:                 # the message names the path once
        return str(self.strerror)


def check_path(path, name: str = "path") -> str:
    """``path`` as a ``str``; TypeError unless it is a ``str`` or ``os.PathLike`` of ``str``."""
    if isinstance(path, bytes) or not isinstance(path, str | os.PathLike):
        raise TypeError(f"{name} must be a file path (str or os.PathLike), got "
                        f"{type(path).__name__}")
    out = os.fspath(path)
    if not isinstance(out, str):
        raise TypeError(f"{name} must be a file path (str or os.PathLike), got a path of "
                        f"{type(out).__name__}")
    if not out or "\x00" in out:
        raise ValueError(f"{name} must be a non-empty file path without NUL characters, "
                         f"got {out!r}")
    return out


def npz_to_write(path: str, name: str = "path") -> str:
    """``path`` with ``.npz`` appended when missing (as ``numpy.savez`` does); it must name a
    file, not end with a separator."""
    if not os.path.basename(path):
        raise ValueError(f"{name} must name a file, got {path!r}")
    return path if path.endswith(".npz") else path + ".npz"


def npz_to_read(path: str) -> str:
    """``path``, or ``path + ".npz"`` when only that exists (what :func:`npz_to_write` wrote)."""
    if os.path.lexists(path) or path.endswith(".npz") or not os.path.exists(path + ".npz"):
        return path
    return path + ".npz"


def _kind(mode: int) -> str:
    for test, what in ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
                       (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
                       (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return what
    return "not a regular file"


def _refuse(path: str, mode: int, name: str):
    if stat.S_ISDIR(mode):
        return IsADirectoryError(errno.EISDIR, f"{name} {path!r} is a directory, not a file",
                                 path)
    return ValueError(f"{name} {path!r} is {_kind(mode)}, not a regular file")


def check_regular(path: str, name: str = "path") -> os.stat_result:
    """Stat ``path`` (following links); refuse a missing path or one that is not a regular file.

    Raises
    ------
    MissingFileError
        Nothing at ``path``.
    IsADirectoryError
        ``path`` is a directory.
    ValueError
        A FIFO, a device or a socket.
    OSError
        The path cannot be examined (permissions), the message naming it.
    """
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise MissingFileError(errno.ENOENT, f"{name} {path!r} does not exist", path) from None
    except OSError as exc:
        raise type(exc)(exc.errno, f"{name} {path!r} cannot be examined: {exc.strerror}",
                        path) from None
    if not stat.S_ISREG(st.st_mode):
        raise _refuse(path, st.st_mode, name)
    return st


def open_regular(path: str, name: str = "path"):
    """Open a regular file for binary reading without ever blocking.

    The file is opened with ``O_NONBLOCK`` (a FIFO opened so returns at once) and checked with
    ``fstat`` on the open descriptor, so a path swapped for a FIFO after a check is refused too.
    Returns a binary file object positioned at the start.
    """
    check_regular(path, name)
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0)
    try:
        fd = os.open(path, flags)
    except FileNotFoundError:
        raise MissingFileError(errno.ENOENT, f"{name} {path!r} does not exist", path) from None
    except OSError as exc:
        raise type(exc)(exc.errno, f"{name} {path!r} cannot be opened: {exc.strerror}",
                        path) from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise _refuse(path, st.st_mode, name)
        if hasattr(os, "set_blocking"):
            os.set_blocking(fd, True)
        return os.fdopen(fd, "rb")
    except BaseException:
        os.close(fd)
        raise


def _temporary(path: str, name: str) -> str:
    """Create an empty file next to ``path`` with the permissions a new file gets (umask)."""
    folder = os.path.dirname(os.path.abspath(path))
    for _ in range(100):
        tmp = os.path.join(folder, f".{os.path.basename(path)}.{secrets.token_hex(6)}.tmp")
        try:
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0),
                         0o666)
        except FileExistsError:
            continue
        except FileNotFoundError:
            raise MissingFileError(errno.ENOENT, f"{name} {path!r}: folder {folder!r} does not "
                                   "exist", path) from None
        except OSError as exc:
            raise type(exc)(exc.errno, f"{name} {path!r} cannot be written: {exc.strerror}",
                            path) from None
        os.close(fd)
        return tmp
    raise FileExistsError(errno.EEXIST, f"{name} {path!r}: no free temporary name", path)


@contextlib.contextmanager
def atomic_write(path: str, name: str = "path"):
    """Yield a temporary path next to ``path``; on success it replaces ``path``.

    On any error the temporary file is removed and ``path`` is left as it was.  A target that
    exists but is not a regular file (a directory, a FIFO, a device) is refused first; an
    existing file keeps its permissions.
    """
    mode = None
    if os.path.exists(path):
        st = os.stat(path)
        if not stat.S_ISREG(st.st_mode):
            raise _refuse(path, st.st_mode, name)
        mode = stat.S_IMODE(st.st_mode)
    tmp = _temporary(path, name)
    try:
        yield tmp
        if mode is not None:
            os.chmod(tmp, mode)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.remove(tmp)
        raise
