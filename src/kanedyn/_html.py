"""Small HTML pieces for the notebook displays (``_repr_html_``) of kanedyn objects.

Everything shown is escaped; figures are inlined as base64 PNG, so a saved
notebook shows them without any file next to it.
"""

from __future__ import annotations

import base64
import html
import io
import math

__all__ = ["number", "table", "png", "box", "names"]

_STYLE = ("font-family: sans-serif; font-size: 12px; border-collapse: collapse; "
          "margin: 2px 12px 2px 0")


def number(value, digits=6):
    """A number as short text (``nan``/``inf`` as such, integers without a point)."""
    if value is None:
        return "n/a"
    if isinstance(value, bool):
        return str(value)
    if isinstance(value, int):
        return str(value)
    value = float(value)
    if not math.isfinite(value):
        return str(value)
    return f"{value:.{digits}g}"


def table(rows, caption=None, headers=None):
    """An HTML table of ``rows`` (sequences of cells; cells are escaped text)."""
    out = [f'<table style="{_STYLE}">']
    if caption:
        out.append(f'<caption style="text-align: left; font-weight: bold">'
                   f"{html.escape(str(caption))}</caption>")
    if headers:
        out.append("<tr>" + "".join(f'<th style="text-align: left; padding: 1px 6px">'
                                    f"{html.escape(str(h))}</th>" for h in headers) + "</tr>")
    rows = [list(row) for row in rows]
    width = max((len(row) for row in rows), default=0)
    numeric = [k > 0 and all(_numeric(row[k]) for row in rows if len(row) > k)
               for k in range(width)]  # columns of numbers only: right-aligned
    for row in rows:
        cells = []
        for k, cell in enumerate(row):
            tag = "th" if k == 0 and not headers else "td"
            align = "right" if numeric[k] else "left"
            cells.append(f'<{tag} style="text-align: {align}; padding: 1px 6px">'
                         f"{html.escape(str(cell))}</{tag}>")
        out.append("<tr>" + "".join(cells) + "</tr>")
    out.append("</table>")
    return "".join(out)


def _numeric(cell):
    try:
        float(str(cell))
    except ValueError:
        return False
    return True


def png(figure, dpi=60, alt="plot"):
    """``<img>`` of a Matplotlib figure, inlined as base64 PNG."""
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=dpi)
    data = base64.b64encode(buffer.getvalue()).decode("ascii")
    return f'<img alt="{html.escape(alt)}" src="data:image/png;base64,{data}"/>'


def box(*parts, title=None):
    """Parts side by side (wrapping), under an optional title line."""
    head = (f'<div style="font-family: sans-serif; font-weight: bold; margin-bottom: 4px">'
            f"{html.escape(title)}</div>" if title else "")
    body = "".join(f'<div style="display: inline-block; vertical-align: top">{p}</div>'
                   for p in parts if p)
    return f'<div class="kanedyn">{head}{body}</div>'


def names(items, limit=12):
    """Comma-separated names, the first ``limit`` of them and how many more."""
    items = [str(i) for i in items]
    if not items:
        return "none"
    shown = ", ".join(items[:limit])
    return shown + (f", ... ({len(items) - limit} more)" if len(items) > limit else "")
