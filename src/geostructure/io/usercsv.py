"""CSV tables people write by hand or in a spreadsheet: ground truth, control points.

A spreadsheet set to a European locale saves its CSV with semicolons between the cells and
commas as decimal marks (``A;40,5;100,5``). Both layouts are read alike: the separator is
the one the header line holds more of, and in a semicolon file a number written with a
decimal comma is read as with a point. Text cells (a surface's name) are left as written.
"""

from __future__ import annotations

import csv
import re

#: A cell that starts as a number with a decimal comma: ``40,5``, ``-1,5e3``, ``89,5(E)``.
_DECIMAL_COMMA = re.compile(r"^\s*[+-]?\d*,\d+(?:[eE][+-]?\d+)?\s*(?:\(\s*[A-Za-z]+\s*\))?\s*$")


def read_rows(fh) -> list[list[str]]:
    """The rows of an open CSV (``newline=""``), comma- or semicolon-separated, decimal
    commas turned to points in a semicolon file's numeric cells.

    Examples
    --------
    >>> import io
    >>> read_rows(io.StringIO("surface;dip;dip_direction\\nA, north;40,5;100\\n"))
    [['surface', 'dip', 'dip_direction'], ['A, north', '40.5', '100']]
    >>> read_rows(io.StringIO("surface,dip\\nA,40.5\\n"))
    [['surface', 'dip'], ['A', '40.5']]
    """
    text = fh.read()
    header = next((line for line in text.splitlines() if line.strip()), "")
    semicolons = header.count(";") > header.count(",")
    rows = list(csv.reader(text.splitlines(), delimiter=";" if semicolons else ","))
    if semicolons:
        rows = [[c.replace(",", ".") if _DECIMAL_COMMA.match(c) else c for c in row] for row in rows]
    return rows
