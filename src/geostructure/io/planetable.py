"""``planes.csv``: the plane table (:class:`~geostructure.core.planes.Planes`) written and
read back, every float to its last bit, every text cell safe from a spreadsheet."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from geostructure.core.cloud import MAX_COORDINATE
from geostructure.core.planes import COLUMNS, LATER_COLUMNS, Planes
from geostructure.errors import InputError
from geostructure.io.atomic import write_table_csv


def write_planes_csv(planes: Planes, path) -> Path:
    """Write ``planes.csv`` (atomically), floats to the last bit.

    Parameters
    ----------
    planes : Planes
        The plane table.
    path : str or Path
        Where ``planes.csv`` goes; written whole or not at all.

    Returns
    -------
    Path
        ``path``.

    Examples
    --------
    >>> import tempfile, os
    >>> path = os.path.join(tempfile.mkdtemp(), "planes.csv")
    >>> planes = Planes(normal=[[0.0, 0.6, 0.8]], local_centroid=[[662000.125, 5103000.5, 400.0]])
    >>> read_planes_csv(write_planes_csv(planes, path)).centroid.tolist()
    [[662000.125, 5103000.5, 400.0]]
    """
    return write_table_csv(planes.rows(), path, columns=COLUMNS + tuple(planes.extra))


def read_planes_csv(path, offset=None) -> Planes:
    """Read a ``planes.csv`` that :func:`write_planes_csv` wrote, positions taken relative to
    ``offset`` (the run's, from ``run.json``); columns after the standard ones come back
    in ``extra``. A file that is not one, or whose centroids or normals are not finite unit
    vectors (a table edited by hand), is refused naming it.

    Parameters
    ----------
    path : str or Path
        A ``planes.csv``.
    offset : (3,) array, optional
        What the table's positions are held relative to (``run.json``'s offset).

    Returns
    -------
    Planes
        The table, its extra columns (``set``, ``joint``, traces) in ``extra``.

    Raises
    ------
    InputError
        No such file, or not a GeoStructure plane table.

    Examples
    --------
    >>> import tempfile, os
    >>> path = os.path.join(tempfile.mkdtemp(), "planes.csv")
    >>> table = Planes(normal=[[0.0, 0.0, 1.0]], local_centroid=[[1.0, 2.0, 3.0]]).with_columns(set=[0])
    >>> back = read_planes_csv(write_planes_csv(table, path), offset=[1.0, 2.0, 3.0])
    >>> back.centroid.tolist(), back.extra["set"].tolist()
    ([[1.0, 2.0, 3.0]], [0])

    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such file; run 'geostructure measure' first.")
    try:
        with open(path, newline="", encoding="utf-8") as fh:
            reader = csv.reader(fh)
            header = next(reader, [])
            cells = [row for row in reader if row]
    except (UnicodeDecodeError, csv.Error):
        raise InputError(f"{path}: not a GeoStructure planes.csv (not a text table).") from None
    if any(name not in header for name in COLUMNS if name not in LATER_COLUMNS) or len(set(header)) != len(header):
        raise InputError(f"{path}: not a GeoStructure planes.csv (its header lacks the plane columns).")
    try:
        if any(len(row) != len(header) for row in cells):
            raise ValueError
        table = np.array(cells, dtype=np.float64).reshape(len(cells), len(header))
    except ValueError:
        raise InputError(
            f"{path}: not a GeoStructure planes.csv (a row is short, or a cell is not a number)."
        ) from None
    column = {name: table[:, i] for i, name in enumerate(header)}
    normal = np.c_[column["normal_x"], column["normal_y"], column["normal_z"]]
    centroid = np.c_[column["centroid_x"], column["centroid_y"], column["centroid_z"]]
    with np.errstate(all="ignore"):
        unit = np.abs(np.linalg.norm(normal, axis=1) - 1.0) < 1e-3
    if not (np.isfinite(centroid).all() and unit.all()):
        raise InputError(
            f"{path}: not a GeoStructure planes.csv (a centroid is not finite, or a normal is not a unit vector)."
        )
    for name, low, high in VALUE_RANGES:
        values = column.get(name)
        if values is None:
            continue
        with np.errstate(invalid="ignore"):
            bad = ~((values >= low) & (values <= high)) & ~(np.isnan(values) & (name in BLANK_ALLOWED))
        if bad.any():
            row = int(np.flatnonzero(bad)[0])
            raise InputError(
                f"{path}: row {row + 2}'s {name} {values[row]:g} lies outside {low:g} to {high:g}, so the table "
                f"was edited or damaged; run 'geostructure measure' again."
            )
    return Planes.from_columns(column, header, offset)


#: What each column of a plane table can hold (a dip of 200, edited in and resealed, went
#: through sets, kinematics and the report, and stayed in the new planes.csv).
VALUE_RANGES = (
    ("dip", 0.0, 90.0),
    ("strike", 0.0, 360.0),
    ("dip_direction", 0.0, 360.0),
    ("n_points", 0.0, 1e15),
    ("area_m2", 0.0, 1e24),  # a square of the largest coordinate a cloud may hold
    ("centroid_x", -MAX_COORDINATE, MAX_COORDINATE),
    ("centroid_y", -MAX_COORDINATE, MAX_COORDINATE),
    ("centroid_z", -MAX_COORDINATE, MAX_COORDINATE),
)
#: Columns that may be blank: a level plane's azimuths, a size not measured.
BLANK_ALLOWED = frozenset({"strike", "dip_direction", "n_points", "area_m2"})
