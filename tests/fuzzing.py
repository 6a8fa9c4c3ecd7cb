"""Machinery of the public-API fuzz suite (``test_api_fuzz.py``): hostile values and the property.

An *entry* is one public call: a function of a dict of arguments, a factory of valid arguments
and, for each argument, an :class:`Arg` (a :class:`Kind` of value plus what the error may name).
A *kind* lists classes of values, each made from the valid value, with a disposition:

- ``OK``: a benign variant (a list for an array, a read-only array, a tuple of labels): the
  call must succeed;
- ``ANY``: may succeed (with a finite, well-formed result) or be refused;
- ``REFUSE``: must be refused (NaN, None where required, a reversed band, ...).

Refusing means a ``ValueError``/``TypeError`` (``OSError`` too for paths) whose message names
the argument (any of ``Arg.names``; for a class flagged ``relational`` -- a shape that no longer
agrees with another argument -- any argument of the call).  Any other exception, a hang, a
result with NaN/inf, or an input modified in place fails the property.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import warnings
from collections.abc import Callable
from typing import Any

import numpy as np
import scipy.sparse as sp
from hypothesis import strategies as st

OK, ANY, REFUSE = "ok", "any", "refuse"


@dataclasses.dataclass(frozen=True)
class Cls:
    """A class of values: ``make(draw, valid) -> value``."""

    make: Callable
    fate: str = ANY
    relational: bool = False


@dataclasses.dataclass(frozen=True)
class Kind:
    classes: dict

    def but(self, **fates) -> Kind:
        """Copy with some classes' fates changed (``None`` drops the class)."""
        out = dict(self.classes)
        for name, fate in fates.items():
            if fate is None:
                out.pop(name, None)
            elif isinstance(fate, Cls):
                out[name] = fate
            else:
                out[name] = dataclasses.replace(out[name], fate=fate)
        return Kind(out)


@dataclasses.dataclass(frozen=True)
class Arg:
    kind: Kind
    names: tuple = ()            # names an error about this argument may use (default: its own)
    template: Any = None         # the value classes are made from when the valid one is None


@dataclasses.dataclass(frozen=True)
class Entry:
    """One public call of the table."""

    name: str
    call: Callable[[dict], Any]
    args: Callable[[], dict]
    kinds: dict                  # argument name -> Arg or Kind
    check: Callable | None = None
    weight: float = 1.0          # examples relative to the profile's max_examples
    errors: tuple = (ValueError, TypeError)
    seconds: float = 30.0        # deadline of one call
    nan_ok: bool = False         # the result may hold NaN by design (e.g. gaps of a plot line)


def arg(entry: Entry, name: str) -> Arg:
    a = entry.kinds[name]
    return a if isinstance(a, Arg) else Arg(a)


# ----------------------------------------------------------------------------------------
# value makers
# ----------------------------------------------------------------------------------------
def _a(v):
    return np.array(v, copy=True)


def _poke(draw, v, value):
    a = _a(v)
    if a.size == 0:
        return a
    if value is not None and np.iscomplexobj(value) and not np.iscomplexobj(a):
        a = a.astype(complex)
    if not np.issubdtype(a.dtype, np.inexact):
        a = a.astype(float)
    i = draw(st.integers(0, a.size - 1))
    a.flat[i] = value
    return a


def _scaled(draw, v, lo, hi):
    a = _a(v).astype(complex if np.iscomplexobj(v) else float)
    m = float(np.abs(a).max(initial=0.0))
    e = draw(st.integers(lo, hi))
    return a / m * 10.0 ** e if m > 0 else a


def _reshape_axis(draw, v, grow: bool):
    a = _a(v)
    if a.ndim == 0:
        return a.reshape(1)
    ax = draw(st.integers(0, a.ndim - 1))
    if grow:
        return np.concatenate([a, np.take(a, [0], axis=ax)], axis=ax)
    return np.take(a, range(max(a.shape[ax] - 1, 0)), axis=ax)


def _readonly(v):
    a = _a(v)
    a.setflags(write=False)
    return a


def _fixed(value):
    return lambda draw, v: copy.deepcopy(value)


def _pick(*values):
    return lambda draw, v: copy.deepcopy(draw(st.sampled_from(values)))


