"""FRF files in the Universal File Format, dataset 58 (through pyuff).

UFF 58 stores one function (one sensor/actuator pair) per dataset.  sdctrl writes double
complex ordinates, an explicit abscissa, binary by default (exact round trips).  Each record:

- response and reference node/direction from FE DOF labels (``"N42.y"`` -> node 42,
  direction +Y), so other tools place the data;
- ID line 1 ``sdctrl FRF``; ID line 2 the full labels, ``sdctrl:<sensor>|<actuator>``, with
  ``%``, ``|``, control and non-ASCII characters and leading/trailing blanks percent-encoded
  (UTF-8), so that any label up to the line's 80 characters survives; longer labels fall back to
  node/direction with a warning;
- ID line 4 ``sdctrl:<s>,<a> <ns>x<na> coh=<0|1> col=<k>``: the pair's place in the FRF
  matrix, its size, whether coherence records follow and, if ``k > 0``, that the pair is the
  ``k``-th collocated pair (0: not collocated).  The reader checks every pair of the matrix
  (and its coherence) is present exactly once: a truncated file is refused, never read small;
- ID line 5 ``sdctrl:axis=<f0>,<df>`` (exact hexadecimal floats) when the axis is written evenly
  spaced (ASCII files, and single-line FRFs, which pyuff cannot write unevenly);
- the measured quantity as the ordinate's specific data type (8 displacement, 11 velocity,
  12 acceleration; denominator 13 force), the units text as the ordinate units label (at most
  20 printable ASCII characters, else not stored, with a warning); coherence, when present, as
  function type 6 (ordinary) datasets.

Collocation: stored per pair by sdctrl (ID line 4).  Files of other tools cannot store it:
directions are read as positive (``-z`` is ``+z`` with the FRF negated: surveys often give the
hammer ``-3``) and a pair of equal labels (a driving point) is collocated, and no other.

Reading refuses, with a ``ValueError`` naming the file and the fault: what is not a regular file
(a FIFO or a device is never opened for reading, so nothing blocks), unterminated datasets or
bytes outside datasets (a truncated or damaged file), records whose point count disagrees with
their data, NaN/inf, inconsistent frequency axes, mixed quantities, duplicated or missing pairs,
and every failure of pyuff.  A path that cannot be opened raises an ``OSError`` naming it.
"""

from __future__ import annotations

import os
import re
import shutil
import urllib.parse
import warnings

import numpy as np

from sdctrl._lib.files import atomic_write, check_path, open_regular
from sdctrl.data._frf import FRF

__all__ = ["read_uff", "write_uff"]

_DIRS = {"x": 1, "y": 2, "z": 3, "rx": 4, "ry": 5, "rz": 6}
_DIR_NAMES = {v: k for k, v in _DIRS.items()}
_QTY_CODE = {"displacement": 8, "velocity": 11, "acceleration": 12}
_CODE_QTY = {v: k for k, v in _QTY_CODE.items()}
_FUNC_FRF = 4
_FUNC_COH = 6
_LABEL_RE = re.compile(r"^N?(\d{1,9})\.(-?)(x|y|z|rx|ry|rz)$", re.IGNORECASE)
_ID_PREFIX = "sdctrl:"
_PAIR_RE = re.compile(r"^sdctrl:(\d{1,9}),(\d{1,9}) (\d{1,9})x(\d{1,9}) coh=([01]) col=(\d{1,9})$")
_HEX = r"([-+]?0x[0-9a-f]+(?:\.[0-9a-f]*)?p[-+]?\d+)"
_AXIS_RE = re.compile(rf"^sdctrl:axis={_HEX},{_HEX}$")
#: ID line 3: the quantity and, for an impact test, the exponential window's time constant
_TAU_RE = re.compile(rf" tau={_HEX}$")
_LINE = 80


def _node_dir(label: str, fallback: int) -> tuple[int, int]:
    m = _LABEL_RE.match(label)
    if m is None:
        return fallback, 0
    sign = -1 if m.group(2) else 1
    return int(m.group(1)), sign * _DIRS[m.group(3).lower()]


def _label(node: int, direction: int) -> str:
    if direction == 0 or abs(direction) not in _DIR_NAMES:
        return f"N{node}"
    sign = "-" if direction < 0 else ""
    return f"N{node}.{sign}{_DIR_NAMES[abs(direction)]}"


