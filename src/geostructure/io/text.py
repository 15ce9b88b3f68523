"""Text clouds: XYZ, TXT, CSV, PTS and ASC, as scanners, surveying software and spreadsheets
write them.

The layout is read from the first lines: the separator (spaces, a comma, a semicolon or a
tab), a header (which may name the coordinate columns), decimal commas, fields in double quotes,
and a PTS file's lines of a block's point count. The rows go through numpy's C parser.
"""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np

from geostructure.core.cloud import Cloud
from geostructure.errors import GeoStructureError, InputError

_NUMBER = re.compile(r"^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$|^[+-]?(nan|inf)$", re.I)


def read_text(path: Path, colour: bool = True) -> Cloud:
    """XYZ/TXT/CSV/PTS: space, comma, semicolon or tab separated; x y z first, or where a
    header names them (:func:`_coordinate_columns`); a PTS file's lines of a block's point
    count skipped. Decimal commas (``1,5;2,25;3,0``, as a spreadsheet in much of Europe saves its CSV) are
    read where the separator is a semicolon, a tab or spaces. Red, green and blue columns
    (:func:`_colour_columns`) give each point's ``grey``, unless ``colour`` is off."""
    first_lines = _first_data_lines(path, 2)
    if not first_lines:
        raise InputError(f"{path}: holds no points.")
    check_no_control_characters(path)
    # A PTS file (Leica, FARO) opens each block of points with a line holding its count.
    counted = len(first_lines) == 2 and first_lines[0][1].strip().isdigit() and len(first_lines[1][1].split()) >= 3
    if counted:
        first_lines = first_lines[1:]
    # "1.5","2.25","3.0": some spreadsheets and scripts quote every field. numpy's parser
    # takes quotes only with a single comment mark, so the lines lose theirs on the way in.
    quoted = '"' in first_lines[-1][1]
    if quoted:
        first_lines = [(number, _unquoted(line)) for number, line in first_lines]
    delimiter, decimal_comma = _sniff_layout(first_lines[-1][1])
    first = _decimal_points(first_lines[0][1]) if decimal_comma else first_lines[0][1]
    header = not all(_NUMBER.match(f) for f in _split(first, delimiter)[:3])
    skip = (first_lines[0][0] if header else first_lines[0][0] - 1) - counted  # the count line is not read
    fields = _split(first, delimiter)
    columns = _coordinate_columns(fields, path) if header else (0, 1, 2)
    colour = _colour_columns(fields, columns, header) if colour else ()
    columns = columns + colour
    try:  # numpy's C parser: fast; on failure, scan the lines to name the bad one
        with warnings.catch_warnings(), open(path, encoding="utf-8-sig") as fh:
            warnings.simplefilter("ignore", UserWarning)  # "input contained no data": said below in our words
            lines = (line for line in fh if not line.strip().isdigit()) if counted else fh
            lines = (_unquoted(line) for line in lines) if quoted else lines
            points = np.loadtxt(
                (_decimal_points(line) for line in lines) if decimal_comma else lines,
                dtype=np.float64,
                delimiter=delimiter,
                usecols=columns,
                comments=("#", "//"),
                skiprows=skip,
                ndmin=2,
            )
    except UnicodeDecodeError:
        raise InputError(f"{path}: is not a text file (not UTF-8).") from None
    except (ValueError, IndexError):
        if colour:  # a later line without colour: the coordinates alone, as before
            return read_text(path, colour=False)
        _raise_bad_line(path, delimiter, skip + counted, columns, decimal_comma, counted, quoted)
        raise
    grey = grey_of(points[:, 3:6]) if colour else None
    return Cloud.from_points(points[:, :3], source=str(path), grey=grey)


#: Bytes no text cloud holds: the C0 controls but tab, line feed and carriage return, and DEL.
CONTROL_BYTES = re.compile(rb"[\x00-\x08\x0b\x0c\x0e-\x1f\x7f]")
#: Bytes of a text file scanned at a time.
SCAN_BLOCK = 1 << 24


