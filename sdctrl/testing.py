"""Closed-loop RMS regression helpers and their pytest fixture.

Lock the closed-loop RMS of every output of a design (model + controller + band + input
PSD) in a small JSON snapshot, and fail with a readable per-output diff when a change of
model, controller or library moves them:

>>> import control, sdctrl.testing as st
>>> G = control.ss(control.tf([1.0], [1.0, 0.2, 1.0]), inputs=["f"], outputs=["x"])
>>> snap = st.record_rms(G, band=(0.0, 1.0))
>>> st.assert_rms_matches(G, snap, rtol=1e-9).round(4)
array([1.1179])

In a test suite (the fixture is registered as the pytest plugin ``sdctrl``; without the
entry point add ``pytest_plugins = ["sdctrl.testing"]`` to the root ``conftest.py``)::

    def test_loop_rms(rms_snapshot):
        closed = sdctrl.feedback(plant, controller)
        rms_snapshot.check(closed, band=(8, 60), psd=1e-2, rtol=1e-6)

The first run (or ``pytest --sdctrl-update-rms``) writes
``<test dir>/rms_snapshots/<module>/<test>.json`` and reports the test skipped, "RMS snapshot
recorded"; later runs compare against it.  Under CI (environment variable ``CI`` set) a
missing snapshot fails the test instead, so a CI run never silently records.
"""

from __future__ import annotations

import json
import math
import os
import pathlib
import re

import numpy as np

from sdctrl._lib.validate import check_band, check_scalar
from sdctrl._lib.signals import as_statespace

__all__ = ["RMSSnapshot", "assert_rms_matches", "load_snapshot", "record_rms"]

SNAPSHOT_FORMAT = "sdctrl-rms-snapshot"
SNAPSHOT_VERSION = 1


def _closed(system, controller):
    from sdctrl.closedloop._loops import feedback

    G = as_statespace(system, "system")
    return G if controller is None else feedback(G, controller)


def _summary(G) -> dict:
    return {"inputs": list(G.input_labels), "outputs": list(G.output_labels),
            "nstates": int(G.nstates)}


def record_rms(system, band, psd=1.0, path=None, *, controller=None, name: str | None = None,
               note: str | None = None) -> dict:
    """Record the (closed-loop) RMS of every output in a JSON-ready snapshot.

    Parameters
    ----------
    system : control.StateSpace or model with ``to_statespace()``
        The closed loop, or the plant when ``controller`` is given.
    band : (float, float)
        Frequency band (Hz) of the white-noise inputs; ``fmax`` may be ``inf``.
    psd : float or array_like
        One-sided PSD of every input (units^2/Hz), scalar or one per input.
    path : str or path-like, optional
        Write the snapshot there as JSON (parent directories are created).
    controller : control.StateSpace, optional
        Closed around ``system`` with :func:`sdctrl.closedloop._loops.feedback` first.
    name : str, optional
        A name stored in the snapshot.
    note : str, optional
        Free text stored in the snapshot (what the design is).

    Returns
    -------
    dict
        ``{"format", "version", "name", "note", "band_hz", "psd", "system",
        "controller", "rms": {output: value}}``; infinite band ends are stored as
        ``"inf"``.
    """
    from sdctrl import __version__
    from sdctrl.closedloop._loops import rms

    lo, hi = check_band(band, infinite=True)
    G = _closed(system, controller)
    values = rms(G, (lo, hi), psd)
    p = np.asarray(psd, float)
    snap = {
        "format": SNAPSHOT_FORMAT, "version": SNAPSHOT_VERSION, "sdctrl": __version__,
        "name": name, "note": note,
        "band_hz": [lo, "inf" if math.isinf(hi) else hi],
        "psd": float(p) if p.ndim == 0 else [float(v) for v in p],
        "system": _summary(G),
        "controller": None if controller is None else _summary(_closed(controller, None)),
        "rms": {lab: float(v) for lab, v in zip(G.output_labels, values)},
    }
    if path is not None:
        path = pathlib.Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(snap, indent=2) + "\n")
    return snap


