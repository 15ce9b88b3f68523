"""A survey too large for memory, thinned to one that fits: one point per cell of a grid,
the first the files give in it.

The facet detector, the joint sets and the rock mass need each point's neighbours and the
face's exposure, so they run in memory. Their joints are some decimetres across: a
point every centimetre or two says no more of them than one every few. A survey that does
not fit is therefore read chunk by chunk (:func:`~.source.spill_inputs`) and thinned on a
grid whose edge makes it fit (:func:`thin_spill`); the thinned cloud is measured in memory,
and a last pass gives every point of the survey its cell's label (:func:`label_survey`).

The point kept in a cell is the first of the survey's points in it, in the files' order,
whatever the chunks: it is an input point, on its own float64 coordinates, and the same
cell of a later pass finds it again.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from geostructure.detect.voxel import MAX_CELLS_PER_AXIS, voxel_keys
from geostructure.errors import GeoStructureError, InputError
from geostructure.io.laz import point_joints, point_sets
from geostructure.io.results import open_regions, ply_field, read_regions
from geostructure.stream.executor import SerialExecutor
from geostructure.stream.passes import VoxelTable
from geostructure.stream.source import Chunk, Spill

#: Points the grid's edge is first judged on, spread evenly through the spill.
EDGE_SAMPLE = 1_000_000
#: The sample's points per occupied cell at the finest edge whose cells it takes as all the
#: survey's: a cell so full in the sample is surely occupied in the survey.
FULL_CELL = 16
#: A thinning that keeps this share of the target or more is taken; a new try aims at
#: ``ENOUGH_AIM`` of it.
ENOUGH, ENOUGH_AIM = 0.6, 0.85
#: Thinning passes at most: each misses by the face's roughness, which adds cells that a
#: flat face's count (the area over the edge squared) does not foresee.
MAX_THINNING_PASSES = 4


@dataclass(frozen=True)
class ThinGrid:
    """A grid of cubes of side ``edge`` from ``lower`` (absolute coordinates), its cells
    numbered ``(i * ny + j) * nz + k``."""

    lower: np.ndarray
    edge: float
    shape: tuple[int, int, int]

    @classmethod
    def from_record(cls, record: dict | None) -> ThinGrid | None:
        """The grid a thinned run recorded in ``run.json`` (``thinned``); None for a run
        that thinned nothing."""
        if not record or record.get("cell") is None or "grid_lower" not in record:
            return None
        return cls(np.asarray(record["grid_lower"], dtype=np.float64), float(record["cell"]),
                   tuple(int(n) for n in record["grid_shape"]))  # fmt: skip

    def to_record(self) -> dict:
        return {"cell": self.edge, "grid_lower": self.lower.tolist(), "grid_shape": list(self.shape)}

    @classmethod
    def over(cls, lower, upper, edge: float) -> ThinGrid:
        lower = np.asarray(lower, dtype=np.float64)
        shape = tuple(int(n) for n in np.floor((np.asarray(upper) - lower) / edge).astype(np.int64) + 1)
        if max(shape) > MAX_CELLS_PER_AXIS or float(shape[0]) * shape[1] * shape[2] >= 2.0**62:
            raise GeoStructureError(f"a grid of {edge:g} over the survey has too many cells to number")
        return cls(lower, float(edge), shape)

    def table(self, points: np.ndarray) -> VoxelTable:
        """The cells of ``points`` (one a cell), each found again from any point in it as
        its row in ``points`` (:meth:`~.passes.VoxelTable.find`; -1 for a cell none holds)."""
        return VoxelTable.of(voxel_keys(points, self.edge, self.lower), self.edge, self.lower)

    def codes(self, points: np.ndarray) -> np.ndarray:
        """Each point's cell number (int64)."""
        index = np.floor((points - self.lower) / self.edge).astype(np.int64)
        np.clip(index, 0, np.array(self.shape) - 1, out=index)  # the upper bound's own cell
        _, ny, nz = self.shape
        return (index[:, 0] * ny + index[:, 1]) * nz + index[:, 2]


@dataclass
class Thinned:
    """A thinned survey: each kept point's absolute coordinates (in the files' order), its
    row in the spill and how many of the survey's points its cell on ``grid`` holds."""

    grid: ThinGrid | None  # None: every point kept, none thinned
    points: np.ndarray
    rows: np.ndarray
    counts: np.ndarray

    def __len__(self) -> int:
        return len(self.rows)

    def finder(self) -> VoxelTable | None:
        """Which kept point stands for each point's cell: what the label pass sends to workers."""
        return None if self.grid is None else self.grid.table(self.points)


def chunk_cells(chunk: Chunk, grid: ThinGrid):
    """A chunk's cells, each with its first point: (codes, spill rows, counts, points)."""
    points = chunk.points()
    codes, first, counts = np.unique(grid.codes(points), return_index=True, return_counts=True)
    return codes, first + chunk.start, counts, points[first]


def _first_of_each(codes, rows, counts, *payload):
    """The first row (in the files' order) of each cell among gathered parts, the cell's
    points counted over all of them, and the first row's ``payload``."""
    order = np.lexsort((rows, codes))
    codes, rows = codes[order], rows[order]
    first = np.ones(len(codes), dtype=bool)
    first[1:] = codes[1:] != codes[:-1]
    counts = np.add.reduceat(counts[order], np.flatnonzero(first)) if len(codes) else counts
    return (codes[first], rows[first], counts, *(p[order][first] for p in payload))