def _escape(label: str, name: str) -> str:
    """Percent-encode what an 80-column ASCII ID line cannot hold or the reader would split on."""
    out = []
    for i, ch in enumerate(label):
        edge = ch == " " and (i == 0 or i == len(label) - 1)
        if ch in "%|" or not (" " <= ch <= "~") or edge:
            try:
                out.append("".join(f"%{b:02X}" for b in ch.encode("utf-8")))
            except UnicodeEncodeError:
                raise ValueError(f"{name} label {label!r} cannot be encoded in UTF-8") from None
        else:
            out.append(ch)
    return "".join(out)


def _unescape(text: str, path: str) -> str:
    try:
        return urllib.parse.unquote(text, errors="strict")
    except UnicodeDecodeError:
        raise ValueError(f"file {path!r}: label {text!r} is not valid percent-encoded "
                         "UTF-8") from None


# ------------------------------------------------------------------------------------------
# writing
# ------------------------------------------------------------------------------------------
def _units(frf: FRF) -> str:
    u = frf.units
    if u is None:
        return "NONE"
    if u.strip().upper() in ("", "NONE"):       # both read back as no units: refused up front
        raise ValueError(f"frf.units {u!r} cannot be written to UFF: UFF marks missing units "
                         "as NONE and reads an empty or NONE label back as units=None (build "
                         "the FRF with units=None, or save it with sdctrl.save)")
    if len(u) > 20 or u != u.strip() or not all(" " <= ch <= "~" for ch in u):
        raise ValueError(f"frf.units {u!r} cannot be written to UFF: a UFF units label holds at "
                         "most 20 printable ASCII characters without leading or trailing blanks "
                         "(build the FRF with shorter units, or save it with sdctrl.save)")
    return u


def _id2(sensor: str, actuator: str) -> str:
    id2 = f"{_ID_PREFIX}{_escape(sensor, 'sensor')}|{_escape(actuator, 'actuator')}"
    if len(id2) > _LINE:
        raise ValueError(f"frf labels ({sensor!r}, {actuator!r}) are too long for a UFF ID line "
                         f"({len(id2)} characters encoded, at most {_LINE}): shorten the sensor "
                         "and actuator labels, or save the FRF with sdctrl.save")
    return id2


def _axis(frf: FRF, binary: bool) -> tuple[dict, str]:
    """Abscissa fields for pyuff and the exact axis line (ID line 5)."""
    f = np.array(frf.freq, dtype=float)
    if f.size == 1:     # pyuff needs two abscissae; an even axis of one line is written
        return ({"abscissa_spacing": 1, "abscissa_min": float(f[0]), "abscissa_inc": 1.0,
                 "x": np.array([f[0], f[0] + 1.0])},
                f"{_ID_PREFIX}axis={float(f[0]).hex()},{(1.0).hex()}")
    df = np.diff(f)
    if not binary and np.allclose(df, df[0], rtol=1e-10, atol=0):
        return ({"abscissa_spacing": 1, "abscissa_min": float(f[0]),
                 "abscissa_inc": float(df[0]), "x": f},
                f"{_ID_PREFIX}axis={float(f[0]).hex()},{float(df[0]).hex()}")
    if not binary:
        warnings.warn("ASCII UFF stores an uneven frequency axis in single precision; "
                      "use binary=True for an exact round trip", stacklevel=4)
    return {"abscissa_spacing": 0, "x": f}, "NONE"


