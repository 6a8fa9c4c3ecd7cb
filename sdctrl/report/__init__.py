"""Reports people read: one self-contained HTML page (and its markdown copy).

A :class:`Document` holds sections of paragraphs, tables, figures and *key numbers against
the truth* (:class:`Check`); :meth:`Document.to_html` writes one HTML file with a table of
contents, inline CSS and every figure embedded as a base64 PNG (it opens anywhere, e-mails
as one attachment), :meth:`Document.to_markdown` a markdown copy whose figures are separate
PNG files.  The ``sdctrl demo`` and ``sdctrl identify`` commands write their reports with it;
the markdown reports of results (``UpdateResult.report()``, ...) are embedded with
:meth:`Section.markdown`.
"""

from __future__ import annotations

import base64
import html
import io
from dataclasses import dataclass

import numpy as np

from sdctrl._lib.display import markdown_table
from sdctrl.report._markup import CSS, html_table, inline, markdown_to_html, nest_headings

__all__ = ["Check", "Document", "Section", "markdown_table", "markdown_to_html", "modes_table",
           "psd_check"]


def modes_table(poles, reference=None) -> str:
    """Table of frequencies (Hz) and damping ratios (%) of complex poles (rad/s).

    Parameters
    ----------
    poles : array_like
        Complex poles, upper half-plane.
    reference : array_like, optional
        Reference poles to compare with (same order): errors are added as columns.

    Returns
    -------
    str
        Markdown table.
    """
    poles = np.asarray(poles, dtype=complex)
    f = np.abs(poles) / (2 * np.pi)
    z = -poles.real / np.abs(poles)
    if reference is None:
        rows = [(j + 1, f"{f[j]:.4f}", f"{100 * z[j]:.3f}") for j in range(poles.size)]
        return markdown_table(["mode", "frequency (Hz)", "damping (%)"], rows)
    ref = np.asarray(reference, dtype=complex)
    fr = np.abs(ref) / (2 * np.pi)
    zr = -ref.real / np.abs(ref)
    rows = [(j + 1, f"{fr[j]:.4f}", f"{f[j]:.4f}", f"{(f[j] - fr[j]) / fr[j]:.1e}",
             f"{100 * zr[j]:.3f}", f"{100 * z[j]:.3f}", f"{100 * (z[j] - zr[j]):.1e}")
            for j in range(poles.size)]
    return markdown_table(["mode", "f true (Hz)", "f model (Hz)", "f rel. error",
                           "zeta true (%)", "zeta model (%)", "zeta error (% points)"], rows)


# --- key numbers ----------------------------------------------------------------------------
def _fmt(x) -> str:
    if x is None:
        return ""
    if isinstance(x, bool | np.bool_):
        return "yes" if x else "no"
    if isinstance(x, int | np.integer):
        return str(int(x))
    if isinstance(x, float | np.floating):
        v = float(x)
        if not np.isfinite(v):
            return str(v)
        return f"{v:.4g}" if v == 0 or 1e-3 <= abs(v) < 1e5 else f"{v:.3e}"
    return str(x)


@dataclass(frozen=True, eq=False)
class Check:
    """A key number of a report against the truth it should match.

    Parameters
    ----------
    quantity : str
        What is measured (e.g. ``"max frequency error"``).
    value : float, int, bool or str
        The number obtained.
    truth : float, int, bool or str, optional
        The true or expected value (None: no truth is known, e.g. a user's own data).
    error : float, optional
        The error of ``value`` against ``truth`` in the unit ``error_unit``.
    tolerance : float, optional
        Largest acceptable ``|error|``; None when no tolerance is stated.
    unit : str
        Unit of ``value`` and ``truth``.
    error_unit : str
        Unit (or kind) of ``error``: ``"rel."``, ``"%"``, ``"abs."``...
    """

    quantity: str
    value: object
    truth: object = None
    error: float | None = None
    tolerance: float | None = None
    unit: str = ""
    error_unit: str = "rel."

    @property
    def passed(self) -> bool | None:
        """``|error| <= tolerance``; for a value without error, ``value == truth``; None
        when nothing is stated."""
        if self.tolerance is not None and self.error is not None:
            return bool(np.isfinite(self.error) and abs(self.error) <= self.tolerance)
        if self.error is None and self.truth is not None and self.tolerance is None:
            return self.value == self.truth
        return None

    def row(self) -> tuple[str, ...]:
        """Formatted cells: quantity, value, truth, error, tolerance, verdict."""
        unit = f" {self.unit}" if self.unit else ""
        err = "" if self.error is None else f"{_fmt(self.error)} {self.error_unit}".strip()
        tol = "" if self.tolerance is None else f"{_fmt(self.tolerance)} {self.error_unit}"
        verdict = {True: "ok", False: "FAILED", None: ""}[self.passed]
        truth = "" if self.truth is None else _fmt(self.truth) + unit
        return (self.quantity, _fmt(self.value) + unit, truth, err, tol.strip(), verdict)


