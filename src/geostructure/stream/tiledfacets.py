"""The facet detector over a spilled survey, tile by tile (docs/tiles.md, step 4): every
point at full resolution, no array of the whole survey's points held.

The passes, each over the spill's chunks or over the tiles:

1. **The cloud's numbers**: the kept points' count and bounds, then the point spacing and
   the grid's edge, read on the same hash-drawn blocks as in memory
   (:func:`~geostructure.core.density.spacing_blocks`,
   :func:`~geostructure.detect.facets.edge_blocks`), gathered chunk by chunk; a survey of
   up to :data:`~geostructure.core.density.SPACING_TREE_POINTS` points is small enough to
   read whole for them, as in memory.
2. **The tiles**: each chunk's points are written to the tile files whose core or halo
   holds them (:data:`HALO_CELLS` cells of halo), with their rows in the spill.
3. **The thresholds**: each tile's core cells' statistics counted in fine bins that add,
   the medians read from the sums to within a bin
   (:func:`~geostructure.detect.halo_tiles.binned_thresholds`).
4. **The pieces**: each tile grows its facet pieces
   (:func:`~geostructure.detect.tilejoin.grow_tile`); its points' pieces and cell normals go
   to its own files, the pieces' entries come back and are joined
   (:func:`~geostructure.detect.tilejoin.join_pieces`).
5. **The planarity test** counts each tile's aligned points, and the labels are written to
   the spill's facet file (``facets.i4``, one int32 a row: the facet, -1 none, -2 a curved
   group's, and :data:`~geostructure.stream.passes.DROPPED` for a point the filter drops).

The tile tasks (3 to 5) read only their own tile file, so they run as Dask tasks as they
run here. On rock rough at every scale the grid tries (the far scatter over
:data:`~geostructure.detect.facets.MAX_CELL_SCATTER`), rough rock's facets are grown in the
same tiles instead (:mod:`.tiledrough`), as in memory.
"""

from __future__ import annotations

import shutil
import time
from dataclasses import dataclass, field

import numpy as np

from geostructure.core.bounds import column_max, column_min
from geostructure.core.density import SPACING_TREE_POINTS, point_spacing, spacing_blocks, spacing_of_blocks
from geostructure.core.sampling import sampled_blocks
from geostructure.detect.facets import (
    CELL_EDGE,
    MAX_CELL_SCATTER,
    FacetThresholds,
    coarsened_planes,
    detection_record,
    edge_blocks,
    edge_of_blocks,
)
from geostructure.detect.halo_tiles import (
    SCATTER_HALO_CELLS,
    binned_statistics,
    binned_thresholds,
    cell_keys,
    key_codes,
    tile_cells_of,
    tile_statistics,
)
from geostructure.detect.roughtiles import HALO_SPACINGS
from geostructure.detect.tilejoin import (
    FacetPlanes,
    aligned_counts,
    facet_normals,
    grow_tile,
    join_pieces,
    piece_facets,
    planar_renumbering,
)
from geostructure.stream.executor import SerialExecutor
from geostructure.stream.passes import DROPPED, local_points
from geostructure.stream.source import Spill
from geostructure.stream.tiledrough import rough_facets_of_tiles
from geostructure.stream.tilefiles import TileContext, TileFile, route_to_tiles

#: Cells of halo round each tile: what the far scatter's pairs need (the growing needs one
#: fewer), so one set of tile files serves every pass.
HALO_CELLS = SCATTER_HALO_CELLS
#: A tile's core is at least this many times its halo across, so that the halo, read by two
#: tiles, adds at most about a fifth to the points read.
MIN_TILE_HALOS = 8
#: The facet file's name in the spill's folder.
FACETS_FILE = "facets.i4"


@dataclass
class StreamedFacets:
    """The facets of a spilled survey: each row's facet in ``labels_path`` (see the module),
    ``n_facets``, the points of curved groups, the thresholds, the grid's edge and far
    scatter, the tiles, each facet's plane from all its points (``planes``); ``rough``,
    where the grid was not trusted and the facets are rough rock's, what ``run.json`` says
    of them."""

    labels_path: str | None
    n_facets: int
    curved_points: int
    thresholds: FacetThresholds
    cell_edge: float
    far_scatter: float
    tile_cells: int
    n_tiles: int
    rough: dict | None = None  # where the grid was not trusted: what the rough facets record
    planes: FacetPlanes | None = None  # each facet's plane from all its points
    seconds: dict = field(default_factory=dict)

    def labels(self, start: int = 0, stop: int | None = None) -> np.ndarray:
        """Rows ``start`` to ``stop`` of the facet file."""
        count = -1 if stop is None else stop - start
        return np.fromfile(self.labels_path, dtype="<i4", count=count, offset=4 * start)

    def record(self) -> dict:
        """What ``run.json`` says of the detection, as in memory, with the tiles."""
        return {
            **detection_record(self.thresholds, self.cell_edge, self.far_scatter, self.n_facets, self.curved_points),
            **({} if self.rough is None else {"rough_facets": self.n_facets, **self.rough}),
            "tiles": self.n_tiles,
            "tile_cells": self.tile_cells,
        }


