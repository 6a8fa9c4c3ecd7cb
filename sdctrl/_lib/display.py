"""Small display helpers shared by the models' reprs and the reports (internal).

Every model and result prints as one short line (sizes, frequency range, key figures), never
its arrays; notebooks get a markdown table from ``_repr_markdown_`` where one helps.
"""

from __future__ import annotations

import numpy as np

__all__ = ["MAX_ROWS", "hz_range", "markdown_table", "one_line"]

#: rows shown by the notebook tables of models before "... and k more"
MAX_ROWS = 40


def hz_range(freq) -> str:
    """``"20.1-58.3 Hz"`` for an array of frequencies in Hz (``"no modes"`` when empty).

    Parameters
    ----------
    freq : array_like
        Frequencies (Hz).

    Returns
    -------
    str

    Examples
    --------
    >>> hz_range([58.31, 20.12, 33.0])
    '20.1-58.3 Hz'
    """
    f = np.asarray(freq, dtype=float).ravel()
    if f.size == 0:
        return "no modes"
    lo, hi = np.nanmin(f), np.nanmax(f)
    return f"{lo:.3g} Hz" if lo == hi else f"{lo:.3g}-{hi:.3g} Hz"


def one_line(name: str, parts) -> str:
    """``name(part, part, ...)`` skipping empty parts.

    Parameters
    ----------
    name : str
        Class name.
    parts : iterable of str
        The pieces of the summary.

    Returns
    -------
    str
    """
    return f"{name}({', '.join(p for p in parts if p)})"


def markdown_table(header, rows, max_rows: int | None = None) -> str:
    """Markdown table from a header and rows of already formatted cells.

    Parameters
    ----------
    header : sequence of str
        Column titles.
    rows : sequence of sequence
        Cells, converted with ``str``.
    max_rows : int, optional
        Show at most this many rows, then a line ``... and k more``.

    Returns
    -------
    str

    Examples
    --------
    >>> print(markdown_table(["mode", "f (Hz)"], [(1, "20.1"), (2, "33.0")]))
    | mode | f (Hz) |
    |---|---|
    | 1 | 20.1 |
    | 2 | 33.0 |
    """
    rows = list(rows)
    shown = rows if max_rows is None else rows[:max_rows]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in shown]
    if len(shown) < len(rows):
        lines.append(f"\n... and {len(rows) - len(shown)} more")
    return "\n".join(lines)
