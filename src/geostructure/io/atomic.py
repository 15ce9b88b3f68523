"""Atomic single files and strict JSON: the lowest layer every writer uses.

A file goes to a temporary name beside its target and is renamed into place only when
complete, so an interrupted write never leaves half a file under the real name. JSON is
written strictly (RFC 8259 has no NaN): non-finite floats become ``null``.
"""

from __future__ import annotations

import json
import math
import os
import re
import tempfile
from contextlib import contextmanager
from pathlib import Path

import numpy as np

#: Temporary names made by :func:`atomic_path`: ``.<name>.<random>.tmp``.
TEMP_PATTERN = re.compile(r"^\.(?P<name>.+)\.[A-Za-z0-9_]{8}\.tmp$")


def _file_mode() -> int:
    """The mode an ordinary new file gets under the current umask (mkstemp would give 0600)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return 0o666 & ~mask


@contextmanager
def atomic_path(path):
    """Yield a temporary path beside ``path``; rename it onto ``path`` if the block succeeds.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> target = pathlib.Path(tempfile.mkdtemp()) / "a.txt"
    >>> with atomic_path(target) as tmp:
    ...     _ = tmp.write_text("done")
    >>> target.read_text()
    'done'
    """
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    os.chmod(tmp, _file_mode())
    try:
        yield Path(tmp)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def json_ready(value):
    """``value`` as plain JSON types: numpy scalars and arrays unwrapped, non-finite floats None.

    Examples
    --------
    >>> json_ready({"a": np.float64("nan"), "b": np.arange(2), "c": (1.5, float("inf"))})
    {'a': None, 'b': [0, 1], 'c': [1.5, None]}
    """
    if isinstance(value, dict):
        return {str(k): json_ready(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_ready(v) for v in value]
    if isinstance(value, np.ndarray):
        return json_ready(value.tolist())
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, Path):
        return str(value)
    return value


def json_text(data, indent: int | None = 2) -> str:
    """Strict JSON text of ``data`` (see :func:`json_ready`); never ``NaN`` or ``Infinity``."""
    return json.dumps(json_ready(data), indent=indent, allow_nan=False)


def write_json(data: dict, path) -> Path:
    """Write ``data`` as strict JSON to ``path``, atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(json_text(data) + "\n", encoding="utf-8")
    return Path(path)


def write_figure(fig, stem, formats=("png", "svg"), **savefig) -> list[Path]:
    """Save a matplotlib figure as ``stem.<format>`` for each format, each file atomically."""
    paths = []
    for fmt in formats:
        path = Path(f"{stem}.{fmt}")
        with atomic_path(path) as tmp:
            fig.savefig(tmp, format=fmt, **savefig)
        paths.append(path)
    return paths


def format_number(value) -> str:
    """A CSV cell: integers as such, floats in the shortest form that reads back to the same
    float64 (``repr``), so UTM coordinates keep every bit.

    Examples
    --------
    >>> format_number(np.int64(3)), format_number(4650000.123456789), format_number(0.1)
    ('3', '4650000.123456789', '0.1')
    """
    if isinstance(value, (bool, np.bool_)):
        return str(bool(value)).lower()
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    return repr(float(value))


_AS_WRITTEN = (int, float)

#: What makes a spreadsheet read a cell as a formula (OWASP's CSV injection list).
_FORMULA_START = ("=", "+", "-", "@", "\t", "\r")


def text_cell(text: str) -> str:
    """A text cell that no spreadsheet runs as a formula: one that starts with ``=``, ``+``,
    ``-``, ``@``, a tab or a carriage return gets a leading single quote (OWASP's advice),
    unless it is a plain number (``-2.5`` stays a number). Every text cell the project writes
    to a CSV goes through here, so a surface named ``=HYPERLINK(...)`` in a user's truth
    file cannot run in the colleague's spreadsheet that opens ``evaluation.csv``.

    Examples
    --------
    >>> text_cell("=1+1"), text_cell("-2.5"), text_cell("@SUM(A1)"), text_cell("wall")
    ("'=1+1", '-2.5', "'@SUM(A1)", 'wall')
    >>> text_cell("+nan"), text_cell("-inf")
    ("'+nan", "'-inf")
    """
    if not text.startswith(_FORMULA_START):
        return text
    try:
        number = float(text)
    except ValueError:
        return "'" + text
    # "+nan" and "-inf" parse as numbers here, but a spreadsheet reads them as a formula
    # or an infinity: a set or a surface named so is text
    return text if math.isfinite(number) else "'" + text


def write_columns_csv(columns: dict, path) -> Path:
    """Columns of one length (name -> array or list) as CSV, atomically: the same file
    :func:`write_table_csv` writes from their rows, without a dict per row (a quarter of a
    million wedges took 0.7 s that way).

    Examples
    --------
    >>> import tempfile, os
    >>> path = os.path.join(tempfile.mkdtemp(), "t.csv")
    >>> _ = write_columns_csv({"id": np.array([3, 4]), "fs": np.array([0.1, np.nan]), "on": ["both", "7"]}, path)
    >>> open(path).read().splitlines()
    ['id,fs,on', '3,0.1,both', '4,nan,7']
    """
    cells = [_cells(values) for values in columns.values()]
    text = [column for column, values in zip(cells, columns.values()) if np.asarray(values).dtype.kind not in "biuf"]
    if any(any(c in cell for c in ',"\r\n') for column in text for cell in column):
        n = len(cells[0]) if cells else 0  # a cell to quote: the csv module's way
        return write_table_csv([dict(zip(columns, row)) for row in zip(*cells)] if n else [], path, columns=columns)
    with atomic_path(path) as tmp:
        with open(tmp, "w", newline="", encoding="utf-8") as fh:
            fh.write(",".join(columns) + "\r\n")  # the csv module's line ends
            fh.writelines(",".join(row) + "\r\n" for row in zip(*cells))
    return Path(path)


def _cells(values) -> list[str]:
    """One column's cells as :func:`format_number` writes them."""
    array = np.asarray(values)
    if array.dtype.kind == "b":
        return ["true" if v else "false" for v in array.tolist()]
    if array.dtype.kind in "iu":
        return list(map(str, array.tolist()))
    if array.dtype.kind == "f":
        return list(map(repr, array.astype(np.float64).tolist()))
    return [text_cell(str(v)) for v in values]


def _table_cell(value):
    """A row's cell: Python's int and float as the csv module writes them (a float's str is
    its repr, as format_number), text through text_cell, numpy's and bools through
    format_number."""
    if type(value) in _AS_WRITTEN:
        return value
    if isinstance(value, str):
        return text_cell(value)
    return format_number(value)


def write_table_csv(rows: list[dict], path, columns=None) -> Path:
    """A list of same-keyed dicts as CSV, atomically; the header is ``columns`` or the first
    row's keys, so a table with no rows still has its header when ``columns`` is given.
    Each row's values are taken by the header's names, not in its own order: a row with a
    key the header lacks, or in another order, cannot shift a column under another's name."""
    import csv

    header = list(columns) if columns is not None else (list(rows[0]) if rows else [])
    with atomic_path(path) as tmp:
        with open(tmp, "w", newline="", encoding="utf-8") as fh:
            writer = csv.writer(fh)
            if header:
                writer.writerow(header)
            for row in rows:
                writer.writerow([_table_cell(row[name]) for name in header])
    return Path(path)
