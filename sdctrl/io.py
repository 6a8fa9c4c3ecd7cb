"""FRF file I/O: Universal File Format dataset 58 (through pyuff) and numpy ``.npz``.

UFF 58 stores one function (one sensor/actuator pair) per dataset.  sdctrl
writes double-precision complex ordinates with an explicit (uneven) abscissa,
in binary by default, so a write/read round trip is exact.  Response and
reference node/direction come from FE DOF labels (``"N42.y"`` -> node 42,
direction +Y); the full labels also go to ID line 2 (``sdctrl:<sensor>|<actuator>``)
so that any label survives.  The measured quantity is the ordinate's specific
data type (8 displacement, 11 velocity, 12 acceleration; denominator 13 force)
and the units text goes to the ordinate units label.  Coherence, when present,
is written as function type 6 (ordinary) datasets.
"""

from __future__ import annotations

import os
import re
import warnings

import numpy as np

from sdctrl.frf import FRF

__all__ = ["load_npz", "read_uff", "save_npz", "write_uff"]

_DIRS = {"x": 1, "y": 2, "z": 3, "rx": 4, "ry": 5, "rz": 6}
_DIR_NAMES = {v: k for k, v in _DIRS.items()}
_QTY_CODE = {"displacement": 8, "velocity": 11, "acceleration": 12}
_CODE_QTY = {v: k for k, v in _QTY_CODE.items()}
_FUNC_FRF = 4
_FUNC_COH = 6
_LABEL_RE = re.compile(r"^N?(\d+)\.(-?)(x|y|z|rx|ry|rz)$", re.IGNORECASE)
_ID_PREFIX = "sdctrl:"


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


def _check_path(path, name="path") -> str:
    if not isinstance(path, str | os.PathLike):
        raise TypeError(f"{name} must be a file path (str or os.PathLike), got {type(path).__name__}")
    return os.fspath(path)


def write_uff(frf: FRF, path, binary: bool = True, overwrite: bool = True) -> None:
    """Write an FRF as UFF dataset 58 records, one per sensor/actuator pair.

    Parameters
    ----------
    frf : FRF
        The data to write.
    path : str or os.PathLike
        Output file (``.uff``/``.unv``).
    binary : bool
        Binary 58b records (exact double precision, default) or ASCII (about 11
        significant digits, readable by every tool).
    overwrite : bool
        Replace an existing file (default) instead of appending to it.
    """
    import pyuff

    if not isinstance(frf, FRF):
        raise TypeError(f"frf must be an sdctrl.FRF, got {type(frf).__name__}")
    path = _check_path(path)
    if overwrite and os.path.exists(path):
        os.remove(path)
    _, ns, na = frf.H.shape
    uff = pyuff.UFF(path)
    units = frf.units if frf.units else "NONE"
    df = np.diff(frf.freq)
    even = frf.freq.size > 1 and np.allclose(df, df[0], rtol=1e-10, atol=0)
    axis = {"abscissa_spacing": 0}
    if not binary:
        if even:      # ASCII min/increment keep more digits than an uneven ASCII axis
            axis = {"abscissa_spacing": 1, "abscissa_min": float(frf.freq[0]),
                    "abscissa_inc": float(df[0])}
        else:
            warnings.warn("ASCII UFF stores an uneven frequency axis in single precision; "
                          "use binary=True for an exact round trip", stacklevel=2)
    sets = []
    for a in range(na):
        ref_node, ref_dir = _node_dir(frf.actuators[a], 1000 + a + 1)
        for s in range(ns):
            rsp_node, rsp_dir = _node_dir(frf.sensors[s], s + 1)
            id2 = f"{_ID_PREFIX}{frf.sensors[s]}|{frf.actuators[a]}"
            if len(id2) > 80:
                warnings.warn(f"labels of ({frf.sensors[s]!r}, {frf.actuators[a]!r}) are too long "
                              "for a UFF ID line (80 characters); only node/direction are stored",
                              stacklevel=2)
                id2 = "NONE"
            common = dict(binary=int(bool(binary)), id1="sdctrl FRF", id2=id2,
                          id3=f"quantity={frf.quantity}", ver_num=0, load_case_id=0,
                          rsp_ent_name="NONE", rsp_node=rsp_node, rsp_dir=rsp_dir,
                          ref_ent_name="NONE", ref_node=ref_node, ref_dir=ref_dir,
                          abscissa_spec_data_type=18,
                          abscissa_axis_units_lab="Hz", orddenom_spec_data_type=13,
                          orddenom_axis_units_lab="N", x=np.array(frf.freq, dtype=float),
                          **axis)
            sets.append(pyuff.prepare_58(
                func_type=_FUNC_FRF, ord_data_type=6,
                ordinate_spec_data_type=_QTY_CODE[frf.quantity],
                ordinate_axis_units_lab=units,
                data=np.array(frf.H[:, s, a], dtype=complex), **common))
            if frf.coherence is not None:
                sets.append(pyuff.prepare_58(
                    func_type=_FUNC_COH, ord_data_type=4, ordinate_spec_data_type=0,
                    ordinate_axis_units_lab="NONE",
                    data=np.array(frf.coherence[:, s, a], dtype=float), **common))
    uff.write_sets(sets, "add")