def _records(frf: FRF, binary: bool) -> list[dict]:
    import pyuff

    _, ns, na = frf.H.shape
    units = _units(frf)
    axis, id5 = _axis(frf, binary)
    rank = {}
    for k, pair in enumerate(frf.collocated):
        rank.setdefault(pair, k + 1)
    coh = int(frf.coherence is not None)
    id3 = f"quantity={frf.quantity}" + ("" if frf.exponential_tau is None
                                         else f" tau={float(frf.exponential_tau).hex()}")
    sets = []
    for a in range(na):
        ref_node, ref_dir = _node_dir(frf.actuators[a], 1_000_000 + a + 1)
        for s in range(ns):
            rsp_node, rsp_dir = _node_dir(frf.sensors[s], s + 1)
            id4 = f"{_ID_PREFIX}{s},{a} {ns}x{na} coh={coh} col={rank.get((s, a), 0)}"
            common = dict(binary=int(bool(binary)), id1="sdctrl FRF",
                          id2=_id2(frf.sensors[s], frf.actuators[a]),
                          id3=id3, id4=id4, id5=id5, ver_num=0,
                          load_case_id=0, rsp_ent_name="NONE", rsp_node=rsp_node,
                          rsp_dir=rsp_dir, ref_ent_name="NONE", ref_node=ref_node,
                          ref_dir=ref_dir, abscissa_spec_data_type=18,
                          abscissa_axis_units_lab="Hz", orddenom_spec_data_type=13,
                          orddenom_axis_units_lab="N", **axis)
            sets.append(pyuff.prepare_58(
                func_type=_FUNC_FRF, ord_data_type=6,
                ordinate_spec_data_type=_QTY_CODE[frf.quantity], ordinate_axis_units_lab=units,
                data=np.array(frf.H[:, s, a], dtype=complex), **common))
            if coh:
                sets.append(pyuff.prepare_58(
                    func_type=_FUNC_COH, ord_data_type=4, ordinate_spec_data_type=0,
                    ordinate_axis_units_lab="NONE",
                    data=np.array(frf.coherence[:, s, a], dtype=float), **common))
    return sets


def write_uff(frf: FRF, path, binary: bool = True, overwrite: bool = True) -> None:
    """Write an FRF as UFF dataset 58 records, one per sensor/actuator pair.

    See the module docstring for what each record holds.  The file is written atomically: on
    any error it is left as it was.

    Parameters
    ----------
    frf : FRF
        The data to write (one line or more).
    path : str or os.PathLike
        Output file (``.uff``/``.unv``).
    binary : bool
        Binary 58b records (exact double precision, default) or ASCII (about 11
        significant digits, readable by every tool).
    overwrite : bool
        Replace an existing file (default) instead of appending to it (a file should hold
        one FRF: the reader refuses two FRFs' records in one file).

    Raises
    ------
    TypeError
        ``frf`` is not an FRF or ``path`` not a path.
    ValueError
        pyuff cannot write the data, or ``path`` exists and is not a regular file.
    OSError
        ``path`` cannot be written.
    """
    import pyuff

    if not isinstance(frf, FRF):
        raise TypeError(f"frf must be an sdctrl.FRF, got {type(frf).__name__}")
    path = check_path(path)
    sets = _records(frf, binary)
    with atomic_write(path) as tmp:
        if not overwrite and os.path.exists(path):
            with open_regular(path) as src, open(tmp, "wb") as dst:
                shutil.copyfileobj(src, dst)
        try:
            pyuff.UFF(tmp).write_sets(sets, "add")
        except Exception as exc:   # pyuff raises bare Exceptions
            raise ValueError(f"cannot write FRF to {path!r} (pyuff: {exc})") from exc


# ------------------------------------------------------------------------------------------
# reading
# ------------------------------------------------------------------------------------------
def _blocks(raw: bytes, path: str) -> int:
    """Number of datasets; refuse unterminated datasets or bytes outside datasets.

    Datasets are delimited as pyuff delimits them: ``    -1`` followed by the end of the file,
    a line end or blanks to column 80.
    """
    marks, i = [], raw.find(b"    -1")
    while i >= 0:
        nxt = raw[i + 6:i + 7]
        if nxt in (b"", b"\n", b"\r") or (len(raw) > i + 80 and raw[i + 6:i + 80] == b" " * 74):
            marks.append(i)
        i = raw.find(b"    -1", i + 1)
    if len(marks) % 2:
        line = raw.count(b"\n", 0, marks[-1]) + 1
        raise ValueError(f"file {path!r}: the UFF block opened by the '    -1' line {line} is "
                         f"not closed by another '    -1' line ({len(marks) // 2} complete "
                         "blocks before it): the file is truncated or damaged")
    edges = [0] + [m + d for pair in zip(marks[::2], marks[1::2]) for m, d in
                   zip(pair, (0, 6))] + [len(raw)]
    for k in range(0, len(edges), 2):
        if raw[edges[k]:edges[k + 1]].strip():
            raise ValueError(f"file {path!r}: unexpected bytes outside UFF datasets at offset "
                             f"{edges[k]} (damaged or not a UFF file)")
    return len(marks) // 2


