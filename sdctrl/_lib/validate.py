"""Input validation shared by the public boundary (internal).

Every helper raises ``ValueError``/``TypeError`` with a message that names the
argument and what was expected, and returns a *new* array so that nothing the
caller passed is ever modified.
"""

from __future__ import annotations

import threading
from collections.abc import Sequence

import numpy as np

QUANTITIES = ("displacement", "velocity", "acceleration")
#: power of ``j*omega`` that turns a displacement FRF into each quantity
QUANTITY_POWER = {"displacement": 0, "velocity": 1, "acceleration": 2}
#: accepted quantity names (canonical and standard FRF names) -> canonical name
QUANTITY_NAMES = {"displacement": "displacement", "velocity": "velocity",
                  "acceleration": "acceleration", "receptance": "displacement",
                  "mobility": "velocity", "accelerance": "acceleration",
                  "inertance": "acceleration"}


def check_quantity(quantity, name: str = "quantity") -> str:
    """The canonical name of a response quantity (:data:`QUANTITIES`).

    The standard FRF names are accepted too (:data:`QUANTITY_NAMES`): ``"receptance"``
    (displacement), ``"mobility"`` (velocity), ``"accelerance"`` and ``"inertance"``
    (acceleration); case is ignored.  Abbreviations (``"acc"``, ``"disp"``, ...) are refused:
    a misspelt quantity would silently change the powers of ``j*omega`` applied.
    """
    if not isinstance(quantity, str):
        raise TypeError(f"{name} must be a string, one of {tuple(QUANTITY_NAMES)}, got "
                        f"{type(quantity).__name__}")
    q = QUANTITY_NAMES.get(quantity.lower())
    if q is None:
        raise ValueError(f"{name} must be one of {tuple(QUANTITY_NAMES)}, got {quantity!r}")
    return q


def _no_text(x, arr: np.ndarray, name: str) -> None:
    """Refuse text where numbers are expected (numpy would parse ``"1.0"`` silently)."""
    if isinstance(x, str | bytes) or arr.dtype.kind in "USV":
        raise TypeError(f"{name} must be a numeric array, got text ({type(x).__name__})")
    if arr.dtype == object and any(v is None or isinstance(v, str | bytes | dict)
                                   for v in arr.ravel()):
        raise TypeError(f"{name} must be a numeric array, got an object array holding "
                        "None, text or dicts")


def as_array(x, name: str, *, ndim: int | tuple[int, ...] | None = None, dtype=float,
             finite: bool = True, shape: tuple | None = None) -> np.ndarray:
    """Copy ``x`` to a numpy array of ``dtype`` and check its rank/shape/finiteness.

    ``shape`` may contain ``None`` for free dimensions.  Text (``"1.0"``), None and
    complex values where ``dtype`` is real are refused with a ``TypeError``; the returned
    array is always a new, writeable copy (a read-only input is fine).
    """
    if x is None:
        raise TypeError(f"{name} must be an array, got None")
    try:
        raw = np.array(x, copy=True)
    except (TypeError, ValueError) as exc:          # ragged nested sequences
        raise TypeError(f"{name} must be a numeric array, got {type(x).__name__} that numpy "
                        f"cannot read as one ({exc})") from None
    _no_text(x, raw, name)
    try:
        if dtype is complex:
            arr = raw.astype(complex)
        else:
            arr = raw
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
        bad = ~np.isfinite(arr)
        first = tuple(int(i) for i in np.argwhere(bad)[0])
        where = "" if arr.ndim == 0 else (
            f" at index {first if arr.ndim > 1 else first[0]}")
        raise ValueError(f"{name} must contain only finite values (no NaN or inf): "
                         f"{int(bad.sum())} non-finite entr{'y' if bad.sum() == 1 else 'ies'}, "
                         f"the first {arr[first]}{where}")
    if not arr.flags.writeable:                     # e.g. a broadcast view: hand out a copy
        arr = arr.copy()
    return arr


def check_bool(x, name: str) -> bool:
    """``x`` as a bool; a TypeError naming ``name`` unless it is True or False (numpy
    bools included)."""
    if not isinstance(x, (bool, np.bool_)):
        raise TypeError(f"{name} must be True or False, got {x!r}")
    return bool(x)