def read_uff(path) -> FRF:
    """Read the FRFs (UFF dataset 58, function type 4) of a file into one MIMO FRF.

    Parameters
    ----------
    path : str or os.PathLike
        UFF file.

    Returns
    -------
    FRF
        Sensors and actuators in order of first appearance; labels from ID line 2
        when written by sdctrl, else ``"N<node>.<dir>"`` from the response/reference
        node and direction.  Sensor/actuator pairs with the same label are marked
        collocated.  A 0 Hz line, which the FRF container cannot hold, is dropped
        with a warning.

    Raises
    ------
    ValueError
        No dataset 58 FRF in the file, frequency axes that differ between records,
        mixed measured quantities, duplicated or missing sensor/actuator pairs.
    """
    import pyuff

    path = _check_path(path)
    if not os.path.exists(path):
        raise ValueError(f"path {path!r} does not exist")
    try:
        uff = pyuff.UFF(path)
        types = list(uff.get_set_types())
    except Exception as exc:  # pyuff raises bare Exceptions on malformed files
        raise ValueError(f"path {path!r} is not a readable UFF file: {exc}") from exc
    idx = [i for i, t in enumerate(types) if int(t) == 58]
    if not idx:
        raise ValueError(f"path {path!r} holds no UFF dataset 58 (found types "
                         f"{sorted({int(t) for t in types})})")
    data = uff.read_sets(idx)
    if isinstance(data, dict):
        data = [data]
    frfs = [d for d in data if int(d.get("func_type", 0)) == _FUNC_FRF]
    cohs = [d for d in data if int(d.get("func_type", 0)) == _FUNC_COH]
    if not frfs:
        raise ValueError(f"path {path!r} holds dataset 58 records but none is an FRF "
                         "(function type 4)")

    def labels(d):
        id2 = str(d.get("id2", ""))
        if id2.startswith(_ID_PREFIX) and "|" in id2:
            s, a = id2[len(_ID_PREFIX):].split("|", 1)
            return s.strip(), a.strip()
        return (_label(int(d["rsp_node"]), int(d["rsp_dir"])),
                _label(int(d["ref_node"]), int(d["ref_dir"])))

    x0 = np.asarray(frfs[0]["x"], dtype=float)
    sensors, actuators, table = [], [], {}
    quantities = set()
    units = set()
    for d in frfs:
        x = np.asarray(d["x"], dtype=float)
        if x.shape != x0.shape or not np.allclose(x, x0, rtol=1e-9, atol=1e-12):
            raise ValueError(f"path {path!r}: inconsistent frequency axes between FRF records "
                             f"({x0.size} lines {x0[0]:g}-{x0[-1]:g} Hz vs {x.size} lines "
                             f"{x[0]:g}-{x[-1]:g} Hz)")
        s, a = labels(d)
        if s not in sensors:
            sensors.append(s)
        if a not in actuators:
            actuators.append(a)
        if (s, a) in table:
            raise ValueError(f"path {path!r}: duplicated FRF record for sensor {s!r}, "
                             f"actuator {a!r}")
        table[(s, a)] = np.asarray(d["data"])
        code = int(d.get("ordinate_spec_data_type", 0))
        quantities.add(_CODE_QTY.get(code, None))
        lab = str(d.get("ordinate_axis_units_lab", "NONE")).strip()
        if lab and lab.upper() != "NONE":
            units.add(lab)
    quantities.discard(None)
    if len(quantities) > 1:
        raise ValueError(f"path {path!r}: FRF records mix measured quantities {sorted(quantities)}")
    if not quantities:
        warnings.warn(f"{path}: ordinate data type not given; FRFs read as displacement/force",
                      stacklevel=2)
    quantity = quantities.pop() if quantities else "displacement"
    missing = [(s, a) for a in actuators for s in sensors if (s, a) not in table]
    if missing:
        raise ValueError(f"path {path!r}: FRF matrix incomplete, missing sensor/actuator pairs "
                         f"{missing[:5]}{' ...' if len(missing) > 5 else ''}")
    H = np.empty((x0.size, len(sensors), len(actuators)), dtype=complex)
    for (s, a), h in table.items():
        H[:, sensors.index(s), actuators.index(a)] = h
    coh = None
    if cohs:
        coh = np.ones(H.shape)
        seen = 0
        for d in cohs:
            s, a = labels(d)
            if s in sensors and a in actuators:
                coh[:, sensors.index(s), actuators.index(a)] = np.real(np.asarray(d["data"]))
                seen += 1
        if seen != len(sensors) * len(actuators):
            warnings.warn(f"{path}: coherence given for {seen} of "
                          f"{len(sensors) * len(actuators)} FRFs; ignored", stacklevel=2)
            coh = None
        else:
            coh = np.clip(coh, 0.0, 1.0)
    keep = x0 > 0
    if not np.all(keep):
        warnings.warn(f"{path}: {np.count_nonzero(~keep)} line(s) at 0 Hz dropped", stacklevel=2)
        x0, H = x0[keep], H[keep]
        coh = None if coh is None else coh[keep]
    collocated = [(i, actuators.index(s)) for i, s in enumerate(sensors) if s in actuators]
    return FRF(x0, H, quantity=quantity, sensors=sensors, actuators=actuators,
               collocated=collocated, coherence=coh,
               units=units.pop() if len(units) == 1 else None)