def _read_sets(path: str) -> list[dict]:
    import pyuff

    with open_regular(path) as fh:
        raw = fh.read()
    if raw[:4] == b"PK\x03\x04":
        raise ValueError(f"file {path!r} is a zip archive (an .npz file), not a UFF file: read "
                         "it with sdctrl.load")
    n = _blocks(raw, path)
    try:
        uff = pyuff.UFF(path)
        types = [int(t) for t in uff.get_set_types()] if n else []
    except Exception as exc:  # pyuff raises bare Exceptions on malformed files
        raise ValueError(f"file {path!r} is not a readable UFF file: {exc}") from exc
    if len(types) != n or any(t <= 0 for t in types):
        bad = next((k for k, t in enumerate(types) if t <= 0), len(types))
        raise ValueError(f"file {path!r}: dataset {bad + 1} has no valid dataset type")
    idx = [i for i, t in enumerate(types) if t == 58]
    if not idx:
        raise ValueError(f"file {path!r} holds no UFF dataset 58 (found types "
                         f"{sorted(set(types))})")
    try:
        with np.errstate(all="ignore"):      # damaged axes give inf/nan, refused afterwards
            data = uff.read_sets(idx)
    except Exception as exc:
        raise ValueError(f"file {path!r}: a dataset 58 cannot be read (pyuff: {exc})") from exc
    return [data] if isinstance(data, dict) else list(data)


def _checked(d: dict, k: int, path: str) -> dict:
    """One record's x, data and ID fields, checked for completeness and finiteness."""
    where = f"file {path!r}, dataset 58 record {k + 1}"
    try:
        x = np.asarray(d["x"], dtype=float).reshape(-1)
        y = np.asarray(d["data"]).reshape(-1)
        npts = int(d["num_pts"])
        out = {"func": int(d.get("func_type", 0)), "x": x, "y": y,
               "rsp": (int(d["rsp_node"]), int(d["rsp_dir"])),
               "ref": (int(d["ref_node"]), int(d["ref_dir"])),
               "even": int(d.get("abscissa_spacing", 0)) == 1,
               "code": int(d.get("ordinate_spec_data_type", 0)),
               "units": str(d.get("ordinate_axis_units_lab", "NONE")).strip(),
               **{f"id{i}": str(d.get(f"id{i}", "")).strip() for i in (2, 3, 4, 5)}}
    except (KeyError, TypeError, ValueError, OverflowError) as exc:
        raise ValueError(f"{where}: malformed header ({type(exc).__name__}: {exc})") from None
    if y.dtype.kind not in "fc" or not (npts == x.size == y.size) or npts < 1:
        raise ValueError(f"{where}: header announces {npts} points, found {x.size} abscissae "
                         f"and {y.size} values (truncated or damaged)")
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
        raise ValueError(f"{where}: NaN or inf in the data")
    m = _AXIS_RE.match(out["id5"])
    if m and out["even"]:
        try:
            f0, df = float.fromhex(m.group(1)), float.fromhex(m.group(2))
            with np.errstate(all="ignore"):
                exact = f0 + np.arange(npts) * df
                ok = np.all(np.isfinite(exact)) and np.allclose(exact, x, rtol=1e-4, atol=0)
        except OverflowError:
            ok = False
        if not ok:
            raise ValueError(f"{where}: exact axis of ID line 5 disagrees with the header")
        out["x"] = exact
    return out


def _labels(r: dict, path: str) -> tuple[str, str]:
    id2 = r["id2"]
    if id2.startswith(_ID_PREFIX):
        parts = id2[len(_ID_PREFIX):].split("|")
        if len(parts) != 2:
            raise ValueError(f"file {path!r}: malformed label line {id2!r}")
        return _unescape(parts[0], path), _unescape(parts[1], path)
    return _label(*r["rsp"]), _label(*r["ref"])


def _pair(r: dict) -> tuple[int, ...] | None:
    m = _PAIR_RE.match(r["id4"])
    return None if m is None else tuple(int(g) for g in m.groups())


