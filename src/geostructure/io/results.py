"""Readers of a result folder's files: ``run.json``, ``planes.csv``, ``regions.ply``,
``sets.csv`` and ``spacing.csv``. They read what is there; a command that must trust the
folder checks its manifest first (:func:`~.outdir.verified_record`)."""

from __future__ import annotations

import csv
from dataclasses import replace
from pathlib import Path

import numpy as np

from geostructure.core.planes import Planes
from geostructure.errors import InputError, OutputError
from geostructure.io.crs import recorded_unit
from geostructure.io.outdir import read_record
from geostructure.io.planetable import read_planes_csv
from geostructure.io.ply import ply_point_count

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


#: A plane holds three points at least, and a ``planes.csv`` row takes at most this many
#: bytes (its 40-odd numbers and the sets' columns, some 1,000 at the most): so a folder's
#: points bound its plane table, read from ``regions.ply``'s header before the table is.
MIN_PLANE_POINTS = 3
MAX_PLANE_ROW_BYTES = 4096


def most_planes(folder) -> tuple[int, int] | None:
    """The most planes a folder's points can make, and its points (``regions.ply``'s
    header); None without the file."""
    regions = Path(folder) / "regions.ply"
    if not regions.is_file():
        return None
    points = ply_point_count(regions, None)
    return max(points // MIN_PLANE_POINTS, 1), points


def _check_plane_count(path: Path, n_rows: int | None, bound: tuple[int, int] | None) -> None:
    """Refuse a ``planes.csv`` larger (in bytes, or once read in rows) than its folder's
    points can make: a table edited by hand, which ``sets``, ``kinematics`` and ``report``
    took minutes over."""
    if bound is None:
        return
    limit, points = bound
    too_big = path.stat().st_size > (limit + 1) * MAX_PLANE_ROW_BYTES if n_rows is None else n_rows > limit
    if too_big:
        raise InputError(
            f"{path}: holds more planes than the {points:,} points of its folder's regions.ply can make "
            f"({limit:,} at the most, {MIN_PLANE_POINTS} points a plane); the table was edited: measure again."
        )


def read_planes(folder, offset=None) -> Planes:
    """The plane table in ``planes.csv`` of a measured folder, positions relative to
    ``offset``, its ``area`` back in the cloud's unit squared (as the measure's own table
    holds it) when ``run.json`` says the file holds square metres (:data:`PLANE_AREA`). A
    table longer than the folder's points can make is refused before it is read."""
    path, bound = Path(folder) / "planes.csv", most_planes(folder)
    if path.is_file():
        _check_plane_count(path, None, bound)
    planes = read_planes_csv(path, offset)
    _check_plane_count(path, len(planes), bound)
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


def read_grey(folder) -> np.ndarray | None:
    """Each point's brightness in a measured folder's ``regions.ply`` (its ``grey`` property,
    :func:`~.writers.write_regions_ply`), in the file's order; None when it has none."""
    vertex = open_regions(folder)
    try:
        return np.asarray(ply_field(vertex, "grey"), dtype=np.float32)
    except (KeyError, ValueError):
        return None


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


def read_traces(folder) -> tuple[list[np.ndarray], np.ndarray] | None:
    """A measured folder's traces (``traces.csv`` and ``trace_vertices.csv``): each trace's
    polyline in the cloud's coordinates, in order, and its set (-1 for none); None when the
    folder has none (measured without ``--sets``, or before traces)."""
    folder = Path(folder)
    table, vertices = folder / "traces.csv", folder / "trace_vertices.csv"
    if not (table.is_file() and vertices.is_file()):
        return None
    try:
        with open(table, newline="", encoding="utf-8") as fh:
            rows = list(csv.DictReader(fh))
        sets = np.array([int(r["set"]) if r["set"].strip() else -1 for r in rows], dtype=np.int64)
        ids = [int(r["trace_id"]) for r in rows]
        with open(vertices, newline="", encoding="utf-8") as fh:
            reader = csv.DictReader(fh)
            at = [(int(r["trace_id"]), float(r["x"]), float(r["y"]), float(r["z"])) for r in reader]
    except (KeyError, ValueError, TypeError) as exc:
        raise OutputError(f"{folder}: traces.csv or trace_vertices.csv is not GeoStructure's ({exc}).") from None
    if ids != list(range(len(ids))):
        raise OutputError(f"{table}: its trace_id column is not 0, 1, 2, ... in order.")
    xyz = np.array([v[1:] for v in at], dtype=np.float64).reshape(-1, 3)
    owner = np.array([v[0] for v in at], dtype=np.int64)
    if len(owner) and (np.any(np.diff(owner) < 0) or owner.max() >= len(ids) or owner.min() < 0):
        raise OutputError(f"{vertices}: its vertices are not grouped by trace, in the order of traces.csv.")
    cuts = np.searchsorted(owner, np.arange(len(ids) + 1))
    lines = [xyz[a:b] for a, b in zip(cuts[:-1], cuts[1:])]
    if any(len(line) < 2 for line in lines) or not np.isfinite(xyz).all():
        raise OutputError(f"{vertices}: a trace has fewer than two vertices, or a vertex is not a finite point.")
    return lines, sets
