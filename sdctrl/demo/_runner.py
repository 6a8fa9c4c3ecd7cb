"""Running the steps of a story: one terminal line per step with its time, failures kept.

:class:`StepLog` calls each step function, prints ``[k/n] title: summary  (t s)`` when it
returns, records the warnings it raised (shown in the report, and on the terminal), and
keeps going when a step fails: the failure is recorded with its message, the steps that
need its result are skipped, and the command's exit status says so.  Ctrl-C stops the
run at once (KeyboardInterrupt is never caught).  :func:`write_outputs` writes the report
(HTML, markdown copy, ``summary.json``) and the models.
"""

from __future__ import annotations

import json
import os
import sys
import time
import traceback
import warnings
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Entry", "StepLog", "agg_backend", "write_outputs"]


@dataclass(eq=False)
class Entry:
    """What happened to one step.

    Parameters
    ----------
    key : str
        Short name (section anchor, ``summary.json`` key).
    title : str
        Title printed and used as section heading.
    status : {"ok", "failed", "skipped", "unavailable"}
        Outcome (``unavailable``: the function the step needs is not in this version).
    seconds : float
        Wall time of the step.
    record : object
        The step's result record (None unless ``status == "ok"``).
    message : str
        Error message (failed), reason (skipped, unavailable), else ``""``.
    warnings : list of str
        Warnings the step raised.
    trace : str
        Last frames of the traceback of a failure.
    """

    key: str
    title: str
    status: str
    seconds: float = 0.0
    record: object = None
    message: str = ""
    warnings: list = field(default_factory=list)
    trace: str = ""


def _one_line(text: str, width: int = 160) -> str:
    text = " ".join(str(text).split())
    return text if len(text) <= width else text[:width - 3] + "..."


def _wrapped(text: str, indent: str = "      ", width: int = 100) -> str:
    """``text`` in full (never cut), on lines of ``width`` characters after ``indent``."""
    import textwrap

    return textwrap.fill(" ".join(str(text).split()), width=width, initial_indent=indent,
                         subsequent_indent=indent + "  ", break_long_words=False,
                         break_on_hyphens=False)


class StepLog:
    """Runs the steps of a command and prints one line per step.

    Parameters
    ----------
    total : int
        Number of steps (for the ``[k/n]`` counter).
    quiet : bool
        Print nothing.
    stream : file, optional
        Where the lines go (default standard output).
    """

    def __init__(self, total: int, quiet: bool = False, stream=None):
        self.total = int(total)
        self.quiet = bool(quiet)
        self.stream = stream
        self.entries: list[Entry] = []
        self.t0 = time.perf_counter()

    def say(self, text: str) -> None:
        """Print a line (unless quiet).

        Parameters
        ----------
        text : str
            The line.
        """
        if not self.quiet:
            print(text, file=self.stream or sys.stdout, flush=True)

    def run(self, key: str, title: str, func, *args, needs=(), **kwargs):
        """Run ``func(*args, **kwargs)`` as step ``key``; return its record or None.

        Parameters
        ----------
        key : str
            Step name.
        title : str
            Printed title.
        func : callable
            The step; its result should have a ``summary`` attribute (one line).
        *args, **kwargs
            Passed to ``func``.
        needs : sequence
            Results of earlier steps this one needs: when one is None (that step failed
            or was skipped) the step is skipped.

        Returns
        -------
        object or None
        """
        k = len(self.entries) + 1
        head = f"[{k}/{self.total}] {title}"
        missing = [i for i, n in enumerate(needs) if n is None]
        if missing:
            entry = Entry(key, title, "skipped", message="an earlier step it needs failed")
            self.entries.append(entry)
            self.say(f"{head}: skipped ({entry.message})")
            return None
        t = time.perf_counter()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                record = func(*args, **kwargs)
            except Exception as exc:  # noqa: BLE001 -- reported, the other steps go on
                dt = time.perf_counter() - t
                msg = f"{type(exc).__name__}: {exc}"
                entry = Entry(key, title, "failed", dt, message=msg,
                              warnings=_unique(caught), trace=traceback.format_exc(limit=-4))
                self.entries.append(entry)
                self.say(f"{head}: FAILED after {dt:.1f} s -- {_one_line(msg)}")
                return None
        dt = time.perf_counter() - t
        entry = Entry(key, title, "ok", dt, record, warnings=_unique(caught))
        self.entries.append(entry)
        summary = getattr(record, "summary", "")
        self.say(f"{head}: {summary}  ({dt:.1f} s)")
        for w in entry.warnings:
            self.say(_wrapped(f"warning: {w}"))
        return record

    def unavailable(self, key: str, title: str, reason: str) -> None:
        """Record step ``key`` as not available in this version (not a failure).

        Parameters
        ----------
        key : str
            Step name.
        title : str
            Printed title.
        reason : str
            What is missing, printed and written in the report.
        """
        k = len(self.entries) + 1
        self.entries.append(Entry(key, title, "unavailable", message=reason))
        self.say(f"[{k}/{self.total}] {title}: not available ({reason})")

    @property
    def failed(self) -> list[Entry]:
        """Entries that failed or were skipped (an unavailable step is neither)."""
        return [e for e in self.entries if e.status in ("failed", "skipped")]

    @property
    def seconds(self) -> float:
        """Wall time since the log was created."""
        return time.perf_counter() - self.t0


