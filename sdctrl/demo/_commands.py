"""The ``sdctrl demo`` and ``sdctrl identify`` jobs (the command line only parses arguments)."""

from __future__ import annotations

import os
import platform
import time
import warnings
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from sdctrl._lib.threads import single_thread
from sdctrl.report import Document
from sdctrl.demo._diagnosing import diagnose_retest
from sdctrl.demo._test_side import identify_test, normal_modes_of
from sdctrl.demo._modelling import build_hybrid, place_strut, update_fe
from sdctrl.demo._robustness import robust_strut
from sdctrl.demo._runner import StepLog, agg_backend, write_outputs
from sdctrl.demo._simulated import simulated_testbed_test

__all__ = ["demo", "identify_report", "mode_lines"]


def _failed_section(doc, entry) -> None:
    s = doc.section(entry.key, entry.title[:1].upper() + entry.title[1:])
    if entry.status == "unavailable":
        s.paragraph(f"This step is not available: {entry.message}.")
    elif entry.status == "skipped":
        s.paragraph(f"This step was skipped: {entry.message}.")
    else:
        s.paragraph(f"This step failed after {entry.seconds:.1f} s; the steps before it stand "
                    "and their models are saved.")
        s.error(entry.message)


def _warnings_block(section, entry) -> None:
    if entry.warnings:
        section.paragraph("Warnings raised by this step:")
        section.code("\n".join(entry.warnings))


def _sections(doc, log, extra: dict, start: int = 0) -> None:
    """One section per step from the ``start``-th on, in order: the record's own, or the
    failure."""
    for entry in log.entries[start:]:
        if entry.status != "ok":
            _failed_section(doc, entry)
            continue
        args = extra.get(entry.key, ())
        entry.record.section(doc, *args)
        _warnings_block(doc.sections[-1], entry)


def _timings(doc, log, report_seconds: float) -> None:
    s = doc.section("timings", "Steps and run time")
    rows = [(e.title, e.status, f"{e.seconds:.1f}") for e in log.entries]
    rows.append(("report (figures, HTML, models)", "ok", f"{report_seconds:.1f}"))
    s.table(["step", "status", "seconds"], rows)
    from sdctrl import __version__

    s.paragraph(f"sdctrl {__version__}, Python {platform.python_version()}, "
                f"{os.cpu_count()} CPU(s); total {log.seconds:.1f} s.")


def _summary(log) -> dict:
    from sdctrl import __version__

    steps = {}
    for e in log.entries:
        rec = e.record
        steps[e.key] = {"title": e.title, "status": e.status, "seconds": e.seconds,
                        "message": e.message, "warnings": e.warnings,
                        "numbers": rec.numbers() if rec is not None else None,
                        "checks": [{"quantity": c.quantity, "value": c.value, "truth": c.truth,
                                    "error": c.error, "tolerance": c.tolerance,
                                    "passed": c.passed}
                                   for c in (rec.checks() if rec is not None else [])]}
    return {"sdctrl": __version__, "seconds": log.seconds, "steps": steps}


def _diagnosis(log, test, upd, progress=None, pending=None):
    """Step 8, or a "not available" line when this version has no ``sdctrl.diagnose``;
    ``pending`` is the step already running in a second process (:func:`_start_diagnosis`)."""
    import sdctrl

    title = "diagnosis of a second test"
    if not hasattr(sdctrl, "diagnose"):
        log.unavailable("diagnosis", title, "sdctrl.diagnose is not in this version of sdctrl "
                        f"({sdctrl.__version__})")
        return None
    if pending is not None:
        return log.run("diagnosis", title, _collected, pending, needs=[upd])
    return log.run("diagnosis", title, diagnose_retest, test, upd, progress=progress,
                   needs=[upd])


