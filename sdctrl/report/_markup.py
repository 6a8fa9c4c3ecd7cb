"""Markdown to HTML for the reports: inline markup, pipe tables, headings, lists, code.

A small renderer of the markdown that sdctrl writes (``UpdateResult.report()``, the
report sections...): no external dependency, everything escaped.
"""

from __future__ import annotations

import html
import re

__all__ = ["CSS", "html_table", "inline", "markdown_to_html", "nest_headings"]


def inline(text: str) -> str:
    """Escape, then ``code``, **bold**, *emphasis*, [links](url) and images as their alt.

    Parameters
    ----------
    text : str
        One paragraph or table cell of markdown.

    Returns
    -------
    str
        HTML.
    """
    parts = re.split(r"(`[^`]+`)", text)
    out = []
    for p in parts:
        if len(p) > 1 and p.startswith("`") and p.endswith("`"):
            out.append(f"<code>{html.escape(p[1:-1])}</code>")
            continue
        p = html.escape(p, quote=False)
        p = re.sub(r"!\[([^\]]*)\]\([^)]*\)", r"<em>[figure: \1]</em>", p)
        p = re.sub(r"\[([^\]]+)\]\(([^)\s]+)\)", r'<a href="\2">\1</a>', p)
        p = re.sub(r"\*\*([^*]+)\*\*", r"<strong>\1</strong>", p)
        p = re.sub(r"(?<![*\w])\*([^*\s][^*]*)\*(?![*\w])", r"<em>\1</em>", p)
        out.append(p)
    return "".join(out)


def _split_row(line: str) -> list[str]:
    cells = line.strip()
    cells = cells.removeprefix("|")
    cells = cells.removesuffix("|")
    return [c.strip() for c in cells.split("|")]


def html_table(header, rows, align=None) -> str:
    """HTML table of markdown cells.

    Parameters
    ----------
    header : sequence of str
        Column titles.
    rows : sequence of sequence
        Cells (inline markdown).
    align : sequence of str, optional
        Attribute string of each column (e.g. ``' class="num"'``).

    Returns
    -------
    str
        HTML.
    """
    align = align or [""] * len(header)
    th = "".join(f"<th{a}>{inline(str(h))}</th>" for h, a in zip(header, align))
    body = "".join("<tr>" + "".join(f"<td{a}>{inline(str(c))}</td>"
                                    for c, a in zip(r, align)) + "</tr>" for r in rows)
    return f"<table><thead><tr>{th}</tr></thead><tbody>{body}</tbody></table>"


def _table_block(lines: list[str]) -> str:
    header = _split_row(lines[0])
    align = []
    for c in _split_row(lines[1]) if len(lines) > 1 else []:
        right, left = c.endswith(":"), c.startswith(":")
        align.append(' class="num"' if right and not left else "")
    rows = [_split_row(x) for x in lines[2:]]
    return html_table(header, rows, align + [""] * (len(header) - len(align)))


def markdown_to_html(text: str, heading_offset: int = 0) -> str:
    """HTML of the markdown subset sdctrl's reports use.

    Headings, paragraphs, ``-`` lists, pipe tables, fenced code, inline code, bold,
    emphasis and links; raw HTML is escaped (a report never injects markup).

    Parameters
    ----------
    text : str
        Markdown.
    heading_offset : int
        Added to every heading level (``# x`` becomes ``<h3>`` with offset 2), so that an
        embedded report nests under its section.

    Returns
    -------
    str
    """
    lines = str(text).splitlines()
    out, para, i = [], [], 0

    def flush():
        if para:
            out.append(f"<p>{inline(' '.join(para))}</p>")
            para.clear()

    while i < len(lines):
        line = lines[i]
        s = line.strip()
        if s.startswith("```"):
            flush()
            j = i + 1
            while j < len(lines) and not lines[j].strip().startswith("```"):
                j += 1
            out.append(f"<pre>{html.escape(chr(10).join(lines[i + 1:j]))}</pre>")
            i = j + 1
            continue
        m = re.match(r"^(#{1,6})\s+(.*)$", s)
        if m:
            flush()
            level = min(len(m.group(1)) + heading_offset, 6)
            out.append(f"<h{level}>{inline(m.group(2))}</h{level}>")
        elif s.startswith("|"):
            flush()
            j = i
            while j < len(lines) and lines[j].strip().startswith("|"):
                j += 1
            out.append(_table_block(lines[i:j]))
            i = j
            continue
        elif s.startswith(("- ", "* ")):
            flush()
            items = []
            while i < len(lines) and lines[i].strip().startswith(("- ", "* ")):
                items.append(f"<li>{inline(lines[i].strip()[2:])}</li>")
                i += 1
            out.append(f"<ul>{''.join(items)}</ul>")
            continue
        elif not s:
            flush()
        else:
            para.append(s)
        i += 1
    flush()
    return "\n".join(out)


# --- the document ---------------------------------------------------------------------------
CSS = """
body{font-family:system-ui,-apple-system,"Segoe UI",Roboto,sans-serif;max-width:1100px;
margin:2em auto;padding:0 1em;line-height:1.45;color:#222}
h1{border-bottom:2px solid #345;padding-bottom:.2em}
h2{border-bottom:1px solid #ccd;margin-top:2em;padding-bottom:.1em}
code,pre{font-family:ui-monospace,Menlo,Consolas,monospace;font-size:.92em}
code{background:#f3f3f6;padding:0 .2em;border-radius:3px}
pre{background:#f6f6f9;padding:.6em;white-space:pre-wrap;overflow-wrap:anywhere}
table{border-collapse:collapse;margin:.6em 0;font-size:.92em}
th,td{border:1px solid #ccd;padding:.2em .55em;text-align:left}
th{background:#eef0f6}td.num{text-align:right}
td.ok{color:#176b1c;font-weight:bold}td.failed{color:#b00020;font-weight:bold}
figure{margin:1em 0}figure img{max-width:100%;border:1px solid #eee}
figcaption{font-size:.9em;color:#555}
nav ol{columns:2}.note{color:#555;font-size:.92em}.error{color:#b00020}
"""


def nest_headings(text: str) -> str:
    """Markdown with every heading two levels deeper (an embedded report in a section).

    Parameters
    ----------
    text : str
        Markdown.

    Returns
    -------
    str
        The same markdown, headings outside code fences demoted by two levels.
    """
    out, fence = [], False
    for line in text.splitlines():
        if line.strip().startswith("```"):
            fence = not fence
        out.append("##" + line if not fence and re.match(r"^#{1,4}\s", line) else line)
    return "\n".join(out)
