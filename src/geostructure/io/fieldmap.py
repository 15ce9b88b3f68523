"""A field map: fractures mapped by hand or compass stations, each a located plane.

Columns (header required, any order, case-insensitive), one row per mapped plane::

    x, y, z, dip, dip_direction[, set]

or the columns of a disc fitted to a mapped trace (as DICE and qFacets write them)::

    Dip, DipDirection, Xcenter, Ycenter, Zcenter[, Radius, Nx, Ny, Nz, ...]

Locations are in the cloud's own coordinates (the same CRS); dip and dip direction in
degrees from true north, as a compass reads them. A ``set`` column (any label; blank for
none) gives each plane's mapped set. Comma or semicolon separated, as :mod:`.usercsv` reads.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from geostructure.errors import InputError
from geostructure.io.usercsv import read_rows

#: Each field's accepted column names (lower case).
NAMES = {
    "x": ("x", "xcenter", "center_x", "centre_x", "easting", "east"),
    "y": ("y", "ycenter", "center_y", "centre_y", "northing", "north"),
    "z": ("z", "zcenter", "center_z", "centre_z", "elevation", "height"),
    "dip": ("dip",),
    "dip_direction": ("dip_direction", "dipdirection", "dipdir", "dip_dir", "dip direction"),
    "set": ("set", "joint_set", "family"),
}
#: The most rows read: a field map is hand-made (hundreds to thousands of planes); a larger
#: file is not one, and scoring it would take minutes.
MAX_ROWS = 200_000


@dataclass(frozen=True)
class FieldMap:
    """Mapped planes: ``centres`` (M, 3) in the cloud's coordinates, ``dip`` and
    ``dip_direction`` (M,) in degrees, and each one's mapped ``set`` label ("" for none)."""

    centres: np.ndarray
    dip: np.ndarray
    dip_direction: np.ndarray
    sets: list[str]

    def __len__(self) -> int:
        return len(self.dip)


def read_field_map(path, *, located: bool = True) -> FieldMap:
    """Read a field map (see the module's description); a file that is not one is refused
    in one sentence naming it and, for a bad cell, its row. With ``located`` False (a list
    of set means: dip, dip direction and set) the x, y, z columns are not needed, and the
    centres are NaN where they are missing.

    Parameters
    ----------
    path : str or Path
        The field map CSV.
    located : bool
        Whether each row must give its plane's position (x, y, z).

    Returns
    -------
    FieldMap
        Per mapped plane its centre, normal, dip, dip direction and set (-1 for none).

    Examples
    --------
    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "map.csv")
    >>> _ = open(path, "w").write("x,y,z,dip,dip_direction,set\\n1,2,3,70,260,A\\n4,5,6,80,7,\\n")
    >>> fm = read_field_map(path)
    >>> fm.dip.tolist(), fm.sets
    ([70.0, 80.0], ['A', ''])
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such field map file.")
    try:
        with open(path, newline="", encoding="utf-8-sig") as fh:
            rows = [row for row in read_rows(fh) if any(cell.strip() for cell in row)]
    except (UnicodeDecodeError, ValueError):
        raise InputError(f"{path}: not a field map (not a UTF-8 text table).") from None
    if len(rows) < 2:
        raise InputError(f"{path}: the field map has no rows under its header.")
    if len(rows) - 1 > MAX_ROWS:
        raise InputError(f"{path}: {len(rows) - 1:,} rows is more than a field map holds (at most {MAX_ROWS:,}).")
    header = [cell.strip().lower() for cell in rows[0]]
    column = {}
    for field, names in NAMES.items():
        found = [i for i, name in enumerate(header) if name in names]
        if found:
            column[field] = found[0]
        elif field != "set" and (located or field in ("dip", "dip_direction")):
            raise InputError(
                f"{path}: the field map needs x, y, z, dip and dip_direction columns "
                f"(or Xcenter, Ycenter, Zcenter, Dip, DipDirection); it has no {field} column."
            )
    numbers = np.empty((len(rows) - 1, 5))
    for r, row in enumerate(rows[1:]):
        for f, field in enumerate(("x", "y", "z", "dip", "dip_direction")):
            if field not in column:  # a list of set means: no location
                numbers[r, f] = np.nan
                continue
            cell = row[column[field]].strip() if column[field] < len(row) else ""
            try:
                numbers[r, f] = float(cell)
            except ValueError:
                raise InputError(f"{path}: row {r + 2} has no number for {field} ({cell!r}).") from None
    bad = ~np.isfinite(numbers[:, 3:]).all(axis=1) | (~np.isfinite(numbers[:, :3]).all(axis=1) if located else False)
    bad |= (numbers[:, 3] < 0) | (numbers[:, 3] > 90) | (numbers[:, 4] < 0) | (numbers[:, 4] > 360)
    if bad.any():
        r = int(np.flatnonzero(bad)[0])
        raise InputError(
            f"{path}: row {r + 2} is no plane (dip {rows[r + 1][column['dip']].strip()}, dip direction "
            f"{rows[r + 1][column['dip_direction']].strip()}: a finite location, a dip of 0 to 90 and a dip "
            f"direction of 0 to 360 degrees are needed)."
        )
    s = column.get("set")
    labels = [(row[s].strip() if s is not None and s < len(row) else "") for row in rows[1:]]
    return FieldMap(numbers[:, :3], numbers[:, 3], numbers[:, 4] % 360.0, labels)