def load_snapshot(snapshot) -> dict:
    """Read and check a snapshot (a dict from :func:`record_rms` or a JSON file path).

    Parameters
    ----------
    snapshot : dict or str or path-like
        The snapshot or its file.

    Returns
    -------
    dict
    """
    if isinstance(snapshot, dict):
        snap = snapshot
    elif isinstance(snapshot, str | pathlib.Path):
        p = pathlib.Path(snapshot)
        if not p.is_file():
            raise ValueError(f"snapshot: no such file {str(p)!r}")
        try:
            snap = json.loads(p.read_text())
        except (UnicodeDecodeError, ValueError) as exc:
            raise ValueError(f"snapshot: {str(p)!r} is not a JSON file ({exc})") from None
    else:
        raise TypeError(f"snapshot must be a dict or a JSON file path, got "
                        f"{type(snapshot).__name__}")
    if not isinstance(snap, dict) or snap.get("format") != SNAPSHOT_FORMAT or \
            "rms" not in snap or "band_hz" not in snap:
        raise ValueError("snapshot is not an sdctrl RMS snapshot (format, band_hz, rms)")
    return snap


def _band_of(snap) -> tuple[float, float]:
    lo, hi = snap["band_hz"]
    return float(lo), (math.inf if hi == "inf" else float(hi))


def assert_rms_matches(system, snapshot, rtol: float = 1e-6, *, atol: float = 0.0,
                       controller=None) -> np.ndarray:
    """Assert that the RMS of every output matches a snapshot (band and PSD taken from it).

    Parameters
    ----------
    system : control.StateSpace or model with ``to_statespace()``
        The closed loop (or the plant when ``controller`` is given).
    snapshot : dict or str or path-like
        From :func:`record_rms`, or its JSON file.
    rtol : float
        Relative tolerance per output.
    atol : float
        Absolute tolerance per output (output units).
    controller : control.StateSpace, optional
        Closed around ``system`` first (:func:`sdctrl.closedloop._loops.feedback`).

    Returns
    -------
    ndarray
        The RMS values computed now (in the snapshot's output order).

    Raises
    ------
    AssertionError
        With a per-output table (snapshot, actual, relative difference) when an output
        differs, is missing or is new.
    """
    from sdctrl.closedloop._loops import rms

    snap = load_snapshot(snapshot)
    rtol = check_scalar(rtol, "rtol", nonneg=True)
    atol = check_scalar(atol, "atol", nonneg=True)
    G = _closed(system, controller)
    now = dict(zip(G.output_labels, rms(G, _band_of(snap), snap["psd"])))
    ref = snap["rms"]
    lines, bad = [], 0
    width = max([len(k) for k in list(ref) + list(now)] + [6])
    for lab in list(ref) + [k for k in now if k not in ref]:
        r, a = ref.get(lab), now.get(lab)
        if r is None or a is None:
            bad += 1
            lines.append(f"  {lab:<{width}}  {'-' if r is None else f'{r:.6e}':>13}  "
                         f"{'-' if a is None else f'{a:.6e}':>13}  "
                         f"{'new output' if r is None else 'missing':>10}  FAIL")
            continue
        diff = a - r
        rel = diff / abs(r) if r != 0 else (0.0 if a == 0 else math.inf)
        ok = abs(diff) <= atol + rtol * abs(r)
        bad += not ok
        lines.append(f"  {lab:<{width}}  {r:13.6e}  {a:13.6e}  {rel:+10.3e}  "
                     f"{'ok' if ok else 'FAIL'}")
    if bad:
        lo, hi = _band_of(snap)
        head = ("closed-loop RMS differs from the snapshot"
                f"{' ' + snap['name'] if snap.get('name') else ''} "
                f"for {bad} of {len(lines)} outputs (rtol={rtol:g}, atol={atol:g}, band "
                f"{lo:g}-{hi:g} Hz, psd {snap['psd']}):\n"
                f"  {'output':<{width}}  {'snapshot':>13}  {'actual':>13}  {'rel.diff':>10}\n")
        raise AssertionError(head + "\n".join(lines))
    return np.array([now[k] for k in ref])