def check_scalar(x, name: str, *, positive: bool = False, nonneg: bool = False,
                 optional: bool = False, allow_inf: bool = False, lo: float | None = None,
                 hi: float | None = None) -> float | None:
    """A real number (Python or numpy scalar, or a 0-d array) as a float.

    Parameters
    ----------
    x : object
        The value.
    name : str
        Argument name used in error messages.
    positive, nonneg : bool
        Require ``x > 0`` / ``x >= 0``.
    optional : bool
        Accept (and return) None.
    allow_inf : bool
        Accept ``+inf`` (never NaN).
    lo, hi : float, optional
        Inclusive bounds.

    Returns
    -------
    float or None

    Raises
    ------
    TypeError
        Not a real number (text, complex, bool, a sequence or an array of several values).
    ValueError
        NaN, inf (unless allowed) or out of range.
    """
    if x is None:
        if optional:
            return None
        raise TypeError(f"{name} must be a real number, got None")
    if isinstance(x, np.ndarray) and x.ndim == 0:
        x = x[()]
    if isinstance(x, bool | np.bool_) or not isinstance(x, int | float | np.integer |
                                                            np.floating):
        raise TypeError(f"{name} must be a real number, got {type(x).__name__} {x!r:.40}")
    v = float(x)
    if np.isnan(v) or (np.isinf(v) and not (allow_inf and v > 0)):
        raise ValueError(f"{name} must be a finite number, got {v}")
    if positive and not v > 0:
        raise ValueError(f"{name} must be a positive number, got {v:g}")
    if nonneg and not v >= 0:
        raise ValueError(f"{name} must be a non-negative number, got {v:g}")
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        raise ValueError(f"{name} must lie in [{lo if lo is not None else '-inf'}, "
                         f"{hi if hi is not None else 'inf'}], got {v:g}")
    return v


def check_int(x, name: str, *, minimum: int | None = None, maximum: int | None = None,
              optional: bool = False) -> int | None:
    """An integer (Python or numpy; an integral float such as ``1e3`` too) as an int.

    Parameters
    ----------
    x : object
        The value.
    name : str
        Argument name used in error messages.
    minimum, maximum : int, optional
        Inclusive bounds.
    optional : bool
        Accept (and return) None.

    Returns
    -------
    int or None
    """
    if x is None:
        if optional:
            return None
        raise TypeError(f"{name} must be an integer, got None")
    if isinstance(x, np.ndarray) and x.ndim == 0:
        x = x[()]
    if isinstance(x, bool | np.bool_):
        raise TypeError(f"{name} must be an integer, got bool {x!r}")
    if isinstance(x, float | np.floating):
        if not (np.isfinite(x) and float(x).is_integer()):
            raise TypeError(f"{name} must be an integer, got {x!r}")
        x = int(x)
    if not isinstance(x, int | np.integer):
        raise TypeError(f"{name} must be an integer, got {type(x).__name__} {x!r:.40}")
    v = int(x)
    if (minimum is not None and v < minimum) or (maximum is not None and v > maximum):
        rng = (f">= {minimum}" if maximum is None else f"<= {maximum}" if minimum is None
               else f"in [{minimum}, {maximum}]")
        raise ValueError(f"{name} must be an integer {rng}, got {v}")
    return v


def check_seed(seed, name: str = "seed"):
    """A random seed: None, a non-negative integer, or a numpy Generator/SeedSequence."""
    if seed is None or isinstance(seed, np.random.Generator | np.random.SeedSequence):
        return seed
    return check_int(seed, name, minimum=0)


def check_executor(executor, name: str = "executor"):
    """None (serial) or an executor with a callable ``map`` (``concurrent.futures``, Dask)."""
    if executor is not None and not callable(getattr(executor, "map", None)):
        raise TypeError(f"{name} must be a concurrent.futures.Executor (an object with a "
                        f"map method) or None, got {type(executor).__name__}")
    return executor


