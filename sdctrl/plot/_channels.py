"""What the response figures draw: systems turned into FRFs, channels chosen by label (internal).

Every overlay item (an :class:`~sdctrl.FRF`, a model with ``frf(freq, quantity)`` or a
python-control system) becomes an FRF in one quantity.  Channels are matched across items
through the house rule for signal names (API.md): sensor ``"N42.y"`` is output ``N42_y``,
actuator ``"N42.y"`` is input ``N42_y_u``.  So a label is compared by its *key*: ``.``
replaced by ``_`` and, for actuators, a trailing ``_u`` dropped.
"""

from __future__ import annotations

import warnings

import numpy as np

from sdctrl._lib.validate import check_freq, check_quantity
from sdctrl._lib.signals import signal_name
from sdctrl.data._frf import FRF

#: channels shown by default when the data has no collocated pair
MAX_DEFAULT_CHANNELS = 12


def _is_lti(obj) -> bool:
    try:
        import control
    except ImportError:  # pragma: no cover - control is a hard dependency
        return False
    return isinstance(obj, control.StateSpace | control.TransferFunction)


def _is_item(obj) -> bool:
    return isinstance(obj, FRF) or _is_lti(obj) or callable(getattr(obj, "frf", None))


def as_list(systems, name: str) -> list:
    """One item or a sequence of items (FRF, model with ``frf``, StateSpace)."""
    if _is_item(systems):
        return [systems]
    if isinstance(systems, list | tuple) and systems and all(_is_item(s) for s in systems):
        return list(systems)
    raise TypeError(f"{name} must be an FRF, a model with a frf(freq, quantity) method or a "
                    "python-control StateSpace, or a non-empty sequence of them, got "
                    f"{type(systems).__name__}")


def to_frfs(items: list, freq=None, quantity: str | None = None, name: str = "systems"):
    """Evaluate every item as an FRF of one quantity.

    Returns ``(frfs, quantity)``.  FRFs keep their own grid (converted by ``j w`` powers);
    models and StateSpace objects are evaluated on ``freq`` (Hz), by default the grid of
    the first FRF.  A StateSpace's outputs are taken to be ``quantity`` per unit input.
    """
    first = next((it for it in items if isinstance(it, FRF)), None)
    q = check_quantity(quantity if quantity is not None else
                       (first.quantity if first is not None else "displacement"), "quantity")
    grid = None
    if freq is not None:
        grid = check_freq(freq, "freq")
    elif first is not None:
        grid = first.freq
    out = []
    for it in items:
        if isinstance(it, FRF):
            out.append(it.to(q))
            continue
        if grid is None:
            raise ValueError(f"freq must be given (Hz) when {name} holds no FRF to take the "
                             "frequency grid from")
        out.append(FRF.from_system(it, grid, q))
    return out, q


def key(label: str, actuator: bool) -> str:
    """Label as compared across FRFs and StateSpace signal names."""
    k = signal_name(label)
    return k.removesuffix("_u") if actuator and k != "_u" else k


def _find(item, labels, actuator: bool, name: str) -> int:
    side = "actuator" if actuator else "sensor"
    if isinstance(item, bool) or not isinstance(item, str | int | np.integer):
        raise TypeError(f"{name} must hold {side} labels (str) or indices (int), got {item!r}")
    if not isinstance(item, str):
        if not -len(labels) <= item < len(labels):
            raise ValueError(f"{name}: {side} index {item} out of range for {len(labels)} "
                             f"{side}s")
        return int(item) % len(labels)
    if item in labels:
        return list(labels).index(item)
    keys = [key(lab, actuator) for lab in labels]
    k = key(item, actuator)
    if k in keys:
        return keys.index(k)
    shown = ", ".join(repr(lab) for lab in labels[:8]) + (", ..." if len(labels) > 8 else "")
    raise ValueError(f"{name}: unknown {side} label {item!r} (known: {shown})")


def _is_pair(obj) -> bool:
    return (isinstance(obj, tuple | list) and len(obj) == 2
            and all(isinstance(x, str | int | np.integer) for x in obj))


