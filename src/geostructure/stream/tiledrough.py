"""Rough rock's facets over a spilled survey, tile by tile (:mod:`geostructure.detect.roughtiles`
in a stream): the passes :func:`~geostructure.stream.tiledfacets.detect_facets_spilled` runs
when the grid is not trusted.

1. The face's envelope: the envelope grid's moments summed over the spill's chunks.
2. The medians: each tile's counts of its own points' neighbour angles and residuals.
3. The groups: each tile grows its own; its own points' rows and groups go to its files.
4. The join, then each own point's facet written to the facet file.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from geostructure.detect.cells import CellGrid
from geostructure.detect.halo_tiles import cell_keys
from geostructure.detect.roughfacets import EnvelopeTable, envelope_edge, envelope_table
from geostructure.detect.roughtiles import grow_rough_tile, join_rough_pieces, read_rough_tile, rough_medians
from geostructure.detect.tilejoin import moved_moments
from geostructure.stream.passes import local_points


@dataclass(frozen=True)
class RoughContext:
    """What every rough tile task needs: the tiles' grid, the envelope, and once read the
    spacing, the join angle."""

    edge: float
    lower: np.ndarray
    tile_cells: int
    halo_cells: int
    envelope: EnvelopeTable
    spacing: float
    join_angle: float = 0.0


def envelope_of_chunks(chunks, executor, offset, keep, lower, upper, spacing: float) -> EnvelopeTable:
    """The face's envelope (:func:`~geostructure.detect.roughfacets.envelope_table`) of the
    kept points, its grid's moments summed chunk by chunk."""
    edge = envelope_edge(spacing, float((upper - lower).max()))
    dims = np.floor((upper - lower) / edge).astype(np.int64) + 3  # as CellGrid.of numbers them
    centre = (lower + upper) / 2.0
    codes, moments = [], []
    for part_codes, part_moments in executor.map(_envelope_moments, chunks, (offset, keep, lower, edge, dims, centre)):
        codes.append(part_codes)
        moments.append(part_moments)
    codes = np.concatenate(codes)
    found, inverse = np.unique(codes, return_inverse=True)
    total = np.zeros((len(found) + 1, 10))
    for c in range(10):
        total[:-1, c] = np.bincount(inverse.ravel(), np.concatenate([m[:, c] for m in moments]), len(found))
    grid = CellGrid(edge, np.asarray(lower, dtype=np.float64), dims, found, np.zeros(0, dtype=np.int64), total, centre)
    return envelope_table(grid)


def _envelope_moments(chunk, context):
    """The chunk's kept points' moments on the envelope grid (anchored as in memory), moved
    to the survey's centre, each cell by its code on the whole grid."""
    offset, keep, lower, edge, dims, centre = context
    local = local_points(chunk, offset)
    if keep is not None:
        local = local[keep.keep(local, chunk)]
    if not len(local):
        return np.zeros(0, dtype=np.int64), np.zeros((0, 10))
    grid = CellGrid.of(local, edge, lower)
    key = grid.cell_key
    code = (key[:, 0] * dims[1] + key[:, 1]) * dims[2] + key[:, 2]
    return code, moved_moments(grid.moments[:-1], grid.centre - centre)


def tile_boxes(tile, edge: float, lower, tile_cells: int, halo_cells: int):
    """A tile's points (local), whether each is its own, the box they fill and its core's box."""
    points = tile.points()
    first = np.asarray(tile.first, dtype=np.int64)
    key = cell_keys(points, edge, lower)
    own = np.all((key >= first) & (key < first + tile_cells), axis=1)
    core = (lower + (first - 1) * edge, lower + (first - 1 + tile_cells) * edge)
    box = (core[0] - halo_cells * edge, core[1] + halo_cells * edge)
    return points, own, box, core


def read_rough_task(tile, context: RoughContext):
    points, own, box, _ = tile_boxes(tile, context.edge, context.lower, context.tile_cells, context.halo_cells)
    return read_rough_tile(points, own, box)


def grow_rough_task(tile, context: RoughContext):
    """The tile's rough pieces (their entries come back); its own points' rows and pieces go
    to the tile's files."""
    points, own, box, core = tile_boxes(tile, context.edge, context.lower, context.tile_cells, context.halo_cells)
    rows = tile.rows()
    found = grow_rough_tile(points, rows, own, box, context.envelope.at(points), context.spacing,
                            context.join_angle, core)  # fmt: skip
    rows[found.point].astype("<i8").tofile(tile.path("own"))
    found.piece.astype("<i4").tofile(tile.path("piece"))
    face_points = int(found.on_face.sum())
    found.point = found.piece = found.on_face = None  # held on disk, not sent back
    return found, face_points


def rough_facets_of_tiles(tiles, chunks, executor, offset, keep, lower, upper, context: dict, step):
    """The rough facets of the routed ``tiles``: each tile's pieces' facet (one array per
    tile), the facets' planes from all their points, and what ``run.json`` says of them: the join angle, the points on the face, and
    how many points had a neighbour past their tile's halo (their planes may differ from
    the whole cloud's)."""
    envelope = envelope_of_chunks(chunks, executor, offset, keep, lower, upper, context["spacing"])
    rough = RoughContext(envelope=envelope, **context)
    reading = None
    for part in executor.map(read_rough_task, tiles, rough):
        reading = part if reading is None else reading + part
        step()
    angle, residual = rough_medians(reading)
    rough = RoughContext(envelope=envelope, join_angle=angle, **context)
    pieces, face_points = [], 0
    for piece, on_face in executor.map(grow_rough_task, tiles, rough):
        pieces.append(piece)
        face_points += on_face
        step()
    record = {"rough_join_angle_deg": angle, "face_points": face_points, "points_past_halo": reading.short}
    numbers, planes = join_rough_pieces(pieces, residual)
    return numbers, planes, record