def array(real: bool = True, optional: bool = False, ndim_free: bool = False) -> Kind:
    """A numeric array that must be finite (real or complex)."""
    c = {
        "nan": Cls(lambda d, v: _poke(d, v, np.nan), REFUSE),
        "inf": Cls(lambda d, v: _poke(d, v, d(st.sampled_from([np.inf, -np.inf]))), REFUSE),
        "huge": Cls(lambda d, v: _scaled(d, v, 100, 307)),
        "tiny": Cls(lambda d, v: _scaled(d, v, -320, -100)),
        "zero": Cls(lambda d, v: np.zeros_like(_a(v))),
        "negative": Cls(lambda d, v: -_a(v).astype(float) if _a(v).dtype == bool else -_a(v)),
        "bool": Cls(lambda d, v: _a(v) != 0),
        "int": Cls(lambda d, v: np.round(np.real(_a(v))).astype(np.int64)),
        "object_numbers": Cls(lambda d, v: _a(v).astype(object)),
        "object_none": Cls(lambda d, v: np.full(np.shape(v), None, dtype=object), REFUSE),
        "string": Cls(_pick("abc", "1.0", b"1"), REFUSE),
        "string_array": Cls(lambda d, v: np.full(np.shape(v), "x"), REFUSE),
        "none": Cls(_fixed(None), OK if optional else REFUSE),
        "dict": Cls(_fixed({"a": 1}), REFUSE),
        "ndim_up": Cls(lambda d, v: _a(v)[..., None], ANY if ndim_free else REFUSE, True),
        "ndim_down": Cls(lambda d, v: _a(v).reshape(-1)[:1].reshape(()) if np.ndim(v) <= 1
                         else _a(v)[0], ANY if ndim_free else REFUSE, True),
        "grow": Cls(lambda d, v: _reshape_axis(d, v, True), ANY, True),
        "shrink": Cls(lambda d, v: _reshape_axis(d, v, False), ANY, True),
        "readonly": Cls(lambda d, v: _readonly(v), OK),
        "list": Cls(lambda d, v: _a(v).tolist(), OK),
    }
    if real:
        c["complex"] = Cls(lambda d, v: _a(v) + 1j, REFUSE)
        c["complex_zero_imag"] = Cls(lambda d, v: _a(v) + 0j, OK)
    else:
        c["real"] = Cls(lambda d, v: np.real(_a(v)).copy(), OK)
    return Kind(c)


def mask_kind(optional: bool = True) -> Kind:
    """A boolean mask, one entry per item."""
    return Kind({
        "none": Cls(_fixed(None), OK if optional else REFUSE),
        "short": Cls(lambda d, v: _a(v)[:-1], REFUSE, True),
        "long": Cls(lambda d, v: np.concatenate([_a(v), [True]]), REFUSE, True),
        "ints": Cls(lambda d, v: _a(v).astype(int), OK),
        "floats": Cls(lambda d, v: _a(v).astype(float) * 0.5),
        "nan": Cls(lambda d, v: np.full(np.shape(v), np.nan), REFUSE),
        "string": Cls(_fixed("yes"), REFUSE),
        "strings": Cls(lambda d, v: np.full(np.shape(v), "no"), REFUSE),
        "2d": Cls(lambda d, v: _a(v)[None, :], REFUSE, True),
        "list": Cls(lambda d, v: _a(v).tolist(), OK),
    })


def freq_kind() -> Kind:
    """Frequencies in Hz: finite, positive, strictly increasing."""
    def dup(d, v):
        a = _a(v)
        if a.size < 2:
            return np.repeat(a, 2)
        i = d(st.integers(1, a.size - 1))
        a[i] = a[i - 1]
        return a
    return Kind({
        "nan": Cls(lambda d, v: _poke(d, v, np.nan), REFUSE),
        "inf": Cls(lambda d, v: _poke(d, v, np.inf), REFUSE),
        "zero": Cls(lambda d, v: np.concatenate([[0.0], _a(v)]), REFUSE),
        "negative": Cls(lambda d, v: -_a(v)[::-1], REFUSE),
        "reversed": Cls(lambda d, v: _a(v)[::-1], REFUSE),
        "duplicate": Cls(dup, REFUSE),
        "empty": Cls(_fixed(np.zeros(0)), REFUSE),
        "2d": Cls(lambda d, v: _a(v)[:, None], REFUSE),
        "complex": Cls(lambda d, v: _a(v) + 1j, REFUSE),
        "string": Cls(_pick("10 Hz", ["a", "b"]), REFUSE),
        "none": Cls(_fixed(None), REFUSE),
        "huge": Cls(lambda d, v: _a(v) * 10.0 ** d(st.integers(100, 305))),
        "tiny": Cls(lambda d, v: _a(v) * 10.0 ** -d(st.integers(100, 320))),
        "single": Cls(lambda d, v: _a(v)[d(st.integers(0, len(v) - 1))]),
        "int": Cls(lambda d, v: np.unique(np.round(_a(v)).astype(int))),
        "readonly": Cls(lambda d, v: _readonly(v), OK),
        "list": Cls(lambda d, v: _a(v).tolist(), OK),
    })