def select(ref: FRF, channels=None, sensors=None, actuators=None,
           max_default: int = MAX_DEFAULT_CHANNELS) -> list[tuple[int, int]]:
    """(sensor, actuator) index pairs of ``ref`` chosen by pairs, or by sensors x actuators.

    Default: the collocated pairs of ``ref``; else the pairs whose sensor and actuator have
    the same label (a model or StateSpace of a test keeps the labels, not the pairs); else
    every pair, at most ``max_default`` (with a warning naming how to choose).
    """
    if channels is not None and (sensors is not None or actuators is not None):
        raise ValueError("channels cannot be combined with sensors/actuators: give "
                         "(sensor, actuator) pairs or the sensors and actuators to cross")
    if channels is not None:
        pairs = [channels] if _is_pair(channels) else channels
        if isinstance(pairs, str) or not isinstance(pairs, list | tuple) or not pairs:
            raise TypeError("channels must be a (sensor, actuator) pair or a non-empty sequence "
                            f"of pairs (labels or indices), got {channels!r}")
        out = []
        for p in pairs:
            if not _is_pair(p):
                raise TypeError(f"channels must hold (sensor, actuator) pairs, got {p!r}")
            out.append((_find(p[0], ref.sensors, False, "channels"),
                        _find(p[1], ref.actuators, True, "channels")))
        return out
    if sensors is not None or actuators is not None:
        def many(sel, labels, act, nm):
            if sel is None:
                return list(range(len(labels)))
            sel = [sel] if isinstance(sel, str | int | np.integer) else list(sel)
            if not sel:
                raise ValueError(f"{nm} selects no channel")
            return [_find(x, labels, act, nm) for x in sel]
        si = many(sensors, ref.sensors, False, "sensors")
        ai = many(actuators, ref.actuators, True, "actuators")
        return [(s, a) for s in si for a in ai]
    if ref.collocated:
        return list(ref.collocated)
    skeys = [key(lab, False) for lab in ref.sensors]
    same = [(skeys.index(k), a) for a, k in enumerate(key(lab, True) for lab in ref.actuators)
            if k in skeys]
    if same:                                  # sensor and actuator on one DOF label
        return same
    ns, na = ref.H.shape[1:]
    pairs = [(s, a) for s in range(ns) for a in range(na)]
    if len(pairs) > max_default:
        warnings.warn(f"showing the first {max_default} of {len(pairs)} channels; choose them "
                      "with channels=[(sensor, actuator), ...] or sensors=/actuators=",
                      UserWarning, stacklevel=3)
        pairs = pairs[:max_default]
    return pairs


def locate(frfs: list[FRF], pairs, name: str = "systems") -> list[list[tuple[int, int] | None]]:
    """Index of each reference channel in every FRF (None where an item lacks it).

    Channels are found by key (see module notes).  An item whose labels share nothing with
    the reference (e.g. default ``s0``/``y[0]`` names) but has its shape is matched by
    position.  An item that shows in no panel is an error.
    """
    ref = frfs[0]
    rs = [key(lab, False) for lab in ref.sensors]
    ra = [key(lab, True) for lab in ref.actuators]
    out = []
    for i, f in enumerate(frfs):
        fs = [key(lab, False) for lab in f.sensors]
        fa = [key(lab, True) for lab in f.actuators]
        positional = (f.H.shape[1:] == ref.H.shape[1:]
                      and not (set(fs) & set(rs)) and not (set(fa) & set(ra)))
        row = []
        for s, a in pairs:
            if positional:
                row.append((s, a))
            elif rs[s] in fs and ra[a] in fa:
                row.append((fs.index(rs[s]), fa.index(ra[a])))
            else:
                row.append(None)
        if all(r is None for r in row):
            raise ValueError(f"{name}[{i}] has none of the selected channels (its sensors "
                             f"{list(f.sensors)[:4]}..., actuators {list(f.actuators)[:4]}...)")
        out.append(row)
    return out


def align(ref: FRF, frf: FRF, name: str) -> tuple[list[int], list[int]]:
    """Sensor and actuator indices of ``frf`` in the order of ``ref`` (by key, else position)."""
    out = []
    for act, (rl, fl) in enumerate(((ref.sensors, frf.sensors), (ref.actuators, frf.actuators))):
        rk = [key(lab, bool(act)) for lab in rl]
        fk = [key(lab, bool(act)) for lab in fl]
        if not set(rk) & set(fk) and len(rk) == len(fk):
            out.append(list(range(len(fk))))
            continue
        missing = [lab for lab, k in zip(rl, rk) if k not in fk]
        if missing:
            side = "actuators" if act else "sensors"
            raise ValueError(f"{name} lacks {side} {missing[:4]} of the first system")
        out.append([fk.index(k) for k in rk])
    return out[0], out[1]


def legend_labels(labels, n: int, name: str = "labels") -> list[str]:
    """Legend entries given by the caller, one per item."""
    labels = [labels] if isinstance(labels, str) else [str(lab) for lab in labels]
    if len(labels) != n:
        raise ValueError(f"{name} must have one entry per system ({n}), got {len(labels)}")
    return labels
