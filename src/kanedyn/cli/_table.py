"""Plain-text tables of the command line (the ``tabulate`` library)."""

from __future__ import annotations

__all__ = ["table"]


def table(rows, headers, title=None, floatfmt="g", widths=None):
    """Rows as a plain-text table with aligned columns.

    Parameters
    ----------
    rows : sequence of sequences
    headers : sequence of str
    title : str, optional
        A line above the table.
    floatfmt : str or sequence of str
        Format of float cells (per column when a sequence).
    widths : sequence of int or None, optional
        Per column, the most characters of a line (longer cells are wrapped).

    Returns
    -------
    str
    """
    from tabulate import tabulate
    text = tabulate(rows, headers=headers, tablefmt="simple", floatfmt=floatfmt,
                    disable_numparse=False, maxcolwidths=widths)
    return f"{title}\n{text}" if title else text