def band_kind(infinite_ok: bool = False) -> Kind:
    """``(fmin, fmax)`` in Hz."""
    return Kind({
        "reversed": Cls(lambda d, v: (v[1], v[0]), REFUSE),
        "empty": Cls(lambda d, v: (v[0], v[0]), REFUSE),
        "nan": Cls(_pick((np.nan, 10.0), (1.0, np.nan)), REFUSE),
        "inf_low": Cls(_fixed((np.inf, np.inf)), REFUSE),
        "inf_high": Cls(lambda d, v: (v[0], np.inf), ANY if infinite_ok else REFUSE),
        "negative": Cls(lambda d, v: (-1.0, v[1]), REFUSE),
        "string": Cls(_pick("8-60", ("a", "b")), REFUSE),
        "none": Cls(_fixed(None), REFUSE),
        "scalar": Cls(lambda d, v: v[1], REFUSE),
        "triple": Cls(lambda d, v: (v[0], v[1], v[1] + 1), REFUSE),
        "complex": Cls(lambda d, v: (v[0] + 1j, v[1]), REFUSE),
        "outside": Cls(lambda d, v: (1e6, 2e6)),
        "huge": Cls(lambda d, v: (1e250, 1e300)),
        "tiny": Cls(lambda d, v: (0.0, 1e-300)),
        "list": Cls(lambda d, v: list(v), OK),
        "array": Cls(lambda d, v: np.array(v, float), OK),
    })


def number(positive: bool = True, optional: bool = False, zero: str = REFUSE,
           negative: str | None = None) -> Kind:
    """A real scalar (gain, sampling frequency, cut-off, tolerance)."""
    neg = negative if negative is not None else (REFUSE if positive else ANY)
    return Kind({
        "nan": Cls(_fixed(float("nan")), REFUSE),
        "inf": Cls(_pick(float("inf"), -float("inf")), REFUSE),
        "zero": Cls(_fixed(0.0), zero if positive else ANY),
        "negative": Cls(lambda d, v: -abs(float(v)) if float(v) else -1.0, neg),
        "huge": Cls(_pick(1e300, 1e200, 1e150)),
        "tiny": Cls(_pick(1e-300, 1e-200, 5e-324)),
        "complex": Cls(lambda d, v: complex(v) + 1j, REFUSE),
        "string": Cls(_pick("1", "abc"), REFUSE),
        "none": Cls(_fixed(None), OK if optional else REFUSE),
        "array": Cls(lambda d, v: np.array([v, v], float), REFUSE),
        "list": Cls(lambda d, v: [v], REFUSE),
        "bool": Cls(_fixed(True)),
        "numpy": Cls(lambda d, v: np.float64(v), OK),
        "int": Cls(lambda d, v: math.ceil(float(v)) if math.isfinite(float(v)) else 1),
    })


def integer(minimum: int = 1, optional: bool = False) -> Kind:
    """A count (number of modes, samples, averages, iterations)."""
    return Kind({
        "below": Cls(_fixed(minimum - 1), REFUSE),
        "negative": Cls(_fixed(-3), REFUSE),
        "float": Cls(lambda d, v: float(v) + 0.5, REFUSE),
        "float_integral": Cls(lambda d, v: float(v)),
        "nan": Cls(_fixed(float("nan")), REFUSE),
        "inf": Cls(_fixed(float("inf")), REFUSE),
        "huge": Cls(_pick(2**63, 10**30)),
        "string": Cls(_pick("3", "x"), REFUSE),
        "none": Cls(_fixed(None), OK if optional else REFUSE),
        "bool": Cls(_fixed(True)),
        "numpy": Cls(lambda d, v: np.int64(v), OK),
        "array": Cls(lambda d, v: np.array([v, v]), REFUSE),
    })