def psd_check(nm) -> list[Check]:
    """The positive-semi-definiteness (3.45) of a normal-mode model's damping, named by its
    size, so that a report gives one verdict per model however many models it shows.

    Parameters
    ----------
    nm : NormalModeModel
        A model from :func:`sdctrl.normal_modes` (its ``properness`` record holds the
        eigenvalues of the identified damping relative to the mass, rad/s).

    Returns
    -------
    list of Check
        The verdict (``yes``/``no``, no truth: an identified damping matrix may be
        indefinite by the noise alone) and, when known, the smallest eigenvalue (rad/s)
        with its size relative to the largest.
    """
    rec = getattr(nm, "properness", None)
    pd = (rec.positive_definite if rec is not None else None) or {}
    name = f"damping matrix of the {nm.n}-mode model"
    out = [Check(f"{name}: positive semi-definite (3.45)", bool(pd.get("damping", True)))]
    ev = None if rec is None else rec.damping_eigenvalues
    if ev is not None and np.size(ev):
        ev = np.asarray(ev, float)
        big = float(np.abs(ev).max()) or 1.0
        out.append(Check(f"{name}: smallest eigenvalue ({ev.min() / big:.1e} of the largest, "
                         f"{big:.3g} rad/s)", float(ev.min()), unit="rad/s"))
    return out


_CHECK_HEADER = ("quantity", "obtained", "truth", "error", "tolerance", "")


# --- markdown subset to HTML ----------------------------------------------------------------
class Section:
    """One section of a :class:`Document` (built by :meth:`Document.section`).

    Parameters
    ----------
    key : str
        Anchor (``id``) of the section, also the stem of its figure files.
    title : str
        Heading.
    """

    def __init__(self, key: str, title: str):
        self.key, self.title = str(key), str(title)
        self.blocks: list[tuple] = []
        self.checks: list[Check] = []
        self.figures: list[str] = []

    def paragraph(self, text: str) -> Section:
        """Add a paragraph (inline markdown: ``code``, **bold**, *emphasis*).

        Parameters
        ----------
        text : str
            The paragraph.

        Returns
        -------
        Section
            This section (calls chain).
        """
        self.blocks.append(("p", str(text)))
        return self

    def markdown(self, text: str) -> Section:
        """Embed a markdown fragment (e.g. ``result.report()``), headings nested.

        Parameters
        ----------
        text : str
            Markdown (headings, tables, lists, paragraphs).

        Returns
        -------
        Section
            This section (calls chain).
        """
        self.blocks.append(("md", str(text)))
        return self

    def table(self, header, rows, caption: str | None = None) -> Section:
        """Add a table of already formatted cells.

        Parameters
        ----------
        header : sequence of str
            Column titles.
        rows : sequence of sequence
            Cells (numbers are formatted, the rest str()'d).
        caption : str, optional
            Caption under the table.

        Returns
        -------
        Section
            This section (calls chain).
        """
        self.blocks.append(("table", tuple(map(str, header)),
                            [tuple(map(_fmt, r)) for r in rows], caption))
        return self

    def key_numbers(self, checks) -> Section:
        """Add the section's key numbers against the truth (a table of :class:`Check`).

        Parameters
        ----------
        checks : iterable of Check
            Quantities, values, truths and tolerances.

        Returns
        -------
        Section
            This section (calls chain).
        """
        checks = list(checks)
        self.checks.extend(checks)
        self.blocks.append(("checks", checks))
        return self

    def code(self, text: str) -> Section:
        """Add preformatted text.

        Parameters
        ----------
        text : str
            Shown as is, in a monospace block.

        Returns
        -------
        Section
            This section (calls chain).
        """
        self.blocks.append(("pre", str(text)))
        return self

    def error(self, text: str) -> Section:
        """Add an error message (a failed step).

        Parameters
        ----------
        text : str
            The message (and traceback).

        Returns
        -------
        Section
            This section (calls chain).
        """
        self.blocks.append(("error", str(text)))
        return self

    def figure(self, fig, caption: str, name: str | None = None, dpi: int = 96) -> Section:
        """Add a matplotlib figure (rendered to PNG now, then closed).

        Parameters
        ----------
        fig : matplotlib.figure.Figure
            The figure.
        caption : str
            Caption (inline markdown).
        name : str, optional
            Figure id (``fig-<name>`` anchor, file stem in the markdown copy).
        dpi : int
            Resolution of the PNG.

        Returns
        -------
        Section
            This section (calls chain).
        """
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=dpi)
        from matplotlib import pyplot as plt

        plt.close(fig)
        name = name or f"{self.key}_{len(self.figures) + 1}"
        self.figures.append(name)
        self.blocks.append(("figure", name, buf.getvalue(), str(caption)))
        return self

    # rendering
    def _html(self, level: int = 2) -> str:
        head = html.escape(self.title)
        out = [f'<section id="{html.escape(self.key)}"><h{level}>{head}</h{level}>']
        for b in self.blocks:
            kind = b[0]
            if kind == "p":
                out.append(f"<p>{inline(b[1])}</p>")
            elif kind == "md":
                out.append(markdown_to_html(b[1], heading_offset=level))
            elif kind == "pre":
                out.append(f"<pre>{html.escape(b[1])}</pre>")
            elif kind == "error":
                out.append(f'<pre class="error">{html.escape(b[1])}</pre>')
            elif kind == "table":
                cap = f'<p class="note">{inline(b[3])}</p>' if b[3] else ""
                out.append(html_table(b[1], b[2]) + cap)
            elif kind == "checks":
                out.append(_checks_html(b[1]))
            elif kind == "figure":
                data = base64.b64encode(b[2]).decode("ascii")
                out.append(f'<figure id="fig-{html.escape(b[1])}"><img alt="{html.escape(b[1])}"'
                           f' src="data:image/png;base64,{data}"><figcaption>{inline(b[3])}'
                           "</figcaption></figure>")
        out.append("</section>")
        return "\n".join(out)

    def _markdown(self, figure_dir: str) -> tuple[str, dict]:
        out, files = [f"## {self.title}", ""], {}
        for b in self.blocks:
            kind = b[0]
            if kind == "p":
                out += [b[1], ""]
            elif kind == "md":
                out += [nest_headings(b[1]), ""]
            elif kind in ("pre", "error"):
                out += ["```", b[1], "```", ""]
            elif kind == "table":
                out += [markdown_table(b[1], b[2]), ""] + ([b[3], ""] if b[3] else [])
            elif kind == "checks":
                out += [markdown_table(_CHECK_HEADER, [c.row() for c in b[1]]), ""]
            elif kind == "figure":
                path = f"{figure_dir}/{b[1]}.png"
                files[path] = b[2]
                out += [f"![{b[3]}]({path})", "", f"*{b[3]}*", ""]
        return "\n".join(out), files