def save_npz(frf: FRF, path) -> None:
    """Save an FRF, labels, collocated pairs and coherence to a numpy ``.npz`` file.

    Parameters
    ----------
    frf : FRF
        The data to save.
    path : str or os.PathLike
        Output file.
    """
    if not isinstance(frf, FRF):
        raise TypeError(f"frf must be an sdctrl.FRF, got {type(frf).__name__}")
    path = _check_path(path)
    kw = {"freq": frf.freq, "H": frf.H, "quantity": np.array(frf.quantity),
          "sensors": np.array(frf.sensors), "actuators": np.array(frf.actuators),
          "collocated": np.array(frf.collocated, dtype=int).reshape(-1, 2),
          "units": np.array(frf.units or "")}
    if frf.coherence is not None:
        kw["coherence"] = frf.coherence
    np.savez(path, **kw)


def load_npz(path) -> FRF:
    """Load an FRF saved by :func:`save_npz`.

    Parameters
    ----------
    path : str or os.PathLike
        The ``.npz`` file.

    Returns
    -------
    FRF
    """
    path = _check_path(path)
    with np.load(path, allow_pickle=False) as z:
        missing = {"freq", "H", "quantity", "sensors", "actuators"} - set(z.files)
        if missing:
            raise ValueError(f"path {path!r} is not an sdctrl FRF archive (missing {sorted(missing)})")
        return FRF(z["freq"], z["H"], quantity=str(z["quantity"]),
                   sensors=[str(s) for s in z["sensors"]],
                   actuators=[str(a) for a in z["actuators"]],
                   collocated=[tuple(int(v) for v in p) for p in z["collocated"]],
                   coherence=z["coherence"] if "coherence" in z.files else None,
                   units=str(z["units"]) or None)