def quantity_kind(optional: bool = False) -> Kind:
    return Kind({
        "unknown": Cls(_pick("force", "", "displacements", "strain"), REFUSE),
        "none": Cls(_fixed(None), OK if optional else REFUSE),
        "int": Cls(_fixed(1), REFUSE),
        "bytes": Cls(_fixed(b"velocity"), REFUSE),
        "list": Cls(_fixed(["velocity"]), REFUSE),
        "upper": Cls(_pick("VELOCITY", "Acceleration")),
        "abbreviation": Cls(_pick("acc", "accel", "disp", "vel"), REFUSE),
        "standard_name": Cls(_pick("receptance", "mobility", "accelerance", "inertance"), OK),
        "other": Cls(_pick("displacement", "velocity", "acceleration"), OK),
    })


def labels_kind(n_fixed: bool = True) -> Kind:
    """Unique string labels, one per channel (``None``: defaults)."""
    def grow(d, v):
        return list(v) + ["extra"]
    return Kind({
        "duplicate": Cls(lambda d, v: [v[0]] * len(v) if len(v) > 1 else [v[0], v[0]], REFUSE),
        "short": Cls(lambda d, v: list(v)[:-1], REFUSE if n_fixed else ANY, True),
        "long": Cls(grow, REFUSE if n_fixed else ANY, True),
        "ints": Cls(lambda d, v: list(range(len(v))), REFUSE),
        "mixed": Cls(lambda d, v: [None] + list(v)[1:], REFUSE),
        "string": Cls(lambda d, v: "".join(v), REFUSE),
        "dict": Cls(lambda d, v: {lab: 0 for lab in v}),
        "number": Cls(_fixed(3), REFUSE),
        "dotted_collision": Cls(lambda d, v: (["a.b", "a_b"] + [f"z{i}" for i in range(len(v))]
                                              )[:len(v)]),
        "signal_collision": Cls(lambda d, v: (["x_u", "x"] + [f"q{i}" for i in range(len(v))]
                                              )[:len(v)]),
        "odd_chars": Cls(lambda d, v: [f"{lab}|\n -é" for lab in v]),
        "blank": Cls(lambda d, v: [""] + [f"b{i}" for i in range(1, len(v))]),
        "none": Cls(_fixed(None), OK),
        "tuple": Cls(lambda d, v: tuple(v), OK),
        "numpy": Cls(lambda d, v: np.array(v), OK),
    })


def collocated_kind(ns: int, na: int) -> Kind:
    return Kind({
        "sensor_range": Cls(_fixed([(ns, 0)]), REFUSE),
        "actuator_range": Cls(_fixed([(0, na)]), REFUSE),
        "negative": Cls(_fixed([(-1, 0)]), REFUSE),
        "unknown_label": Cls(_fixed([("nowhere", 0)]), REFUSE),
        "float": Cls(_fixed([(0.0, 0.0)]), REFUSE),
        "bool": Cls(_fixed([(True, False)]), REFUSE),
        "triple": Cls(_fixed([(0, 0, 0)]), REFUSE),
        "flat": Cls(_fixed((0, 0)), OK),              # one pair (API.md: "one pair or a list")
        "string": Cls(_fixed("0,0"), REFUSE),
        "number": Cls(_fixed(1), REFUSE),
        "nan": Cls(_fixed([(float("nan"), 0)]), REFUSE),
        "duplicate": Cls(_fixed([(0, 0), (0, 0)])),
        "empty": Cls(_fixed([])),
        "numpy": Cls(lambda d, v: np.array(v if v else [(0, 0)]), OK),
    })


def obj_kind(*alternatives, optional: bool = False) -> Kind:
    """An object argument (model, system, FRF): wrong types must be refused.

    ``alternatives`` are ``(name, value, fate)`` for other objects of interest (a
    TransferFunction where a StateSpace is expected, an unstable system, ...).
    """
    c = {
        "none": Cls(_fixed(None), OK if optional else REFUSE),
        "string": Cls(_fixed("model"), REFUSE),
        "number": Cls(_fixed(3.0), REFUSE),
        "list": Cls(_fixed([1.0, 2.0]), REFUSE),
        "dict": Cls(_fixed({"A": 1}), REFUSE),
        "array": Cls(_fixed(np.eye(2)), REFUSE),
    }
    for name, value, fate in alternatives:
        c[name] = Cls(_fixed(value) if not callable(value) else _made(value), fate)
    return Kind(c)


def _made(factory):
    return lambda draw, v: factory()