def _checks_html(checks) -> str:
    head = "".join(f"<th>{h}</th>" for h in _CHECK_HEADER)
    rows = []
    for c in checks:
        cells = c.row()
        cls = {True: ' class="ok"', False: ' class="failed"', None: ""}[c.passed]
        rows.append("<tr>" + "".join(f'<td{" class=num" if 0 < k < 5 else ""}>'
                                     f"{inline(x)}</td>" for k, x in enumerate(cells[:-1]))
                    + f"<td{cls}>{cells[-1]}</td></tr>")
    return (f'<table class="checks"><thead><tr>{head}</tr></thead><tbody>{"".join(rows)}'
            "</tbody></table>")


class Document:
    """A report: title, introduction, sections; rendered to HTML or markdown.

    Parameters
    ----------
    title : str
        Title of the report.
    intro : str, optional
        First paragraph (inline markdown).

    Examples
    --------
    >>> doc = Document("demo")
    >>> s = doc.section("id", "Identification").paragraph("12 modes").key_numbers(
    ...     [Check("modes", 12, 12)])
    >>> "<nav>" in doc.to_html() and doc.checks[0].passed
    True
    """

    def __init__(self, title: str, intro: str | None = None):
        self.title = str(title)
        self.intro = intro
        self.sections: list[Section] = []

    def section(self, key: str, title: str) -> Section:
        """Append a new section and return it.

        Parameters
        ----------
        key : str
            Anchor (unique in the document).
        title : str
            Heading and table-of-contents entry.

        Returns
        -------
        Section
            The new, empty section.
        """
        if any(s.key == key for s in self.sections):
            raise ValueError(f"key: a section {key!r} already exists")
        s = Section(key, title)
        self.sections.append(s)
        return s

    @property
    def checks(self) -> list[Check]:
        """Every key number of every section, in order."""
        return [c for s in self.sections for c in s.checks]

    def to_html(self) -> str:
        """The whole report as one self-contained HTML page."""
        toc = "".join(f'<li><a href="#{html.escape(s.key)}">{html.escape(s.title)}</a></li>'
                      for s in self.sections)
        intro = f"<p>{inline(self.intro)}</p>" if self.intro else ""
        body = "\n".join(s._html() for s in self.sections)
        return (f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
                f'<meta name="viewport" content="width=device-width, initial-scale=1">'
                f"<title>{html.escape(self.title)}</title><style>{CSS}</style></head><body>"
                f"<h1>{html.escape(self.title)}</h1>{intro}<nav><h2>Contents</h2><ol>{toc}"
                f"</ol></nav>\n{body}\n</body></html>\n")

    def to_markdown(self, figure_dir: str = "figures") -> tuple[str, dict[str, bytes]]:
        """Markdown copy and its figures.

        Parameters
        ----------
        figure_dir : str
            Folder (relative to the markdown file) the figures are referenced in.

        Returns
        -------
        (str, dict)
            The markdown text and ``{relative path: PNG bytes}`` of its figures.
        """
        parts, files = [f"# {self.title}", ""] + ([self.intro, ""] if self.intro else []), {}
        parts += ["Contents:", ""] + [f"{k + 1}. {s.title}" for k, s in enumerate(self.sections)]
        parts.append("")
        for s in self.sections:
            text, f = s._markdown(figure_dir)
            parts.append(text)
            files.update(f)
        return "\n".join(parts), files
