"""Input validation shared by the public boundary (internal).

Every helper raises ``ValueError``/``TypeError`` with a message that names the
argument and what was expected, and returns a *new* array so that nothing the
caller passed is ever modified.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

QUANTITIES = ("displacement", "velocity", "acceleration")
#: power of ``j*omega`` that turns a displacement FRF into each quantity
QUANTITY_POWER = {"displacement": 0, "velocity": 1, "acceleration": 2}


def check_quantity(quantity, name: str = "quantity") -> str:
    """Return ``quantity`` if it is a known response quantity."""
    if not isinstance(quantity, str):
        raise TypeError(f"{name} must be a string, one of {QUANTITIES}, got {type(quantity).__name__}")
    q = quantity.lower()
    aliases = {"disp": "displacement", "vel": "velocity", "acc": "acceleration",
               "accel": "acceleration"}
    q = aliases.get(q, q)
    if q not in QUANTITIES:
        raise ValueError(f"{name} must be one of {QUANTITIES}, got {quantity!r}")
    return q


def as_array(x, name: str, *, ndim: int | tuple[int, ...] | None = None, dtype=float,
             finite: bool = True, shape: tuple | None = None) -> np.ndarray:
    """Copy ``x`` to a numpy array of ``dtype`` and check its rank/shape/finiteness.

    ``shape`` may contain ``None`` for free dimensions.
    """
    if x is None:
        raise TypeError(f"{name} must be an array, got None")
    try:
        if dtype is complex:
            arr = np.array(x, dtype=complex, copy=True)
        else:
            arr = np.array(x, copy=True)
            if np.iscomplexobj(arr) and dtype is float:
                if np.any(np.imag(arr) != 0):
                    raise TypeError(f"{name} must be real, got complex values")
                arr = arr.real.copy()
            arr = arr.astype(dtype, copy=False)
    except (TypeError, ValueError) as exc:
        if isinstance(exc, TypeError) and str(exc).startswith(name):
            raise
        raise TypeError(f"{name} must be a numeric array, got {type(x).__name__}") from exc
    if ndim is not None:
        ndims = (ndim,) if isinstance(ndim, int) else tuple(ndim)
        if arr.ndim not in ndims:
            raise ValueError(f"{name} must be a {' or '.join(str(d) for d in ndims)}-D array, "
                             f"got shape {arr.shape}")
    if shape is not None and (arr.ndim != len(shape) or any(
            s is not None and s != a for s, a in zip(shape, arr.shape))):
        want = "(" + ", ".join("n" if s is None else str(s) for s in shape) + ")"
        raise ValueError(f"{name} must have shape {want}, got {arr.shape}")
    if finite and arr.size and not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must contain only finite values (no NaN or inf)")
    return arr


def check_square(x, name: str, n: int | None = None, dtype=float) -> np.ndarray:
    arr = as_array(x, name, ndim=2, dtype=dtype)
    if arr.shape[0] != arr.shape[1]:
        raise ValueError(f"{name} must be a square (n, n) array, got shape {arr.shape}")
    if n is not None and arr.shape[0] != n:
        raise ValueError(f"{name} must have shape ({n}, {n}), got {arr.shape}")
    return arr


def check_freq(freq, name: str = "freq") -> np.ndarray:
    """Strictly increasing, positive, finite 1-D frequency vector (Hz)."""
    f = as_array(freq, name, ndim=(0, 1), dtype=float)
    f = np.atleast_1d(f)
    if f.size == 0:
        raise ValueError(f"{name} must contain at least one frequency")
    if np.any(f <= 0):
        raise ValueError(f"{name} must contain strictly positive frequencies (Hz), "
                         f"got minimum {f.min():g}")
    if f.size > 1 and np.any(np.diff(f) <= 0):
        raise ValueError(f"{name} must be strictly increasing")
    return f


def check_labels(labels, n: int, name: str, default_prefix: str) -> tuple[str, ...]:
    """Tuple of ``n`` unique string labels (defaults ``prefix0, prefix1, ...``)."""
    if labels is None:
        return tuple(f"{default_prefix}{i}" for i in range(n))
    if isinstance(labels, str) or not isinstance(labels, Sequence | np.ndarray):
        raise TypeError(f"{name} must be a sequence of {n} strings, got {type(labels).__name__}")
    out = tuple(labels)
    if len(out) != n:
        raise ValueError(f"{name} must have {n} labels (one per {default_prefix.rstrip('_')}), "
                         f"got {len(out)}")
    for lab in out:
        if not isinstance(lab, str | np.str_):
            raise TypeError(f"{name} must contain strings, got {type(lab).__name__}")
    out = tuple(str(lab) for lab in out)
    if len(set(out)) != len(out):
        raise ValueError(f"{name} must be unique, got duplicates")
    return out


def check_collocated(collocated, ns: int, na: int, name: str = "collocated",
                     sensors: Sequence[str] | None = None,
                     actuators: Sequence[str] | None = None) -> tuple[tuple[int, int], ...]:
    """Collocated (sensor, actuator) index pairs, in range; labels are accepted too."""
    if collocated is None:
        return ()
    try:
        pairs = [tuple(p) for p in collocated]
    except TypeError as exc:
        raise TypeError(f"{name} must be a sequence of (sensor, actuator) pairs") from exc
    out = []
    for p in pairs:
        if len(p) != 2:
            raise ValueError(f"{name} must contain (sensor, actuator) pairs, got {p!r}")
        s, a = p
        if isinstance(s, str):
            if sensors is None or s not in sensors:
                raise ValueError(f"{name}: unknown sensor label {s!r}")
            s = list(sensors).index(s)
        if isinstance(a, str):
            if actuators is None or a not in actuators:
                raise ValueError(f"{name}: unknown actuator label {a!r}")
            a = list(actuators).index(a)
        if isinstance(s, bool) or isinstance(a, bool) or not (
                isinstance(s, int | np.integer) and isinstance(a, int | np.integer)):
            raise TypeError(f"{name} pairs must hold integer indices or labels, got {p!r}")
        if not (0 <= s < ns):
            raise ValueError(f"{name}: sensor index {s} out of range [0, {ns})")
        if not (0 <= a < na):
            raise ValueError(f"{name}: actuator index {a} out of range [0, {na})")
        out.append((int(s), int(a)))
    return tuple(out)


def signal_name(label: str) -> str:
    """python-control signal name for a label: '.' (refused by python-control) becomes '_'."""
    return str(label).replace(".", "_")


def readonly(arr: np.ndarray | None) -> np.ndarray | None:
    if arr is None:
        return None
    arr.setflags(write=False)
    return arr