def path_kind(tmp, must_exist: bool, suffix: bool = False) -> Kind:
    """A file path; ``suffix``: a writer that appends its suffix (a directory name is fine)."""
    return Kind({
        "missing_dir": Cls(lambda d, v: str(tmp / "no" / "such" / "dir" / "f"), REFUSE),
        "directory": Cls(lambda d, v: str(tmp), ANY if suffix else REFUSE),
        "none": Cls(_fixed(None), REFUSE),
        "number": Cls(_fixed(3.5), REFUSE),
        "empty": Cls(_fixed(""), REFUSE),
        "nul": Cls(_fixed("a\0b"), REFUSE),
        "missing": Cls(lambda d, v: str(tmp / ("missing.file" if must_exist else "new.file")),
                       REFUSE if must_exist else ANY),
    })


def label_kind() -> Kind:
    """One string label."""
    return Kind({"none": Cls(_fixed(None), REFUSE), "number": Cls(_fixed(3), REFUSE),
                 "list": Cls(_fixed(["a"]), REFUSE), "empty": Cls(_fixed(""), REFUSE),
                 "dotted": Cls(_fixed("a.b"), OK), "numpy": Cls(lambda d, v: np.str_(v), OK)})


def flag_kind() -> Kind:
    return Kind({"int": Cls(_fixed(1)), "string": Cls(_fixed("yes")), "none": Cls(_fixed(None)),
                 "numpy": Cls(_fixed(np.True_))})


def choice_kind(*valid) -> Kind:
    return Kind({"unknown": Cls(_fixed("no-such-choice"), REFUSE),
                 "none": Cls(_fixed(None)),
                 "number": Cls(_fixed(1), REFUSE),
                 "other": Cls(_pick(*valid), OK)})


# ----------------------------------------------------------------------------------------
# the property
# ----------------------------------------------------------------------------------------
class _Obj:
    """An object argument: the object itself plus copies of its arrays (models, systems)."""

    def __init__(self, obj):
        self.obj = obj
        self.state = {k: np.array(v, copy=True) for k, v in _arrays(obj).items()}

    def __eq__(self, other):
        return isinstance(other, _Obj) and self.obj is other.obj and all(
            np.array_equal(v, other.state[k], equal_nan=True) for k, v in self.state.items())


def _arrays(obj) -> dict:
    if type(obj).__name__ == "StateSpace":
        return {m: getattr(obj, m) for m in "ABCD"}
    names = [f.name for f in dataclasses.fields(obj)] if dataclasses.is_dataclass(obj) else \
        list(getattr(type(obj), "__slots__", ()))
    out = {}
    for nm in names:
        v = getattr(obj, nm, None)
        if isinstance(v, np.ndarray) and v.dtype != object:
            out[nm] = v
    return out


def snapshot(value):
    """Copy of an argument to compare after the call: arrays and containers copied, other
    objects kept with copies of their arrays (so that an object changed in place is seen)."""
    if isinstance(value, np.ndarray):
        return value.copy()
    if sp.issparse(value):
        return value.copy()
    if isinstance(value, list):
        return [snapshot(v) for v in value]
    if isinstance(value, tuple):
        return tuple(snapshot(v) for v in value)
    if isinstance(value, dict):
        return {k: snapshot(v) for k, v in value.items()}
    if value is None or isinstance(value, str | bytes | int | float | complex | np.generic):
        return value
    return _Obj(value)


def same(a, b) -> bool:
    """``b`` (the argument after the call) equals its snapshot ``a``."""
    if isinstance(a, _Obj):
        return a == _Obj(b)
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        if not (isinstance(a, np.ndarray) and isinstance(b, np.ndarray)):
            return False
        if a.shape != b.shape or a.dtype != b.dtype:
            return False
        if a.dtype.kind in "fc":
            return bool(np.array_equal(a, b, equal_nan=True))
        return bool(np.all(a == b)) if a.dtype != object else all(
            same(x, y) for x, y in zip(a.ravel(), b.ravel()))
    if sp.issparse(a):
        return sp.issparse(b) and a.shape == b.shape and (a != b).nnz == 0
    if isinstance(a, list | tuple):
        return type(a) is type(b) and len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return type(a) is type(b) and bool(a == b)


