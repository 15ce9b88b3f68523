"""A field map: fractures mapped by hand or compass stations, each a located plane.

Columns (header required, any order, case-insensitive), one row per mapped plane::

    x, y, z, dip, dip_direction[, set]

or the columns of a disc fitted to a mapped trace (as DICE and qFacets write them)::

    Dip, DipDirection, Xcenter, Ycenter, Zcenter[, Radius, Nx, Ny, Nz, ...]

Locations are in the cloud's own coordinates (the same CRS); dip and dip direction in
degrees from the north the run read its azimuths from (true north with a CRS, unless
``--grid-north``), as a compass reads them. Where the map gives each plane's unit normal
(DICE's ``Nx, Ny, Nz``, in the cloud's own axes) the planes are compared by it, in those
axes, and no north comes between them. A ``set`` column (any label; blank for
none) gives each plane's mapped set. Comma or semicolon separated, as :mod:`.usercsv` reads.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from geostructure.core.cloud import MAX_COORDINATE
from geostructure.errors import InputError
from geostructure.io.usercsv import read_user_rows

#: Each field's accepted column names (lower case).
NAMES = {
    "x": ("x", "xcenter", "center_x", "centre_x", "easting", "east"),
    "y": ("y", "ycenter", "center_y", "centre_y", "northing", "north"),
    "z": ("z", "zcenter", "center_z", "centre_z", "elevation", "height"),
    "dip": ("dip",),
    "dip_direction": ("dip_direction", "dipdirection", "dipdir", "dip_dir", "dip direction"),
    "set": ("set", "joint_set", "family"),
}
#: Optional numeric columns: a disc's radius (its trace's half chord) and unit normal, as DICE
#: writes them (the normal in the cloud's own axes, so no north is read into it).
OPTIONAL = {"radius": ("radius",), "nx": ("nx",), "ny": ("ny",), "nz": ("nz",)}
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
    radius: np.ndarray | None = None
    normals: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.dip)

    def with_sets(self, labels: list[str]) -> FieldMap:
        """The same map with each plane's set from ``labels`` (one per plane, in order)."""
        from dataclasses import replace

        return replace(self, sets=list(labels))


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
    rows = _table(path, "field map")
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
    bad |= np.any(np.abs(numbers[:, :3]) > MAX_COORDINATE, axis=1)  # 1e308 stopped the matching with a traceback
    if bad.any():
        r = int(np.flatnonzero(bad)[0])
        raise InputError(
            f"{path}: row {r + 2} is no plane (dip {rows[r + 1][column['dip']].strip()}, dip direction "
            f"{rows[r + 1][column['dip_direction']].strip()}: a finite location, a dip of 0 to 90 and a dip "
            f"direction of 0 to 360 degrees are needed)."
        )
    s = column.get("set")
    labels = [(row[s].strip() if s is not None and s < len(row) else "") for row in rows[1:]]
    extra = _optional_columns(path, header, rows)
    radius = extra.get("radius")
    if radius is not None and not (np.isfinite(radius).all() and (radius > 0).all()):
        r = int(np.flatnonzero(~(np.isfinite(radius) & (radius > 0)))[0])
        raise InputError(f"{path}: row {r + 2}'s radius is no length (a positive number is needed).")
    normals = None
    if all(axis in extra for axis in ("nx", "ny", "nz")):
        normals = np.column_stack([extra["nx"], extra["ny"], extra["nz"]])
        size = np.linalg.norm(normals, axis=1)
        if not (np.isfinite(size).all() and (np.abs(size - 1.0) < 0.01).all()):
            r = int(np.flatnonzero(~(np.isfinite(size) & (np.abs(size - 1.0) < 0.01)))[0])
            raise InputError(f"{path}: row {r + 2}'s Nx, Ny, Nz is not a unit normal.")
    return FieldMap(numbers[:, :3], numbers[:, 3], numbers[:, 4] % 360.0, labels, radius, normals)


def _table(path: Path, what: str) -> list[list[str]]:
    """A user's CSV's non-empty rows, or one sentence naming the file and ``what`` it should be."""
    return [row for row in read_user_rows(path, what) if any(cell.strip() for cell in row)]


def _optional_columns(path, header: list[str], rows: list) -> dict[str, np.ndarray]:
    """The :data:`OPTIONAL` columns the header has, as numbers (a bad cell refused)."""
    out = {}
    for field, names in OPTIONAL.items():
        found = [i for i, name in enumerate(header) if name in names]
        if not found:
            continue
        values = np.empty(len(rows) - 1)
        for r, row in enumerate(rows[1:]):
            cell = row[found[0]].strip() if found[0] < len(row) else ""
            try:
                values[r] = float(cell)
            except ValueError:
                raise InputError(f"{path}: row {r + 2} has no number for {field} ({cell!r}).") from None
        out[field] = values
    return out


def read_set_labels(path, n: int) -> list[str]:
    """Each mapped plane's set from a separate file, row for row (its ``set`` column, as
    DICE's ``set_labels.csv`` gives it; blank for none); ``n`` rows are needed.

    Examples
    --------
    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "sets.csv")
    >>> _ = open(path, "w").write("Dip,DipDirection,Set\\n70,260,1\\n80,7,\\n")
    >>> read_set_labels(path, 2)
    ['1', '']
    """
    path = Path(path)
    rows = _table(path, "table of set labels")
    header = [cell.strip().lower() for cell in rows[0]] if rows else []
    found = [i for i, name in enumerate(header) if name in NAMES["set"]]
    if not found:
        raise InputError(f"{path}: has no set column.")
    if len(rows) - 1 != n:
        raise InputError(f"{path}: {len(rows) - 1} rows of set labels for a field map of {n}.")
    labels = [row[found[0]].strip() if found[0] < len(row) else "" for row in rows[1:]]
    # DICE writes 1.0 for set 1: one label, not two
    return [label[:-2] if label.endswith(".0") and label[:-2].isdigit() else label for label in labels]