def _unique(caught) -> list[str]:
    out = []
    for w in caught:
        text = f"{w.category.__name__}: {w.message}"
        if text not in out:
            out.append(text)
    return out


def agg_backend() -> None:
    """Draw with the non-interactive ``Agg`` backend (commands write files, never show)."""
    if "matplotlib.pyplot" not in sys.modules:
        import matplotlib

        matplotlib.use("Agg")


def _jsonable(x):
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.generic):
        x = x.item()
    if isinstance(x, float) and not np.isfinite(x):
        return str(x)
    if isinstance(x, complex):
        return [x.real, x.imag]
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    return x


def write_outputs(doc, out: str, models: dict, summary: dict, name: str = "report") -> dict:
    """Write the report, its markdown copy with figures, ``summary.json`` and the models.

    Parameters
    ----------
    doc : sdctrl.report.Document
        The report.
    out : str
        Output folder (created).
    models : dict
        ``{file stem: object}`` saved with :func:`sdctrl.save` (``.npz``), or written
        with :func:`sdctrl.write_uff` when the stem ends in ``.uff``.
    summary : dict
        Key numbers (JSON-able after conversion of numpy values).
    name : str
        Stem of the report files.

    Returns
    -------
    dict
        ``{"html": path, "markdown": path, "summary": path, "models": {stem: path}}``.
    """
    from sdctrl.data import write_uff
    from sdctrl.storage import save

    os.makedirs(out, exist_ok=True)
    paths = {"models": {}}
    for stem, obj in models.items():
        if stem.endswith(".uff"):
            path = os.path.join(out, stem)
            write_uff(obj, path)
        else:
            path = save(obj, os.path.join(out, stem + ".npz"))
        paths["models"][stem] = path
    html_path = os.path.join(out, f"{name}.html")
    with open(html_path, "w", encoding="utf-8") as fh:
        fh.write(doc.to_html())
    md, figures = doc.to_markdown("figures")
    for rel, data in figures.items():
        path = os.path.join(out, rel)
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(path, "wb") as fh:
            fh.write(data)
    md_path = os.path.join(out, f"{name}.md")
    with open(md_path, "w", encoding="utf-8") as fh:
        fh.write(md)
    summary_path = os.path.join(out, "summary.json")
    with open(summary_path, "w", encoding="utf-8") as fh:
        json.dump(_jsonable(summary), fh, indent=1)
    paths.update(html=html_path, markdown=md_path, summary=summary_path)
    return paths