class RMSSnapshot:
    """The ``rms_snapshot`` fixture: check or (re)record one snapshot per test.

    Parameters
    ----------
    path : path-like
        Snapshot file of the test (a ``name`` given to :meth:`check` is appended).
    update : bool
        Record instead of comparing (``pytest --sdctrl-update-rms``).
    """

    def __init__(self, path, update: bool = False):
        self.path = pathlib.Path(path)
        self.update = bool(update)

    def __repr__(self) -> str:
        return f"RMSSnapshot({str(self.path)!r}, update={self.update})"

    def _file(self, name):
        if name is None:
            return self.path
        safe = re.sub(r"[^A-Za-z0-9_.-]+", "_", str(name))
        return self.path.with_name(f"{self.path.stem}-{safe}.json")

    def check(self, system, band, psd=1.0, rtol: float = 1e-6, *, atol: float = 0.0,
              controller=None, name: str | None = None):
        """Compare with the stored snapshot, or record it when missing/updating.

        Parameters
        ----------
        system : control.StateSpace or model with ``to_statespace()``
            Closed loop (or plant with ``controller``).
        band : (float, float)
            Frequency band (Hz), used when recording (the stored one is compared).
        psd : float or array_like
            Input PSD (units^2/Hz), used when recording.
        rtol : float
            Relative tolerance per output.
        atol : float
            Absolute tolerance per output.
        controller : control.StateSpace, optional
            Closed around ``system`` first.
        name : str, optional
            Distinguishes several snapshots in one test.

        Returns
        -------
        ndarray
            RMS of every output.
        """
        f = self._file(name)
        if self.update or not f.exists():
            snap = record_rms(system, band, psd, f, controller=controller, name=name)
            if not self.update:
                _first_record(f)
            return np.array(list(snap["rms"].values()))
        snap = load_snapshot(f)
        lo, hi = _band_of(snap)
        blo, bhi = (float(v) for v in band)
        if not (np.isclose(lo, blo) and (hi == bhi or np.isclose(hi, bhi))) or \
                not np.allclose(np.asarray(snap["psd"], float), np.asarray(psd, float)):
            raise AssertionError(f"RMS snapshot {f} was recorded for band {lo:g}-{hi:g} Hz, "
                                 f"psd {snap['psd']}; the test asks for band {blo:g}-{bhi:g} "
                                 f"Hz, psd {psd} (rerun with --sdctrl-update-rms)")
        return assert_rms_matches(system, snap, rtol, atol=atol, controller=controller)


def _first_record(path) -> None:
    """A snapshot written by its first run: the test is skipped with the reason ("recorded");
    under CI (environment variable ``CI`` set) a missing snapshot fails instead, so CI never
    records silently.  Either way one line, no traceback."""
    msg = f"RMS snapshot recorded: {path} (check it in; later runs compare against it)"
    if os.environ.get("CI", "").lower() not in ("", "0", "false"):
        msg = (f"RMS snapshot {path} is missing under CI; it was written now: record it "
               "locally (pytest --sdctrl-update-rms) and check it in")
        if pytest is None:                                   # pragma: no cover
            raise AssertionError(msg)
        pytest.fail(msg, pytrace=False)
    if pytest is None:                                       # pragma: no cover
        return
    pytest.skip(msg)


try:                                    # the pytest plugin (only when pytest is installed)
    import pytest
except ImportError:                     # pragma: no cover
    pytest = None

if pytest is not None:
    def pytest_addoption(parser):
        """Register ``--sdctrl-update-rms``.

        Parameters
        ----------
        parser : pytest.Parser
            pytest's option parser.
        """
        parser.addoption("--sdctrl-update-rms", action="store_true", default=False,
                         help="sdctrl: (re)write the closed-loop RMS snapshots of "
                              "rms_snapshot instead of comparing")

    @pytest.fixture
    def rms_snapshot(request) -> RMSSnapshot:
        """Closed-loop RMS snapshot of the current test (see :class:`RMSSnapshot`).

        Parameters
        ----------
        request : pytest.FixtureRequest
            pytest's request object.

        Returns
        -------
        RMSSnapshot
        """
        test_file = pathlib.Path(str(request.node.path))
        test = re.sub(r"[^A-Za-z0-9_.-]+", "_", request.node.name)
        path = test_file.parent / "rms_snapshots" / test_file.stem / f"{test}.json"
        return RMSSnapshot(path, update=request.config.getoption("--sdctrl-update-rms",
                                                                default=False))