def _diagnosis_worker(test, upd):
    """``diagnose_retest`` in a second process: its record and the warnings it raised.  Its
    candidate scan runs on two threads (one BLAS thread each): the main process needs its
    core only for steps 5-7 and their figures, a fraction of the diagnosis; the ranking
    is the serial one bit for bit (measured on the demo's second test, idle machine: 50.8 s
    wall serial, 42.2 s on two threads, the same effects and errors)."""
    from concurrent.futures import ThreadPoolExecutor

    with single_thread(), warnings.catch_warnings(record=True) as caught, \
            ThreadPoolExecutor(2) as pool:
        warnings.simplefilter("always")
        record = diagnose_retest(test, upd, progress=False, executor=pool)
    return record, [(w.category, str(w.message)) for w in caught]


def _start_diagnosis(test, upd):
    """Start step 8 in a second (forked) process, beside steps 5-7 that do not need it: the
    story's wall time is then about the longer of the two branches on a machine with two
    cores.  Its inputs -- the updated model of step 4, and the first test its effects are
    weighed against (prior model errors or the change) -- exist once step 4 is done.
    ``(executor, future)``, or None when the step cannot run there (no ``fork`` or
    no ``sdctrl.diagnose``): it then runs in turn."""
    import multiprocessing

    import sdctrl

    if upd is None or not hasattr(sdctrl, "diagnose") or (os.cpu_count() or 1) < 2 \
            or "fork" not in multiprocessing.get_all_start_methods():
        return None
    try:
        pool = ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("fork"))
        return pool, pool.submit(_diagnosis_worker, test, upd)
    except (OSError, ValueError, TypeError):
        return None


def _collected(pending):
    """The record of the step started by :func:`_start_diagnosis` (its warnings raised again
    here, so that the step log records them)."""
    pool, future = pending
    try:
        record, caught = future.result()
    finally:
        pool.shutdown()
    for category, message in caught:
        warnings.warn(message, category, stacklevel=2)
    return record


def demo(out: str = "sdctrl-demo", noise: float = 0.01, seed: int = 0, quiet: bool = False,
         progress: bool | None = None) -> int:
    """Run the whole story on the built-in testbed and write its report; return the status.

    Simulated test with noise -> identification (stabilisation diagram) -> normal modes
    with non-proportional damping -> update of a deliberately wrong FE model -> hybrid
    model -> D-strut placement and closed-loop RMS -> structured uncertainty and a
    robust-stability margin -> diagnosis of an undeclared effect in a second test.  Each
    step prints one line with its time and its key numbers are compared with the truth in
    the report.  Writes to ``out``: ``report.html`` (self-contained), ``report.md`` with
    ``figures/``, ``summary.json``, the models (``identified.npz``, ``normal_modes.npz``,
    ``fe_updated.npz``, ``hybrid.npz``, ``uncertain.npz``, ``updated_model.npz``, all read
    back by :func:`sdctrl.load`) and the two tests (``test.uff``, ``retest.uff``).

    Parameters
    ----------
    out : str
        Output folder (created).
    noise : float
        Relative noise of the simulated tests.
    seed : int
        Noise seed.
    quiet : bool
        Print nothing.
    progress : bool, optional
        Progress bars of the long steps (default: :mod:`sdctrl.config` policy).

    Returns
    -------
    int
        0 when every step ran, 1 when one failed (the report says which and why); a step
        whose function this version lacks (``sdctrl.diagnose``) is reported as not
        available and is not a failure.

    Notes
    -----
    The story runs with single-threaded BLAS: its matrices are small (a 246-DOF model,
    reduced models of a few dozen modes), where BLAS threads cost more in synchronisation
    than they gain -- on a loaded machine several times the whole run.
    """
    with single_thread():
        return _story(out, noise, seed, quiet, progress)


