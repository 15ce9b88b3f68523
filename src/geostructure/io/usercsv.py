"""CSV tables people write by hand or in a spreadsheet: ground truth, control points.

A spreadsheet set to a European locale saves its CSV with semicolons between the cells and
commas as decimal marks (``A;40,5;100,5``). Both layouts are read alike: the separator is
the one the header line holds more of, and in a semicolon file a number written with a
decimal comma is read as with a point. Text cells (a surface's name) are left as written.
"""

from __future__ import annotations

import csv
import io
import re
from pathlib import Path

from geostructure.errors import InputError

#: A cell that starts as a number with a decimal comma: ``40,5``, ``-1,5e3``, ``89,5(E)``.
_DECIMAL_COMMA = re.compile(r"^\s*[+-]?\d*,\d+(?:[eE][+-]?\d+)?\s*(?:\(\s*[A-Za-z]+\s*\))?\s*$")


#: The largest table a person writes (a ground truth, a field map, control points, a WKT):
#: 32 MB is some 300,000 rows. A 150 MB truth of 7M rows took 2.9 GB and 22 s; a 2 GB sparse
#: file ran into the memory cap.
MAX_USER_TABLE_BYTES = 32 * 1024 * 1024


def user_text(path, what: str, limit: int = MAX_USER_TABLE_BYTES) -> str:
    """The text of a file a person gives (``what`` it should be, for the messages): checked
    to be a regular file (a FIFO hung the run) under ``limit`` bytes before a byte is read,
    and UTF-8 (an Excel byte-order mark dropped).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "truth.csv"
    >>> _ = path.write_bytes(b"surface,dip\\n" + b"0" * 100)
    >>> user_text(path, "ground-truth table", limit=50)
    Traceback (most recent call last):
    ...
    geostructure.errors.InputError: ...truth.csv: 112 bytes, more than any ground-truth table holds (at most 50); check it is the right file.
    """
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: no such {what} file.")
    if not path.is_file():
        raise InputError(f"{path}: is not a regular file (a folder, a pipe or a device); give the {what} as a file.")
    size = path.stat().st_size
    if size > limit:
        raise InputError(
            f"{path}: {size:,} bytes, more than any {what} holds (at most {limit:,}); check it is the right file."
        )
    try:
        with open(path, "rb") as fh:
            data = fh.read(limit + 1)
    except OSError as exc:
        raise InputError(f"{path}: cannot be read ({exc.strerror or exc}).") from None
    if len(data) > limit:  # grew while we looked
        raise InputError(f"{path}: more than {limit:,} bytes, more than any {what} holds; check it is the right file.")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise InputError(f"{path}: is not a text file (not UTF-8); save the {what} as UTF-8 text.") from None


def read_user_rows(path, what: str) -> list[list[str]]:
    """:func:`read_rows` of :func:`user_text`: a person's CSV, bounded, in one sentence when not one."""
    text = user_text(path, what)
    try:
        return read_rows(io.StringIO(text, newline=""))
    except csv.Error as exc:
        raise InputError(f"{path}: is not a readable CSV ({exc}).") from None


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