def fold_first(parts, report=None):
    """Each cell's first row over ``parts`` ((codes, rows, counts, *payload) each, as
    :func:`chunk_cells` gives), folded as they come so that memory stays bounded, in the
    files' order; ``report()`` after each part."""
    gathered, held, limit = [], 0, None
    for part in parts:
        gathered.append(part)
        held += len(part[0])
        if report is not None:
            report()
        if limit is None:
            limit = max(4 * held, 1_000_000)
        if held > limit:  # cells seen in several chunks: fold them
            gathered = [_first_of_each(*(np.concatenate(c) for c in zip(*gathered)))]
            held, limit = len(gathered[0][0]), 2 * len(gathered[0][0]) + 1_000_000
    whole = _first_of_each(*(np.concatenate(c) for c in zip(*gathered)))
    order = np.argsort(whole[1])  # the files' order
    return tuple(c[order] for c in whole)


def thin_with(spill: Spill, grid: ThinGrid, chunks, executor, report=None) -> Thinned:
    """One pass over ``chunks`` keeping each cell's first point; ``report()`` after each chunk."""
    _, rows, counts, points = fold_first(executor.map(chunk_cells, chunks, grid), report)
    return Thinned(grid, points, rows, counts)


def first_edge(spill: Spill, target: int, sample: int = EDGE_SAMPLE) -> float:
    """The edge at which ``spill`` would keep about ``target`` cells were it a surface: its
    area read on an even sample at the finest edge whose cells are all full."""
    n = spill.n_points
    rows = np.unique(np.linspace(0, n - 1, min(n, sample)).astype(np.int64))
    points = np.memmap(spill.points_path, dtype="<f8", mode="r", shape=(n, 3))[rows]
    extent = float(np.max(spill.upper - spill.lower))
    area = None
    for level in range(2, 21):
        edge = extent / 2**level
        try:
            grid = ThinGrid.over(spill.lower, spill.upper, edge)
        except GeoStructureError:
            break
        cells = len(np.unique(grid.codes(points)))
        if len(points) / cells < FULL_CELL:
            break
        area = cells * edge**2
    if area is None:
        return extent / 4
    return float(np.sqrt(area / target))


def thin_spill(spill: Spill, target: int, chunk_points: int, executor=None, progress=None) -> Thinned:
    """``spill`` thinned to at most ``target`` points (and :data:`ENOUGH` of it where the
    tries reach it), one per cell of a grid (a pass over the spill a try,
    :data:`MAX_THINNING_PASSES` at most).

    ``progress("thin", done, total)`` over the passes' chunks."""
    if not np.max(spill.upper - spill.lower) > 0:
        raise InputError(f"{spill.source}: all points lie at one spot; there is no plane to measure.")
    executor = executor or SerialExecutor()
    report = progress or (lambda stage, done, total: None)
    chunks = spill.chunks(chunk_points)
    if spill.n_points <= target:  # it fits: every point, read back in one piece
        rows = np.arange(spill.n_points)
        points = np.fromfile(spill.points_path, dtype="<f8").reshape(-1, 3)
        return Thinned(None, points, rows, np.ones(spill.n_points, dtype=np.int64))
    edge = first_edge(spill, target)
    done = [0]
    total = len(chunks)

    def step():
        done[0] += 1
        report("thin", done[0], total)

    best = None
    for _ in range(MAX_THINNING_PASSES):
        grid = ThinGrid.over(spill.lower, spill.upper, edge)
        thinned = thin_with(spill, grid, chunks, executor, step)
        if len(thinned) <= target and (best is None or len(thinned) > len(best)):
            best = thinned
        if best is not None and len(best) >= ENOUGH * target:
            break
        # The count goes about as the edge's square on a face: aim a little under the target.
        edge *= np.sqrt(len(thinned) / (ENOUGH_AIM * target))
        total += len(chunks)
    if best is not None:
        return best
    raise GeoStructureError(
        f"{spill.source}: could not thin the survey to {target:,} points in {MAX_THINNING_PASSES} passes; "
        f"give more --max-memory."
    )


def label_survey(spill: Spill, thinned: Thinned, chunk_points: int, executor=None, progress=None):
    """Yield, chunk by chunk in the files' order, each chunk, its points (absolute) and the
    index in ``thinned`` of the kept point that stands for each (:meth:`Thinned.finder`)."""
    executor = executor or SerialExecutor()
    report = progress or (lambda stage, done, total: None)
    chunks = spill.chunks(chunk_points)
    for i, (points, found) in enumerate(executor.map(_chunk_found, chunks, thinned.finder())):
        report("label", i + 1, len(chunks))
        yield chunks[i], points, found


def _chunk_found(chunk: Chunk, finder: VoxelTable | None):
    points = chunk.points()
    if finder is None:  # nothing thinned: each point stands for itself
        return points, np.arange(chunk.start, chunk.stop)
    return points, finder.find(points)


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
    """The points a folder's planes were measured on, as :func:`~..io.results.read_regions`
    reads them (positions less ``offset``, regions, vegetation marks or None), and a
    :class:`~.passes.VoxelTable` of their cells (None but for a thinned run's folder).

    A thinned run's ``regions.ply`` holds every point of its survey; the points it measured
    are each cell's first (:mod:`.thin`), read here again chunk by chunk on the grid
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