def _story(out, noise, seed, quiet, progress) -> int:
    """The steps of :func:`demo`, its report and its status."""
    agg_backend()
    log = StepLog(8, quiet)
    log.say(f"sdctrl demo: the whole story on the built-in testbed, report in {out}/")
    test = log.run("test", "simulated test", simulated_testbed_test, noise, seed)
    ident = log.run("identification", "identification", identify_test, test and test.frf,
                    truth=test and test.poles, progress=progress, needs=[test])
    nm = log.run("normal_modes", "normal modes", normal_modes_of, ident, test, needs=[ident])
    upd = log.run("update", "FE model update", update_fe, test, nm, progress=progress,
                  ident=ident, needs=[test, nm])
    pending = _start_diagnosis(test, upd)
    hy = log.run("hybrid", "hybrid model", build_hybrid, test, nm, upd, ident, needs=[upd])
    pl = log.run("placement", "D-strut placement", place_strut, test, hy, upd,
                 progress=progress, needs=[hy])
    rb = log.run("robustness", "robust stability", robust_strut, hy, pl, upd,
                 progress=progress, needs=[pl])
    t0 = time.perf_counter()
    doc = Document("sdctrl demo: from a vibration test to a robust, diagnosed model",
                   "Every step of sdctrl on the built-in testbed, whose truth is known: each "
                   "section compares its key numbers with it (*ok* within the stated "
                   "tolerance). Models are saved next to this report; `sd.load(path)` "
                   "reads them back.")
    extra = {"update": (test and test.frf,), "hybrid": (upd and upd.result.fe,),
             "placement": (hy and hy.model,)}
    done = len(log.entries)          # steps 1-7: their sections (figures) drawn while the
    _sections(doc, log, extra)               # diagnosis still runs in its own process
    report_seconds = time.perf_counter() - t0
    dg = _diagnosis(log, test, upd, progress, pending)
    t0 = time.perf_counter()
    _sections(doc, log, extra, start=done)
    models = {name: obj for name, obj in (
        ("test.uff", test and test.frf), ("identified", ident and ident.cm),
        ("normal_modes", nm and nm.nm), ("fe_updated", upd and upd.result.fe),
        ("updated_model", upd and upd.result.model), ("hybrid", hy and hy.model),
        ("uncertain", rb and rb.uncertain), ("retest.uff", dg and dg.frf))
        if obj is not None}
    summary = _summary(log)
    _timings(doc, log, report_seconds + time.perf_counter() - t0)
    summary["models"] = sorted(models)
    paths = write_outputs(doc, out, models, summary)
    failed = log.failed
    missing = [e.title for e in log.entries if e.status == "unavailable"]
    status = ("every available step ran" if missing else "every step ran") if not failed else (
        f"{len(failed)} step(s) did not run: " + ", ".join(e.title for e in failed))
    if missing:
        status += "; not available in this version: " + ", ".join(missing)
    log.say(f"report: {paths['html']} ({status}; total {log.seconds:.1f} s)")
    return 1 if failed else 0


def mode_lines(ident) -> list[str]:
    """Terminal table of identified modes: frequency and damping with one standard deviation
    (``frequency_std``, ``damping_std``, thesis 3.4; "n/a" where the data do not determine
    them), in band.

    Parameters
    ----------
    ident : Identification
        Output of the identification step.

    Returns
    -------
    list of str
        One line per mode, after a header line.
    """
    cm = ident.cm
    lines = [f"{'mode':>4} {'freq (Hz)':>10} {'+- std':>8} {'damping (%)':>11} {'+- std':>7}"
             "  in band"]
    rows = zip(cm.frequency, cm.frequency_std, cm.damping, cm.damping_std, cm.in_band)
    for j, (f, fs, z, zs, ib) in enumerate(rows):
        fs = f"{fs:>8.2g}" if np.isfinite(fs) else f"{'n/a':>8}"
        zs = f"{100 * zs:>7.2g}" if np.isfinite(zs) else f"{'n/a':>7}"
        lines.append(f"{j + 1:>4} {f:>10.4f} {fs} {100 * z:>11.3f} {zs}  {'yes' if ib else 'no'}")
    return lines


