"""FRF files of sdctrl before 0.2 (``save_npz``), read by :func:`sdctrl.load`.

One save format remains (:func:`sdctrl.save`); files of the former FRF-only format still load.
Members ``freq``, ``H``, ``quantity``, ``sensors``, ``actuators``, ``collocated``, ``units``
and optionally ``coherence``.  Reading goes through :func:`sdctrl._lib.npzfile.read_arrays`: nothing
is unpickled and a damaged or hostile file is refused before any large allocation.  Models and
results of every kind are saved by :func:`sdctrl.save` instead.
"""

from __future__ import annotations

import numpy as np

from sdctrl.data._frf import FRF

__all__ = ["frf_from_arrays"]


def _text(z: dict, key: str, path: str, ndim: int):
    v = z[key]
    if v.dtype.kind != "U" or v.ndim != ndim:
        raise ValueError(f"file {path!r}: member {key!r} must be a {ndim}-D string array, got "
                         f"{v.dtype} of shape {v.shape}")
    return str(v[()]) if ndim == 0 else [str(s) for s in v]


def frf_from_arrays(z: dict, path: str) -> FRF:
    """The FRF of an archive written by ``save_npz`` (sdctrl before 0.2), read by :func:`load`.

    Parameters
    ----------
    z : dict of str to ndarray
        The archive's members, read by :func:`sdctrl._lib.npzfile.read_arrays` (nothing
        unpickled, sizes checked before allocation).
    path : str
        The file (error messages).

    Returns
    -------
    FRF

    Raises
    ------
    ValueError
        Not an FRF archive, or a damaged one, naming the file and the member.
    """
    missing = {"freq", "H", "quantity", "sensors", "actuators"} - set(z)
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
