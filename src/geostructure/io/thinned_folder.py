"""A results folder's measured points read back: every point of ``regions.ply`` for a run
in memory or streamed; for a thinned survey's (whose ``regions.ply`` holds every point of the
survey), each cell's first point on the grid ``run.json`` recorded
(:class:`~geostructure.core.thingrid.ThinGrid`), chunk by chunk; and each point's set, joint
and face part for ``regions.laz``.
"""

from __future__ import annotations

import numpy as np

from geostructure.core.thingrid import ThinGrid, fold_first
from geostructure.core.voxeltable import VoxelTable
from geostructure.io.laz import point_joints, point_sets
from geostructure.io.results import open_regions, ply_field, read_regions

#: Points of ``regions.ply`` read at a time from a thinned run's folder.
FOLDER_ROWS = 2_000_000


def _ply_cells(vertex, start: int, stop: int, grid: ThinGrid):
    """Rows ``start`` to ``stop`` of ``regions.ply``: their cells, each with its first point's
    row, coordinates, region and vegetation mark (as :func:`chunk_cells`)."""
    part = vertex[start:stop]
    xyz = np.column_stack([np.asarray(part[a], dtype=np.float64) for a in "xyz"])
    codes, first, counts = np.unique(grid.codes(xyz), return_index=True, return_counts=True)
    region = np.asarray(ply_field(part, "region_id"), dtype=np.int64)[first]
    try:
        vegetation = np.asarray(ply_field(part, "vegetation"), dtype=np.int8)[first]
    except (KeyError, ValueError):
        vegetation = np.full(len(first), -1, dtype=np.int8)
    return codes, first + start, counts, xyz[first], region, vegetation


def read_measured(folder, record: dict, offset=None):
    """The points a folder's planes were measured on, as :func:`~geostructure.io.results.read_regions`
    reads them (positions less ``offset``, regions, vegetation marks or None), and a
    :class:`~geostructure.core.voxeltable.VoxelTable` of their cells (None but for a thinned run's folder).

    A thinned run's ``regions.ply`` holds every point of its survey; the points it measured
    are each cell's first (:mod:`geostructure.stream.thin`), read here again chunk by chunk on the grid
    ``run.json`` recorded."""
    grid = ThinGrid.from_record(record.get("thinned"))
    if grid is None:
        return (*read_regions(folder, offset), None)
    vertex = open_regions(folder)
    parts = (_ply_cells(vertex, a, min(a + FOLDER_ROWS, len(vertex)), grid) for a in range(0, len(vertex), FOLDER_ROWS))
    _, _, _, xyz, region, vegetation = fold_first(parts)
    cells = grid.table(xyz)
    if offset is not None:
        xyz -= np.asarray(offset, dtype=np.float64)
    marks = None if (vegetation < 0).any() else vegetation.astype(bool)
    return xyz, region, marks, cells


def cell_point_sets(folder, finder: VoxelTable, planes, face_part=None):
    """Per :data:`FOLDER_ROWS` rows of a thinned run's ``regions.ply``: each point's set and
    joint (by its region) and face part (its cell's measured point's), for ``regions.laz``
    (:data:`~geostructure.io.laz.POINT_SET_DIMENSIONS`, by name)."""
    vertex = open_regions(folder)
    for a in range(0, len(vertex), FOLDER_ROWS):
        part = vertex[a : a + FOLDER_ROWS]
        region = np.asarray(ply_field(part, "region_id"), dtype=np.int64)
        if face_part is None:
            parts = np.zeros(len(part), dtype=np.uint8)
        else:
            xyz = np.column_stack([np.asarray(part[c], dtype=np.float64) for c in "xyz"])
            parts = np.asarray(face_part, dtype=np.uint8)[finder.find(xyz)]
        yield {"set": point_sets(region, planes), "face_part": parts, "joint": point_joints(region, planes)}


def point_set_values(folder, planes, face_part=None, cells: VoxelTable | None = None):
    """Per :data:`FOLDER_ROWS` rows of a folder's ``regions.ply``: each point's set, joint and
    face part, in the file's order. A thinned run's (``cells`` its measured points' table)
    through :func:`cell_point_sets`; otherwise the file's rows are the points measured, and
    ``face_part`` (one per row) is read along."""
    if cells is not None:
        yield from cell_point_sets(folder, cells, planes, face_part)
        return
    vertex = open_regions(folder)
    for a in range(0, len(vertex), FOLDER_ROWS):
        region = np.asarray(ply_field(vertex[a : a + FOLDER_ROWS], "region_id"), dtype=np.int64)
        parts = np.zeros(len(region), np.uint8) if face_part is None else np.asarray(face_part[a : a + len(region)])
        yield {
            "set": point_sets(region, planes),
            "face_part": parts.astype(np.uint8),
            "joint": point_joints(region, planes),
        }