def finite(value, where: str = "result", seen=None) -> list[str]:
    """Places where ``value`` holds NaN/inf (numeric arrays, matrices, models, containers)."""
    seen = set() if seen is None else seen
    if id(value) in seen:
        return []
    seen.add(id(value))
    bad = []
    if isinstance(value, np.ndarray):
        if value.dtype.kind in "fc" and not np.all(np.isfinite(value)):
            bad.append(where)
        elif value.dtype == object:
            for i, v in enumerate(value.ravel()[:50]):
                bad += finite(v, f"{where}[{i}]", seen)
    elif sp.issparse(value):
        bad += finite(value.data, where, seen)
    elif isinstance(value, float | complex | np.floating | np.complexfloating):
        if not np.isfinite(value):
            bad.append(where)
    elif isinstance(value, list | tuple):
        for i, v in enumerate(value[:200]):
            bad += finite(v, f"{where}[{i}]", seen)
    elif isinstance(value, dict):
        for k, v in value.items():
            bad += finite(v, f"{where}[{k!r}]", seen)
    elif type(value).__name__ in ("StateSpace", "LinearIOSystem"):
        for m in "ABCD":
            bad += finite(np.asarray(getattr(value, m)), f"{where}.{m}", seen)
    elif dataclasses.is_dataclass(value) or hasattr(value, "__slots__"):
        names = ([f.name for f in dataclasses.fields(value)] if dataclasses.is_dataclass(value)
                 else list(getattr(type(value), "__slots__", ())))
        for nm in names:
            if nm in ("info", "cost") or nm.startswith("_"):
                continue
            bad += finite(getattr(value, nm, None), f"{where}.{nm}", seen)
    return bad


def _repr(value) -> str:
    try:
        return repr(value)[:200]
    except Exception as exc:                 # noqa: BLE001 -- a broken repr is reported, not raised
        return f"<{type(value).__name__} whose repr raises {type(exc).__name__}: {exc}>"


def draw_case(entry: Entry, draw, excluded=frozenset()):
    """Valid arguments with 0, 1 or 2 of them replaced by drawn classes of values.

    Returns ``(args, mutated)`` with ``mutated`` mapping argument -> class name.
    ``excluded`` holds ``(argument, class)`` pairs not to draw (known failures).
    """
    args = entry.args()
    choices = [(a, c) for a in entry.kinds for c in arg(entry, a).kind.classes
               if (a, c) not in excluded]
    k = draw(st.sampled_from([1, 1, 1, 1, 1, 1, 2, 0])) if choices else 0
    mutated = {}
    for _ in range(k):
        left = [p for p in choices if p[0] not in mutated]
        if not left:
            break
        a, c = draw(st.sampled_from(left))
        spec = arg(entry, a)
        base = args[a] if args[a] is not None else spec.template
        args[a] = spec.kind.classes[c].make(draw, 1.0 if base is None else base)
        mutated[a] = c
    return args, mutated


def expect(entry: Entry, args: dict, mutated: dict, deadline) -> str:
    """Run the call and check the property; returns the outcome ("ok" or "refused")."""
    fates = {a: arg(entry, a).kind.classes[c] for a, c in mutated.items()}
    before = {k: snapshot(v) for k, v in args.items()}
    what = ", ".join(f"{a}={c}" for a, c in mutated.items()) or "valid arguments"
    case = f"{entry.name} with {what}"
    try:
        with deadline(entry.seconds), warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")
            result = entry.call(dict(args))
    except entry.errors as exc:
        msg = str(exc)
        assert not fates or not all(f.fate == OK for f in fates.values()), (
            f"{case}: a valid input was refused: {type(exc).__name__}: {msg}")
        if not fates:
            raise AssertionError(f"{case}: valid arguments refused: "
                                 f"{type(exc).__name__}: {msg}") from exc
        names = set()
        for a in mutated:
            names |= {a, *arg(entry, a).names}
            if fates[a].relational:
                names |= set(entry.kinds) | set(args)
        assert any(n in msg for n in names), (
            f"{case}: the message names none of {sorted(names)}: {type(exc).__name__}: {msg}")
        outcome = "refused"
    except Exception as exc:
        raise AssertionError(f"{case}: {type(exc).__name__} escaped: {exc}") from exc
    else:
        refuse = [a for a, f in fates.items() if f.fate == REFUSE]
        assert not refuse, f"{case}: accepted (the contract says refuse), returned {_repr(result)}"
        bad = [] if entry.nan_ok else finite(result)
        assert not bad, f"{case}: NaN/inf in {bad[:5]} of the result"
        if entry.check is not None:
            try:
                entry.check(result, args)
            except AssertionError as exc:
                raise AssertionError(f"{case}: ill-formed result: {exc}") from exc
            except Exception as exc:
                raise AssertionError(f"{case}: checking the result raised "
                                     f"{type(exc).__name__}: {exc}") from exc
        outcome = "ok"
    finally:
        changed = [k for k in args if not same(before[k], args[k])]
        assert not changed, f"{case}: modified its input(s) {changed} in place"
    return outcome
