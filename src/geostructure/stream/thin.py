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

from geostructure.core.thingrid import ThinGrid, fold_first
from geostructure.core.voxeltable import VoxelTable
from geostructure.errors import GeoStructureError, InputError
from geostructure.stream.executor import SerialExecutor
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