def check_info(info, name: str = "info") -> dict:
    """A copy of a diagnostics mapping (``info`` of models and results)."""
    from collections.abc import Mapping

    if not isinstance(info, Mapping):
        raise TypeError(f"{name} must be a dict, got {type(info).__name__}")
    return dict(info)


def check_modal_std(std, n: int, ns: int, na: int, name: str = "std") -> dict | None:
    """A read-only copy of the standard deviations of a normal-mode model's parameters.

    ``std`` maps ``"Omega"``, ``"Gamma"`` (n, n), ``"cphi"`` (ns, n), ``"phib"`` (n, na) to
    arrays of non-negative entries (NaN: undetermined); None passes (no statistics).
    """
    from collections.abc import Mapping

    shapes = {"Omega": (n, n), "Gamma": (n, n), "cphi": (ns, n), "phib": (n, na)}
    if std is None:
        return None
    if not isinstance(std, Mapping) or set(std) != set(shapes):
        raise ValueError(f"{name} must be None or a dict with keys {sorted(shapes)}, got "
                         f"{std!r:.80}")
    out = {}
    for k, shape in shapes.items():
        a = np.array(std[k], dtype=float)
        if a.shape != tuple(shape) or np.any(np.isinf(a)) or np.any(a < 0):
            raise ValueError(f"{name}[{k!r}] must be non-negative standard deviations of "
                             f"shape {tuple(shape)} (NaN: undetermined), got shape {a.shape}")
        out[k] = readonly(a)
    return out


def check_label(x, name: str) -> str:
    """A non-empty string label."""
    if not isinstance(x, str | np.str_):
        raise TypeError(f"{name} must be a string label, got {type(x).__name__} {x!r:.40}")
    if not str(x):
        raise ValueError(f"{name} must be a non-empty label")
    return str(x)


def check_finite_result(x, what: str, culprits: str) -> None:
    """Raise when a computed array holds NaN/inf although its inputs were finite.

    Parameters
    ----------
    x : array_like
        The computed values.
    what : str
        What was computed (``"the FRF"``).
    culprits : str
        The arguments whose size caused it (named in the message).
    """
    a = np.asarray(x)
    if a.size and not np.all(np.isfinite(a)):
        raise ValueError(f"{what} overflows (NaN/inf from finite inputs): {culprits} too large "
                         "or too small in magnitude for double precision; rescale them")


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


#: long label tuples (FE DOF labels) already returned by :func:`check_labels`, by id: a model
#: built from another's labels (a hybrid's candidates and folds, ``replace``) skips the
#: O(N) check of a tuple it returned (tuples of str are immutable, so the check holds)
_CHECKED: dict[int, tuple] = {}
_CHECKED_LOCK = threading.Lock()
#: only tuples of at least this many labels are remembered, at most this many of them
_CHECKED_MIN, _CHECKED_MAX = 1000, 16


def check_labels(labels, n: int, name: str, default_prefix: str) -> tuple[str, ...]:
    """Tuple of ``n`` unique string labels (defaults ``prefix0, prefix1, ...``)."""
    if labels is None:
        return tuple(f"{default_prefix}{i}" for i in range(n))
    if type(labels) is tuple and len(labels) == n and _CHECKED.get(id(labels)) is labels:
        return labels
    if isinstance(labels, str) or not isinstance(labels, Sequence | np.ndarray):
        raise TypeError(f"{name} must be a sequence of {n} strings, got {type(labels).__name__}")
    out = tuple(labels)
    if len(out) != n:
        what = {"s": "sensor: axis 1 of H[f, sensor, actuator]",
                "a": "actuator: axis 2 of H[f, sensor, actuator]"}.get(
                    default_prefix, default_prefix.rstrip("_"))
        hint = (" (sensor and actuator axes of H swapped? H.transpose(0, 2, 1))"
                if default_prefix in ("s", "a") else "")
        raise ValueError(f"{name} must have {n} labels (one per {what}), got {len(out)}{hint}")
    if set(map(type, out)) - {str}:                  # exact str needs no conversion
        for lab in out:
            if not isinstance(lab, str | np.str_):
                raise TypeError(f"{name} must contain strings, got {type(lab).__name__}")
        out = tuple(str(lab) for lab in out)
    if len(set(out)) != len(out):
        raise ValueError(f"{name} must be unique, got duplicates")
    if len(out) >= _CHECKED_MIN:
        with _CHECKED_LOCK:
            while len(_CHECKED) >= _CHECKED_MAX:
                _CHECKED.pop(next(iter(_CHECKED)))
            _CHECKED[id(out)] = out
    return out


