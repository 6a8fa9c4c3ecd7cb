"""FRFs in numpy ``.npz`` files of plain arrays (readable by ``numpy.load``).

Members ``freq``, ``H``, ``quantity``, ``sensors``, ``actuators``, ``collocated``, ``units``
and optionally ``coherence``.  Reading goes through :func:`sdctrl._npz.read_arrays`: nothing is
unpickled and a damaged or hostile file is refused before any large allocation.  Models and
results of every kind are saved by :func:`sdctrl.save` instead.
"""

from __future__ import annotations

import numpy as np

from sdctrl._files import check_path, npz_to_read, npz_to_write
from sdctrl._npz import read_arrays, write_arrays
from sdctrl.frf import FRF

__all__ = ["load_npz", "save_npz"]


def save_npz(frf: FRF, path) -> str:
    """Save an FRF, labels, collocated pairs and coherence to a numpy ``.npz`` file.

    Plain arrays only (readable with ``numpy.load``); written atomically.

    Parameters
    ----------
    frf : FRF
        The data to save.
    path : str or os.PathLike
        Output file; ``.npz`` is appended when missing (as ``numpy.savez`` does).

    Returns
    -------
    str
        The path written.
    """
    if not isinstance(frf, FRF):
        raise TypeError(f"frf must be an sdctrl.FRF, got {type(frf).__name__}")
    path = npz_to_write(check_path(path))
    kw = {"freq": frf.freq, "H": frf.H, "quantity": np.array(frf.quantity),
          "sensors": np.array(frf.sensors, dtype=str),
          "actuators": np.array(frf.actuators, dtype=str),
          "collocated": np.array(frf.collocated, dtype=np.int64).reshape(-1, 2),
          "units": np.array(frf.units or "")}
    if frf.coherence is not None:
        kw["coherence"] = frf.coherence
    write_arrays(path, kw)
    return path


def _text(z: dict, key: str, path: str, ndim: int):
    v = z[key]
    if v.dtype.kind != "U" or v.ndim != ndim:
        raise ValueError(f"file {path!r}: member {key!r} must be a {ndim}-D string array, got "
                         f"{v.dtype} of shape {v.shape}")
    return str(v[()]) if ndim == 0 else [str(s) for s in v]


def load_npz(path) -> FRF:
    """Load an FRF saved by :func:`save_npz`.

    The archive is checked before anything large is allocated and never unpickled: a damaged
    or hostile file raises ``ValueError`` naming it and the fault.

    Parameters
    ----------
    path : str or os.PathLike
        The ``.npz`` file; ``path + ".npz"`` is tried when ``path`` does not exist.

    Returns
    -------
    FRF

    Raises
    ------
    ValueError
        Not an FRF archive, or a damaged one.
    OSError
        The path cannot be opened (missing, a directory, no permission).
    """
    path = npz_to_read(check_path(path))
    z = read_arrays(path)
    missing = {"freq", "H", "quantity", "sensors", "actuators"} - set(z)
    if missing and "__sdctrl__" in z:
        raise ValueError(f"file {path!r} is not an sdctrl FRF archive of save_npz but a file "
                         "of sdctrl.save: read it with sdctrl.load")
    if missing:
        raise ValueError(f"file {path!r} is not an sdctrl FRF archive (missing members "
                         f"{sorted(missing)})")
    for key, kinds in (("freq", "f"), ("H", "c"), ("coherence", "f"), ("collocated", "iu")):
        if key in z and z[key].dtype.kind not in kinds:
            raise ValueError(f"file {path!r}: member {key!r} has dtype {z[key].dtype}")
    col = z.get("collocated", np.zeros((0, 2), np.int64))
    if col.ndim != 2 or col.shape[1] != 2:
        raise ValueError(f"file {path!r}: member 'collocated' must have shape (k, 2), got "
                         f"{col.shape}")
    units = _text(z, "units", path, 0) if "units" in z else ""
    try:
        return FRF(z["freq"], z["H"], quantity=_text(z, "quantity", path, 0),
                   sensors=_text(z, "sensors", path, 1),
                   actuators=_text(z, "actuators", path, 1),
                   collocated=[(int(s), int(a)) for s, a in col],
                   coherence=z.get("coherence"), units=units or None)
    except (ValueError, TypeError) as exc:
        raise ValueError(f"file {path!r}: {exc}") from exc