def _assemble_indexed(frfs, cohs, path):
    """Matrix of a file written by sdctrl: every pair placed by its ID line 4, checked."""
    keys = {p[2:5] for p in (_pair(r) for r in frfs + cohs)}
    if len(keys) != 1:
        raise ValueError(f"file {path!r}: records disagree on the FRF size {sorted(keys)}")
    ns, na, coh = keys.pop()
    if ns < 1 or na < 1 or len(frfs) != ns * na or len(cohs) != coh * ns * na:
        raise ValueError(f"file {path!r}: holds {len(frfs)} FRF and {len(cohs)} coherence "
                         f"records of a {ns}x{na} FRF (expected {ns * na} and "
                         f"{coh * ns * na}): truncated or incomplete")
    sensors, actuators = [None] * ns, [None] * na
    H = np.empty((frfs[0]["x"].size, ns, na), dtype=complex)
    C = np.empty(H.shape) if coh else None
    seen, col = set(), []
    for recs, kind in ((frfs, "FRF"), (cohs, "coherence")):
        for r in recs:
            s, a, *_, c = _pair(r)
            if s >= ns or a >= na or (kind, s, a) in seen:
                raise ValueError(f"file {path!r}: {kind} record for pair ({s}, {a}) out of "
                                 f"range or duplicated")
            seen.add((kind, s, a))
            ls, la = _labels(r, path)
            for labels, i, lab in ((sensors, s, ls), (actuators, a, la)):
                if labels[i] not in (None, lab):
                    raise ValueError(f"file {path!r}: inconsistent labels {labels[i]!r} and "
                                     f"{lab!r} for channel {i}")
                labels[i] = lab
            if kind == "FRF":
                H[:, s, a] = r["y"]
                if c:
                    col.append((c, s, a))
            else:
                C[:, s, a] = np.real(r["y"])
    return sensors, actuators, H, C, [(s, a) for _, s, a in sorted(col)]


def _foreign_labels(r: dict) -> tuple[str, str, float]:
    """Labels of another tool's record with positive directions, and the sign of its FRF
    (a response or reference along ``-z`` is the ``+z`` one, negated)."""
    (rn, rd), (fn, fd) = r["rsp"], r["ref"]
    sign = (-1.0 if rd < 0 else 1.0) * (-1.0 if fd < 0 else 1.0)
    return _label(rn, abs(rd)), _label(fn, abs(fd)), sign


def _assemble_foreign(frfs, cohs, path):
    """Matrix of a file of another tool: labels in order of first appearance."""
    sensors, actuators, table = [], [], {}
    for r in frfs:
        s, a, sign = _foreign_labels(r)
        sensors += [s] if s not in sensors else []
        actuators += [a] if a not in actuators else []
        if (s, a) in table:
            raise ValueError(f"file {path!r}: duplicated FRF record for sensor {s!r}, "
                             f"actuator {a!r} (directions read as positive)")
        table[(s, a)] = sign * r["y"]
    missing = [(s, a) for a in actuators for s in sensors if (s, a) not in table]
    if missing:
        raise ValueError(f"file {path!r}: FRF matrix incomplete, missing sensor/actuator pairs "
                         f"{missing[:5]}{' ...' if len(missing) > 5 else ''}")
    H = np.empty((frfs[0]["x"].size, len(sensors), len(actuators)), dtype=complex)
    for (s, a), h in table.items():
        H[:, sensors.index(s), actuators.index(a)] = h
    C, seen = (np.ones(H.shape) if cohs else None), set()
    for r in cohs:
        s, a, _sign = _foreign_labels(r)
        if s in sensors and a in actuators and (s, a) not in seen:
            C[:, sensors.index(s), actuators.index(a)] = np.real(r["y"])
            seen.add((s, a))
    if cohs and len(seen) != H.shape[1] * H.shape[2]:
        warnings.warn(f"{path}: coherence given for {len(seen)} of {H.shape[1] * H.shape[2]} "
                      "FRFs; ignored", stacklevel=4)
        C = None
    col = [(i, actuators.index(s)) for i, s in enumerate(sensors) if s in actuators]
    return sensors, actuators, H, C, col