def check_no_control_characters(path: Path) -> None:
    """Refuse a text cloud holding a control character (a vertical tab, a form feed, a NUL)
    or a line longer than :data:`MAX_LINE`, naming its line, in one pass at the disk's
    speed before the parser: it read a vertical tab inside a number as a break between
    columns, so ``5<VT>0006`` became two numbers and the point was kept with a wrong z; a
    sparse 2 GB file (NULs) or a 60 MB line ran it into the memory cap.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "cloud.xyz"
    >>> _ = path.write_bytes(b"1 2 3\\n4 5 6\\n7 8 5\\x0b0006\\n")
    >>> check_no_control_characters(path)
    Traceback (most recent call last):
    ...
    geostructure.errors.InputError: ...cloud.xyz: line 3 holds a control character (\\x0b) inside its row; the file may be damaged.
    """
    lines, since_break = 0, 0  # lines before this block; bytes since the last line break
    with open(path, "rb") as fh:
        while block := fh.read(SCAN_BLOCK):
            found = CONTROL_BYTES.search(block)
            if found is not None:
                line = lines + block.count(b"\n", 0, found.start()) + 1
                byte = found.group()[0]
                name = "NUL" if byte == 0 else f"\\x{byte:02x}"
                raise InputError(
                    f"{path}: line {line:,} holds a control character ({name}) inside its row; the file may be damaged."
                )
            breaks = np.flatnonzero(np.frombuffer(block, dtype=np.uint8) == 10)
            gaps = np.diff(np.r_[-1 - since_break, breaks, len(block)])  # each line's length, the last one open
            if gaps.max() > MAX_LINE:
                line = lines + int(np.argmax(gaps > MAX_LINE)) + 1
                raise InputError(
                    f"{path}: line {line:,} runs past {MAX_LINE:,} bytes, which no row of a cloud does; "
                    f"the file may be damaged."
                )
            since_break = len(block) - 1 - int(breaks[-1]) if len(breaks) else since_break + len(block)
            lines += len(breaks)


#: Header names of colour columns (lower case, as :data:`AXIS_NAMES`).
COLOUR_NAMES = (("r", "red"), ("g", "green"), ("b", "blue"))


def _colour_columns(fields: list[str], columns: tuple, header: bool) -> tuple:
    """The red, green and blue columns: those a header names (:data:`COLOUR_NAMES`), or,
    without a header, the three after x, y and z where the first line holds whole numbers
    from 0 to 255 there (DICE's and CloudCompare's ``x y z r g b``); () for none.

    Examples
    --------
    >>> _colour_columns(["1.5", "2", "3", "92", "96", "98"], (0, 1, 2), False)
    (3, 4, 5)
    >>> _colour_columns(["1.5", "2", "3", "0.1", "0.2", "0.97"], (0, 1, 2), False)  # normals, not colour
    ()
    >>> _colour_columns(["x", "y", "z", "Red", "Green", "Blue"], (0, 1, 2), True)
    (3, 4, 5)
    """
    if header:
        keys = [re.sub(r"[\"'\s]", "", name).lower() for name in fields]
        found = tuple(next((i for i, key in enumerate(keys) if key in names), None) for names in COLOUR_NAMES)
        return found if None not in found and not set(found) & set(columns) else ()
    if columns != (0, 1, 2) or len(fields) < 6:
        return ()
    values = fields[3:6]
    whole = all(re.fullmatch(r"\d{1,3}", v) and int(v) <= 255 for v in values)
    return (3, 4, 5) if whole else ()


def grey_of(rgb: np.ndarray) -> np.ndarray:
    """Brightness from 0 to 1: the mean of red, green and blue, scaled by the largest a file of
    that depth holds (255 for 8 bits, 65535 for LAS's 16).

    Examples
    --------
    >>> [round(float(v), 3) for v in grey_of(np.array([[255, 255, 255], [0, 0, 30]]))]
    [1.0, 0.039]
    """
    rgb = np.asarray(rgb, dtype=np.float64)
    top = 65535.0 if rgb.size and np.nanmax(rgb) > 255 else 255.0
    return (np.clip(rgb.mean(axis=1), 0, top) / top).astype(np.float32)


def holds_rows_of_numbers(path: Path) -> bool:
    """Whether a text file's first data line after any header holds three numbers, as a
    cloud's rows do: how a folder's point files are told from its notes (a PROVENANCE.txt,
    a README.txt), which share their extension.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (folder / "cloud.txt").write_text("X Y Z\\n1.5 2.0 3.25\\n")
    >>> _ = (folder / "README.txt").write_text("Survey of 3 June, 2 stations.\\nSee the report.\\n")
    >>> holds_rows_of_numbers(folder / "cloud.txt"), holds_rows_of_numbers(folder / "README.txt")
    (True, False)
    """
    try:
        lines = _first_data_lines(path, 2)
    except (GeoStructureError, OSError):
        return False
    if not lines:
        return False
    line = _unquoted(lines[-1][1])
    delimiter, decimal_comma = _sniff_layout(line)
    fields = _split(_decimal_points(line) if decimal_comma else line, delimiter)
    return len(fields) >= 3 and all(_NUMBER.match(f) for f in fields[:3])