def check_collocated(collocated, ns: int, na: int, name: str = "collocated",
                     sensors: Sequence[str] | None = None,
                     actuators: Sequence[str] | None = None) -> tuple[tuple[int, int], ...]:
    """Collocated (sensor, actuator) index pairs, in range; labels are accepted too.

    ``collocated`` is one pair ``(s, a)`` (two labels or indices) or a sequence of pairs; a
    pair given twice is kept once (in the order first given).
    """
    if collocated is None:
        return ()
    if isinstance(collocated, str | bytes):
        raise TypeError(f"{name} must be a (sensor, actuator) pair or a sequence of pairs, "
                        f"got the string {collocated!r}")
    if _is_pair(collocated):
        collocated = [collocated]
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
    return tuple(dict.fromkeys(out))            # a pair given twice is one pair


def _is_pair(x) -> bool:
    """True for one ``(sensor, actuator)`` pair: two labels or integer indices."""
    try:
        items = list(x)
    except TypeError:
        return False
    return len(items) == 2 and all(isinstance(v, str | np.str_ | int | np.integer)
                                   and not isinstance(v, bool) for v in items)


class BandError(TypeError, ValueError):
    """A band that is not a pair of numbers: both a ``TypeError`` (wrong kind of argument)
    and a ``ValueError`` (bad value), so callers catching either keep working (in the
    manner of numpy's ``AxisError``, a ``ValueError`` and an ``IndexError``)."""


def check_band(band, name: str = "band", *, infinite: bool = False) -> tuple[float, float]:
    """The one band checker: ``(fmin, fmax)`` in Hz with ``0 <= fmin < fmax``.

    Parameters
    ----------
    band : (float, float)
        Frequency band in Hz.
    name : str
        Argument name used in error messages.
    infinite : bool
        Accept ``fmax = inf`` (integrals over ``(fmin, inf)``); otherwise ``fmax`` must be
        finite.

    Returns
    -------
    (float, float)

    Raises
    ------
    BandError
        ``band`` is not a pair of numbers (a ``TypeError`` and a ``ValueError``).
    ValueError
        Negative or non-finite ``fmin``, infinite ``fmax`` when not allowed, NaN, or an
        empty band ``fmin >= fmax``.
    """
    try:
        if isinstance(band, str | bytes | dict):
            raise TypeError("not a pair")
        vals = tuple(band)
        if any(isinstance(v, str | bytes | complex | np.complexfloating) for v in vals):
            raise TypeError("not real numbers")
        lo, hi = (float(v) for v in vals)
    except (TypeError, ValueError):
        raise BandError(f"{name} must be a pair (fmin, fmax) in Hz, got {band!r:.60}") from None
    if np.isnan(lo) or np.isnan(hi) or not np.isfinite(lo):
        raise ValueError(f"{name} must hold finite frequencies (Hz), got ({lo}, {hi})")
    if np.isinf(hi) and not infinite:
        raise ValueError(f"{name} must be finite, got ({lo:g}, {hi:g})")
    if lo < 0:
        raise ValueError(f"{name} must satisfy 0 <= fmin (Hz), got ({lo:g}, {hi:g})")
    if not lo < hi:
        raise ValueError(f"{name} must satisfy fmin < fmax (Hz), got ({lo:g}, {hi:g}): "
                         "empty band")
    return lo, hi


# ----------------------------------------------------------------------------------------
# python-control signal names
# ----------------------------------------------------------------------------------------
#: suffix of input signal names (API.md): actuator ``"N3.z"`` is input ``N3_z_u``
def readonly(arr: np.ndarray | None) -> np.ndarray | None:
    if arr is None:
        return None
    arr.setflags(write=False)
    return arr