def _read(path):
    from sdctrl.data._frf import FRF
    from sdctrl.data import read_uff
    from sdctrl.storage import load

    if str(path).endswith(".npz"):
        obj = load(path)
        if not isinstance(obj, FRF):
            raise ValueError(f"path: {path} holds a {type(obj).__name__}, not measured FRFs")
        return obj
    return read_uff(path)


class _Data:
    """Record of the data read (for the terminal line and the report)."""

    def __init__(self, frf, path):
        self.frf, self.path = frf, path
        f = frf
        self.summary = (f"{len(f.sensors)} sensors x {len(f.actuators)} actuators, "
                        f"{f.freq.size} lines {f.freq[0]:.5g}-{f.freq[-1]:.5g} Hz, {f.quantity}; "
                        f"{len(f.collocated or [])} collocated pair(s)")

    def section(self, doc):
        s = doc.section("data", "The data")
        s.paragraph(f"`{os.path.basename(self.path)}`: {self.summary}.")
        f = self.frf
        if f.collocated:
            s.paragraph("Collocated pairs: " + ", ".join(
                f"`{f.sensors[a]}`/`{f.actuators[b]}`" for a, b in f.collocated) + ".")

    def numbers(self):
        return {"sensors": list(self.frf.sensors), "actuators": list(self.frf.actuators),
                "lines": int(self.frf.freq.size)}

    def checks(self):
        return []


def identify_report(path: str, band=None, out: str | None = None, quiet: bool = False,
                    progress: bool | None = None, weighting: str = "auto") -> int:
    """Identify the modes of a user's test: terminal table, HTML report, saved models.

    Parameters
    ----------
    path : str
        Measured FRFs: UFF dataset 58 (``.uff``/``.unv``) or an FRF saved with
        :func:`sdctrl.save` (``.npz``).
    band : (float, float), optional
        Band (Hz); default all lines.
    out : str, optional
        Output folder (default ``<file stem>-sdctrl`` next to the data).
    quiet : bool
        Print nothing.
    progress : bool, optional
        Progress bars (default: :mod:`sdctrl.config` policy).
    weighting : {"auto", "none", "level"}
        Weight of each line in the fit (:func:`sdctrl.identify`).

    Returns
    -------
    int
        0 when the identified model exists (each step's status, and the reason of a step
        that failed, are in the report); 1 when nothing usable was produced.
    """
    agg_backend()
    if out is None:
        out = os.path.splitext(str(path))[0] + "-sdctrl"
    frf = _read(path)                       # bad files: the error goes to the caller
    if band is not None:
        frf = frf.band(*band)
    log = StepLog(3 if frf.collocated else 2, quiet)
    log.say(f"sdctrl identify {path}: report in {out}/")
    log.run("data", "data", _Data, frf, path)
    ident = log.run("identification", "identification", identify_test, frf, progress=progress,
                    weighting=weighting)
    nm = None
    if ident is not None:
        if not quiet:
            print("\n".join(mode_lines(ident)), flush=True)
        if frf.collocated:
            nm = log.run("normal_modes", "normal modes", normal_modes_of, ident, needs=[ident])
    doc = Document(f"sdctrl identify: {os.path.basename(str(path))}",
                   "Modes identified from the measured FRFs with no initial guess (chapter "
                   "III) and, when the test has collocated pairs, the normal-mode model with "
                   "its full damping matrix (3.3). The models are saved next to this report.")
    _sections(doc, log, {})
    models = {k: v for k, v in (("identified", ident and ident.cm), ("normal_modes", nm and nm.nm))
              if v is not None}
    summary = _summary(log)
    summary["models"] = sorted(models)
    paths = write_outputs(doc, out, models, summary)
    status = "; ".join(f"{e.title}: {e.status}" for e in log.entries)
    log.say(f"report: {paths['html']} ({status}; total {log.seconds:.1f} s)")
    return 0 if ident is not None else 1