def read_uff(path) -> FRF:
    """Read the FRFs (UFF dataset 58, function type 4) of a file into one MIMO FRF.

    Parameters
    ----------
    path : str or os.PathLike
        UFF file.

    Returns
    -------
    FRF
        Labels, collocated pairs, coherence and units as written by :func:`write_uff`.  For
        files of other tools: channels in order of first appearance, labels ``"N<node>.<dir>"``
        with positive directions (``-z`` is ``+z``, FRF negated), and a pair collocated when
        its labels are equal (a driving point, whichever way the hammer hit).  A 0 Hz
        line, which the FRF container cannot hold, is dropped with a warning.

    Raises
    ------
    ValueError
        Not a regular file (FIFO, device), not a UFF file, no dataset 58 FRF, a truncated or
        damaged file, NaN/inf, frequency axes that differ between records, mixed measured
        quantities, duplicated or missing sensor/actuator pairs; the message names the file.
    OSError
        The path cannot be opened (missing, a directory, no permission).
    """
    path = check_path(path)
    recs = [_checked(d, k, path) for k, d in enumerate(_read_sets(path))]
    frfs = [r for r in recs if r["func"] == _FUNC_FRF]
    cohs = [r for r in recs if r["func"] == _FUNC_COH]
    if not frfs:
        raise ValueError(f"file {path!r} holds dataset 58 records but none is an FRF "
                         "(function type 4)")
    x0 = frfs[0]["x"]
    for r in frfs + cohs:
        x = r["x"]
        if x.shape != x0.shape or not np.allclose(x, x0, rtol=1e-9, atol=1e-12):
            raise ValueError(f"file {path!r}: inconsistent frequency axes between records "
                             f"({x0.size} lines {x0[0]:g}-{x0[-1]:g} Hz vs {x.size} lines "
                             f"{x[0]:g}-{x[-1]:g} Hz)")
    indexed = [_pair(r) is not None for r in frfs + cohs]
    if any(indexed) and not all(indexed):
        raise ValueError(f"file {path!r} mixes records written by sdctrl with others (damaged, "
                         "or two FRFs in one file)")
    assemble = _assemble_indexed if all(indexed) else _assemble_foreign
    sensors, actuators, H, coh, col = assemble(frfs, cohs, path)
    quantity, units = _quantity(frfs, path)
    if coh is not None:
        if np.any(coh < -1e-9) or np.any(coh > 1 + 1e-9):
            raise ValueError(f"file {path!r}: coherence outside [0, 1]")
        coh = np.clip(coh, 0.0, 1.0)
    keep = x0 > 0
    if not np.all(keep):
        warnings.warn(f"{path}: {np.count_nonzero(~keep)} line(s) at 0 Hz dropped", stacklevel=2)
        x0, H = x0[keep], H[keep]
        coh = None if coh is None else coh[keep]
    try:
        return FRF(x0, H, quantity=quantity, sensors=sensors, actuators=actuators,
                   collocated=col, coherence=coh, units=units, exponential_tau=_tau(frfs, path))
    except (ValueError, TypeError) as exc:
        raise ValueError(f"file {path!r}: {exc}") from exc


def _tau(frfs, path) -> float | None:
    """The exponential window's time constant written in ID line 3 (one for all records)."""
    taus = set()
    for r in frfs:
        m = _TAU_RE.search(r["id3"])
        taus.add(None if m is None else float.fromhex(m.group(1)))
    if len(taus) > 1:
        raise ValueError(f"file {path!r}: records disagree on the exponential window (ID line "
                         f"3: {sorted(taus, key=str)})")
    return taus.pop()


def _quantity(frfs, path) -> tuple[str, str | None]:
    quantities = {_CODE_QTY.get(r["code"]) for r in frfs} - {None}
    if len(quantities) > 1:
        raise ValueError(f"file {path!r}: FRF records mix measured quantities "
                         f"{sorted(quantities)}")
    if not quantities:
        warnings.warn(f"{path}: ordinate data type not given; FRFs read as displacement/force",
                      stacklevel=4)
    units = {r["units"] for r in frfs if r["units"] and r["units"].upper() != "NONE"}
    return (quantities.pop() if quantities else "displacement",
            units.pop() if len(units) == 1 else None)
