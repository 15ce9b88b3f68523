"""Readers of a result folder's files: ``run.json``, ``planes.csv``, ``regions.ply``,
``sets.csv`` and ``spacing.csv``. They read what is there; a command that must trust the
folder checks its manifest first (:func:`~.outdir.verified_record`)."""

from __future__ import annotations

import csv
from dataclasses import replace
from pathlib import Path

import numpy as np

from geostructure.core.planes import Planes
from geostructure.errors import OutputError
from geostructure.io.crs import recorded_unit
from geostructure.io.outdir import read_record
from geostructure.io.planetable import read_planes_csv

#: The prefix of a PLY property that CloudCompare's command line loads as a scalar field.
SCALAR = "scalar_"


def ply_field(vertex, name: str):
    """A PLY vertex property written by GeoStructure: ``scalar_<name>`` (since 2026-12-02) or
    ``<name>`` (folders written before).

    Examples
    --------
    >>> import numpy as np
    >>> ply_field(np.zeros(2, dtype=[("scalar_region_id", "i4")]), "region_id").tolist()
    [0, 0]
    """
    names = vertex.dtype.names or ()
    return vertex[SCALAR + name] if SCALAR + name in names else vertex[name]


def read_run(folder) -> dict:
    """``run.json`` of a measured folder (or of a staged set) as a dict, with its frame.

    It does not check the manifest: readers of a finished folder call
    :func:`verified_record` first.
    """
    path = Path(folder) / "run.json"
    if not path.is_file():
        raise OutputError(f"{path}: no such file; run 'geostructure measure' first.")
    record = read_record(path)
    try:
        record["frame"]["rotation"]
    except (KeyError, TypeError):
        raise OutputError(f"{path}: not a GeoStructure run record.") from None
    return record


#: ``run.json``'s word that ``planes.csv``'s ``area_m2`` is in square metres whatever the
#: cloud's unit (:func:`in_square_metres`). A folder written before 2026-12-05 lacks it: its
#: ``area_m2`` is in the cloud's unit squared (a survey in feet wrote square feet there).
PLANE_AREA = {"plane_area": "m2"}


def in_square_metres(planes: Planes, metres_per_unit: float) -> Planes:
    """The plane table with its ``area`` turned from the cloud's unit squared into square
    metres, as ``planes.csv``, ``planes.geojson`` and ``planes.gpkg`` hold it under
    ``area_m2``; the table's other sizes stay in the cloud's unit, as its coordinates do.

    Examples
    --------
    >>> feet = Planes(normal=[[0.0, 0.0, 1.0]], area=[100.0])
    >>> round(float(in_square_metres(feet, 0.3048).area[0]), 4)
    9.2903
    """
    return planes if metres_per_unit == 1.0 else replace(planes, area=planes.area * metres_per_unit**2)


def read_planes(folder, offset=None) -> Planes:
    """The plane table in ``planes.csv`` of a measured folder, positions relative to
    ``offset``, its ``area`` back in the cloud's unit squared (as the measure's own table
    holds it) when ``run.json`` says the file holds square metres (:data:`PLANE_AREA`)."""
    planes = read_planes_csv(Path(folder) / "planes.csv", offset)
    record = read_record(Path(folder) / "run.json") or {}
    if record.get("plane_area") != PLANE_AREA["plane_area"]:
        return planes
    return in_square_metres(planes, 1.0 / recorded_unit(record)["metres"])


def open_regions(folder):
    """``regions.ply``'s vertices in a measured folder, memory-mapped (a structured array with
    ``x``, ``y``, ``z`` and ``region_id``), checked to be GeoStructure's."""
    from plyfile import PlyData, PlyParseError

    path = Path(folder) / "regions.ply"
    try:
        vertex = PlyData.read(str(path), mmap=True)["vertex"].data
        names = vertex.dtype.names or ()
        missing = [n for n in ("x", "y", "z", "region_id") if n not in names and SCALAR + n not in names]
        if missing:
            raise KeyError(", ".join(missing))
    except FileNotFoundError:
        raise OutputError(f"{path}: no such file; run 'geostructure measure' first.") from None
    except (PlyParseError, KeyError, ValueError) as exc:
        raise OutputError(f"{path}: not a GeoStructure regions file ({exc}).") from None
    return vertex


def read_regions(folder, offset=None) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """The labelled points of ``regions.ply`` in a measured folder: (N, 3) float64 positions
    relative to ``offset``, each point's ``region_id`` (-1 for none), and which points the
    input classified as vegetation (its ``vegetation`` property,
    :func:`~.writers.write_regions_ply`; None when it has none)."""
    vertex = open_regions(folder)
    xyz = np.column_stack([np.asarray(vertex[a], dtype=np.float64) for a in "xyz"])
    region = np.asarray(ply_field(vertex, "region_id"), dtype=np.int64)
    try:
        vegetation = np.asarray(ply_field(vertex, "vegetation"), dtype=bool)
    except (KeyError, ValueError):
        vegetation = None
    if offset is not None:
        xyz -= np.asarray(offset, dtype=np.float64)
    return xyz, region, vegetation


def read_spacings(folder) -> dict[int, np.ndarray]:
    """Set -> its normal spacings (m) along the scanlines, from ``spacing.csv``; {} when none."""
    path = Path(folder) / "spacing.csv"
    if not path.is_file():
        return {}
    with open(path, newline="", encoding="utf-8") as fh:
        try:
            rows = [(int(r["set"]), r["method"], float(r["spacing_m"])) for r in csv.DictReader(fh)]
        except (ValueError, TypeError, KeyError):
            raise OutputError(f"{path}: not a GeoStructure spacing table.") from None
    out: dict[int, list] = {}
    for s, method, value in rows:
        if method == "scanline":
            out.setdefault(s, []).append(value)
    return {s: np.array(v) for s, v in out.items()}


#: The columns of ``sets.csv`` that hold words, not numbers.
TEXT_SET_COLUMNS = {"spacing_best_fit", "spacing_basis", "persistence", "spacing_class", "flags"}


def read_sets(folder) -> list[dict]:
    """The rows of ``sets.csv`` of a folder, as numbers; [] when it has none."""
    path = Path(folder) / "sets.csv"
    if not path.is_file():
        return []
    with open(path, newline="", encoding="utf-8") as fh:
        try:
            return [
                {k: (v if k in TEXT_SET_COLUMNS else float(v)) for k, v in row.items()} for row in csv.DictReader(fh)
            ]
        except (ValueError, TypeError):
            raise OutputError(f"{path}: not a GeoStructure sets table (a cell is not a number).") from None