def detect_facets_spilled(
    spill: Spill,
    chunk_points: int,
    executor=None,
    *,
    keep=None,
    tile_points: int | None = None,
    tile_cells: int | None = None,
    progress=None,
) -> StreamedFacets:
    """The facet detector (:func:`~geostructure.detect.facets.detect_facets`) over a spilled
    survey in tiles with halos: every point's facet, as in memory, written to the spill's
    facet file.

    Parameters
    ----------
    spill : Spill
        The survey (:func:`~geostructure.stream.source.spill_inputs`).
    chunk_points : int
        Points a chunk of the spill holds in a pass.
    executor : SerialExecutor or DaskExecutor, optional
        Where the tile tasks run (here by default).
    keep : FilterContext, optional
        The outlier filter's decisions (written to its keep file): the facets are grown on
        the points it keeps, as in memory on the filtered cloud.
    tile_points : int, optional
        Points a tile's core holds on a surface facing it, about: ``chunk_points`` unless
        given.
    tile_cells : int, optional
        Cells on a side of a tile's core (even), instead of ``tile_points``.
    progress : callable, optional
        ``progress(stage, done, total)``: the stages ``route`` (over the chunks) and ``tiles``.

    Returns
    -------
    StreamedFacets
    """
    executor = executor or SerialExecutor()
    report = progress or (lambda stage, done, total: None)
    seconds = {}
    t = time.perf_counter()
    chunks = spill.chunks(chunk_points)
    offset = spill.offset
    n, lower, upper = 0, np.full(3, np.inf), np.full(3, -np.inf)
    for count, lo, hi in executor.map(_kept_bounds, chunks, (offset, keep)):
        n, lower, upper = n + count, np.minimum(lower, lo), np.maximum(upper, hi)
    spacing, edge = _spacing_and_edge(chunks, executor, offset, keep, n, lower, upper)
    seconds["grid"] = time.perf_counter() - t
    if tile_cells is None:
        across = spacing * np.sqrt(tile_points or chunk_points) / edge
        tile_cells = max(MIN_TILE_HALOS * HALO_CELLS, int(across // 2) * 2)
    bound = cell_keys(upper[None], edge, lower)[0] + 2
    # One halo for both detectors: the grid's far scatter needs HALO_CELLS, rough rock's
    # points their neighbours' neighbours (roughtiles.HALO_SPACINGS).
    halo = max(HALO_CELLS, int(np.ceil(HALO_SPACINGS * spacing / edge)))
    context = TileContext(edge, lower, bound, int(tile_cells), halo)
    folder = spill.folder / "tiles"
    try:
        t = time.perf_counter()
        tiles = route_to_tiles(chunks, offset, keep, context, folder, report)
        seconds["route"] = time.perf_counter() - t
        total, done = 3 * len(tiles), [0]  # the thresholds, the growing, the labels

        def step():
            done[0] += 1
            report("tiles", done[0], total)

        t = time.perf_counter()
        binned = None  # the cells' values in bins that add: a survey's would not fit
        for part in executor.map(_tile_statistics, tiles, context):
            binned = part if binned is None else binned + part
            step()
        thresholds, scatter = binned_thresholds(binned, spacing)
        seconds["thresholds"] = time.perf_counter() - t
        found = StreamedFacets(None, 0, 0, thresholds, edge, scatter, int(tile_cells), len(tiles))
        t = time.perf_counter()
        if scatter > MAX_CELL_SCATTER:
            # Rough at every scale the grid tries: rough rock's facets, in the same tiles.
            settings = {"edge": edge, "lower": lower, "tile_cells": int(tile_cells), "halo_cells": halo,
                        "spacing": spacing}  # fmt: skip
            ranks, found.planes, found.rough = rough_facets_of_tiles(tiles, chunks, executor, offset, keep, lower,
                                                                     upper, settings, step)  # fmt: skip
            renumber = np.r_[np.arange(len(found.planes)), -1]
        else:
            context = TileContext(edge, lower, bound, int(tile_cells), halo, thresholds)
            pieces = []
            for piece in executor.map(_tile_pieces, tiles, context):
                pieces.append(piece)
                step()
            joined = join_pieces(pieces)
            normal, _ = facet_normals(joined)
            aligned = np.zeros(len(joined))
            for counts in executor.map(_tile_aligned, list(zip(tiles, joined.rank)), (normal, thresholds)):
                aligned += counts
            renumber, ranks = planar_renumbering(joined, aligned, thresholds), joined.rank
            planar = np.flatnonzero(renumber[:-1] >= 0)  # in rank order, as they are numbered
            found.planes = FacetPlanes.of(joined.count, joined.mean, joined.covariance).take(planar)
        seconds["grow"] = time.perf_counter() - t
        t = time.perf_counter()
        found.labels_path = str(spill.folder / FACETS_FILE)
        found.curved_points = _write_labels(spill, keep, chunk_points, tiles, ranks, renumber, found.labels_path,
                                            step)  # fmt: skip
        found.n_facets = int(renumber.max(initial=-1)) + 1
        seconds["label"] = time.perf_counter() - t
        found.seconds = seconds
        return found
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def _spacing_and_edge(chunks, executor, offset, keep, n: int, lower, upper) -> tuple[float, float]:
    """The spacing and the grid's edge of the kept points, as
    :func:`~geostructure.detect.facets.detect_facets` reads them: on the whole cloud when it
    is small enough to read, else on the blocks it draws, gathered chunk by chunk."""
    if n <= SPACING_TREE_POINTS:
        points = np.vstack([p for p in executor.map(_drawn_points, chunks, (offset, keep, None))] or [np.zeros((0, 3))])
        spacing = point_spacing(points)
        return spacing, coarsened_planes(points, CELL_EDGE * spacing).edge
    block_lower, block_edge, fraction = spacing_blocks(lower, upper, n)
    drawn = (block_lower, block_edge, fraction, 0.0)
    sub = np.vstack([p for p in executor.map(_drawn_points, chunks, (offset, keep, drawn))])
    spacing = spacing_of_blocks(sub, block_lower, block_edge)
    if spacing is None:  # too few probes inside their blocks: the drawn points' own spacing
        spacing = point_spacing(sub)
    block_edge, fraction = edge_blocks(CELL_EDGE * spacing, n)
    drawn = (lower, block_edge, fraction, 0.5)
    sub = np.vstack([p for p in executor.map(_drawn_points, chunks, (offset, keep, drawn))])
    return spacing, edge_of_blocks(sub, CELL_EDGE * spacing, lower, fraction)


def _write_labels(spill, keep, chunk_points, tiles, ranks, renumber, path, step) -> int:
    """Each row's facet in the facet file: -1 by default (:data:`DROPPED` where the filter
    drops it), then each tile's own points; the points of curved groups counted."""
    out = np.memmap(path, dtype="<i4", mode="w+", shape=(max(spill.n_points, 1),))
    for chunk in spill.chunks(chunk_points):
        if keep is None:
            out[chunk.start : chunk.stop] = -1
        else:
            local = None if keep.written else local_points(chunk, spill.offset)
            out[chunk.start : chunk.stop] = np.where(keep.keep(local, chunk), -1, DROPPED)
    curved = 0
    for tile, rank in zip(tiles, ranks):
        own = np.fromfile(tile.path("own"), dtype="<i8")
        piece = np.fromfile(tile.path("piece"), dtype="<i4")
        found = renumber[piece_facets(piece, rank)].astype("<i4")
        out[own] = found
        curved += int((found == -2).sum())
        step()
    out.flush()
    del out
    return curved


# --- the tasks: each reads its own chunk or tile ---------------------------------------------


def _kept_bounds(chunk, context) -> tuple[int, np.ndarray, np.ndarray]:
    offset, keep = context
    local = local_points(chunk, offset)
    if keep is not None:
        local = local[keep.keep(local, chunk)]
    if not len(local):
        return 0, np.full(3, np.inf), np.full(3, -np.inf)
    return len(local), column_min(local), column_max(local)


def _drawn_points(chunk, context) -> np.ndarray:
    """The chunk's kept points in the drawn blocks (all of them with no ``drawn``)."""
    offset, keep, drawn = context
    local = local_points(chunk, offset)
    if keep is not None:
        local = local[keep.keep(local, chunk)]
    if drawn is None:
        return local
    block_lower, block_edge, fraction, shift = drawn
    return local[sampled_blocks(local, block_lower, block_edge, fraction, 0, shift=shift)]


def _tile_cells(tile: TileFile, context: TileContext):
    points = tile.points()
    return points, tile_cells_of(points, context.edge, context.lower, np.array(tile.first), context.tile_cells)


def _tile_statistics(tile: TileFile, context: TileContext):
    return binned_statistics(tile_statistics(_tile_cells(tile, context)[1]))


def _tile_pieces(tile: TileFile, context: TileContext):
    """The tile's pieces (their entries come back); its own points' rows, pieces and cell
    normals go to the tile's files, read again by the planarity test and the labelling."""
    points, cells = _tile_cells(tile, context)
    codes = key_codes(cells.key, context.bound)
    found = grow_tile(cells, codes, tile.first, context.tile_cells, context.halo_cells, context.thresholds, points)
    tile.rows()[found.point].astype("<i8").tofile(tile.path("own"))
    found.piece.astype("<i4").tofile(tile.path("piece"))
    found.normal.astype("<f8").tofile(tile.path("normal"))
    found.point = found.piece = found.normal = None  # held on disk, not sent back
    return found


def _tile_aligned(item, context) -> np.ndarray:
    tile, rank = item
    normal, thresholds = context
    piece = np.fromfile(tile.path("piece"), dtype="<i4")
    cell_normal = np.fromfile(tile.path("normal"), dtype="<f8").reshape(-1, 3)
    return aligned_counts(piece, cell_normal, rank, normal, thresholds)