#: Header names of the coordinate columns (lower case, without quotes, spaces or a unit in
#: brackets): x, y and z, or a surveyor's easting, northing and elevation.
AXIS_NAMES = (
    ("x", "easting", "east", "e"),
    ("y", "northing", "north", "n"),
    ("z", "elevation", "height", "h", "up", "alt", "altitude"),
)
_GEOGRAPHIC_NAMES = ({"lat", "latitude"}, {"lon", "long", "longitude"})


def _coordinate_columns(names: list[str], path) -> tuple[int, int, int]:
    """The columns a header names as x, y and z (:data:`AXIS_NAMES`; ``id,x,y,z`` gives 1, 2,
    3), else the first three; a header of latitude and longitude is refused: degrees are not
    lengths."""
    keys = [re.sub(r"\(.*?\)|\[.*?\]|[\"'\s/]", "", name).lower() for name in names]
    if all(set(keys) & group for group in _GEOGRAPHIC_NAMES):
        raise InputError(
            f"{path}: its columns are latitude and longitude, in degrees, which are not lengths; project the "
            f"cloud to a metric coordinate system (UTM) and measure that."
        )
    found = [next((i for i, key in enumerate(keys) if key in axis), None) for axis in AXIS_NAMES]
    return tuple(found) if None not in found and len(set(found)) == 3 else (0, 1, 2)


def _unquoted(line: str) -> str:
    return line.replace('"', "")


def _decimal_points(line: str) -> str:
    return line.replace(",", ".")


#: The longest line a text cloud may hold (characters, and bytes): a point's line is under a
#: hundred; a file whose first line runs on for a megabyte is no text cloud (a 2 GB file of
#: NUL bytes, one "line", took 6.2 GB of memory before it was refused; a 60 MB line further
#: on, 1.5 GB).
MAX_LINE = 1 << 20


def _first_data_lines(path: Path, n: int) -> list[tuple[int, str]]:
    """The first ``n`` non-blank, non-comment lines with their 1-based numbers; a file whose
    lines run past :data:`MAX_LINE` or hold NUL bytes is refused, read no further."""
    found = []
    try:
        with open(path, "r", encoding="utf-8-sig") as fh:  # -sig: a byte-order mark is not data
            for number, line in enumerate(iter(lambda: fh.readline(MAX_LINE), ""), start=1):
                if "\0" in line:
                    raise InputError(f"{path}: holds NUL bytes on line {number}: not a text point cloud.")
                if len(line) >= MAX_LINE and not line.endswith("\n"):
                    raise InputError(
                        f"{path}: line {number} runs past {MAX_LINE:,} characters: not a text point cloud."
                    )
                if line.strip() and not line.lstrip().startswith(("#", "//")):
                    found.append((number, line))
                    if len(found) == n:
                        break
    except UnicodeDecodeError:
        raise InputError(f"{path}: is not a text file (not UTF-8).") from None
    return found


def _raise_bad_line(
    path: Path, delimiter: str | None, skip: int, columns=(0, 1, 2), decimal_comma=False, counted=False, quoted=False
) -> None:
    with open(path, "r", encoding="utf-8-sig") as fh:
        for number, line in enumerate(fh, start=1):
            if number <= skip or not line.strip() or line.lstrip().startswith(("#", "//")):
                continue
            if counted and line.strip().isdigit():  # a PTS block's count
                continue
            line = _unquoted(line) if quoted else line
            line = _decimal_points(line) if decimal_comma else line
            fields = _split(line, delimiter)
            if len(fields) <= max(columns):
                raise InputError(
                    f"{path}: line {number} has {len(fields)} field(s); x, y and z are needed"
                    + (f" (columns {', '.join(str(c + 1) for c in columns)})." if max(columns) > 2 else ".")
                )
            bad = next((fields[c] for c in columns if not _NUMBER.match(fields[c])), None)
            if bad is not None:
                raise InputError(f"{path}: line {number}: '{bad}' is not a number.")


def _sniff_layout(line: str) -> tuple[str | None, bool]:
    """A data line's separator (None: any run of whitespace) and whether its decimal mark is
    a comma. A tab or a semicolon is the separator, and a comma beside it a decimal mark;
    commas alone separate, unless the fields they give are not numbers while the
    whitespace's are with commas read as points (``1,5 2,25 3,0``)."""
    for delim in ("\t", ";"):
        if delim in line:
            return delim, "," in line
    if "," not in line:
        return None, False
    by_comma, by_space = _split(line, ","), line.split()
    if len(by_space) >= 3 and not all(_NUMBER.match(f) for f in by_comma[:3]):
        if all(_NUMBER.match(_decimal_points(f)) for f in by_space[:3]):
            return None, True
    return ",", False


def _split(line: str, delimiter: str | None) -> list[str]:
    return [f.strip() for f in line.strip().split(delimiter)] if delimiter else line.split()
