"""Rough rock's facets (:mod:`.roughfacets`) tile by tile (docs/tiles.md): each point's plane
from its own neighbours, the groups grown where neighbours agree, joined across the tiles'
borders by the points two tiles share.

What the rough detector reads from the whole cloud, and how the tiles read it:

- **the face's envelope**, a grid an eighth of the cloud wide: its cells' moments add, so
  they are summed over the whole cloud first (:func:`~.roughfacets.envelope_table`), and
  each tile looks its points' normals up in it;
- **the join angle and the typical residual**, medians over every point: each tile counts
  its own points' values in fine bins (:mod:`.bins`), and the medians are read from the
  summed counts, to within a bin;
- **the groups**: each tile grows its own (:func:`grow_rough_tile`) over its core and halo,
  from the points whose nearest neighbours lie inside the tile; they are joined as the
  grid's facet pieces are (:func:`~.tilejoin.piece_groups`), by the points one tile holds as
  its own and another in its halo; a group's size, plane and face add over its pieces.

The halo must hold each own point's neighbours within the join radius and theirs:
:data:`HALO_SPACINGS` spacings.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from geostructure.core.bounds import column_min
from geostructure.detect.bins import angle_counts, angle_quantile, log_counts, log_quantile
from geostructure.detect.cells import SURFACE_VARIATION
from geostructure.detect.roughfacets import (
    FACE_CONE,
    JOIN_ANGLE_RANGE,
    JOIN_RADIUS,
    MIN_FACET_POINTS,
    NORMAL_NEIGHBOURS,
    RoughFacets,
    envelope_normals,
    point_normals,
    steps_off_the_face,
)
from geostructure.detect.tilejoin import FacetPlanes, added_moments, cell_keys, piece_groups, piece_moments

#: A tile's halo, in point spacings: an own point's partners lie within JOIN_RADIUS (2)
#: spacings, and their 16 nearest neighbours within about 2.3 more on a surface.
HALO_SPACINGS = 8.0


def inside_room(points: np.ndarray, box_lower, box_upper) -> np.ndarray:
    """Each point's distance to the nearest face of the box it lies in."""
    return np.minimum((points - box_lower).min(axis=1), (box_upper - points).min(axis=1))


@dataclass
class RoughReading:
    """One tile's counts for the medians: its own points' neighbour angles and residuals (in
    the bins of :mod:`.bins`), and how
    many of its own points had a neighbour past the tile's box (their planes may differ
    from the whole cloud's)."""

    angles: np.ndarray
    residuals: np.ndarray
    short: int

    def __add__(self, other: RoughReading) -> RoughReading:
        return RoughReading(self.angles + other.angles, self.residuals + other.residuals, self.short + other.short)


def read_rough_tile(points: np.ndarray, own: np.ndarray, box) -> RoughReading:
    """One tile's :class:`RoughReading`: ``points`` its core and halo (local coordinates),
    ``own`` (N,) which are its own, ``box`` (lower, upper) the box the tile's points fill."""
    normal, _, residual, neighbours, distances = point_normals(points)
    mine = np.flatnonzero(own)
    cos = np.abs(np.einsum("ij,ikj->ik", normal[mine], normal[neighbours[mine, 1:NORMAL_NEIGHBOURS]]))
    angle = np.degrees(np.arccos(np.clip(cos.ravel(), 0.0, 1.0)))
    short = int((distances[mine, -1] > inside_room(points[mine], *box)).sum())
    return RoughReading(angle_counts(angle), log_counts(residual[mine]), short)


def rough_medians(reading: RoughReading) -> tuple[float, float]:
    """The join angle (degrees, held to the range :func:`~.roughfacets.join_angle` holds it
    to) and the typical residual from the tiles' summed counts."""
    if not reading.angles.sum():
        return JOIN_ANGLE_RANGE[1], 0.0
    angle = float(np.clip(angle_quantile(reading.angles), *JOIN_ANGLE_RANGE))
    return angle, log_quantile(reading.residuals)


@dataclass
class RoughPieces:
    """One tile's groups before the join (P pieces), as :class:`~.tilejoin.TilePieces` has
    them for the grid: ``size`` (P,) own points in each, ``least`` (P,) its least own row,
    ``halo`` and ``border`` (row, piece) pairs, ``moments`` (P, 10) of its own points about
    ``reference``, ``face`` (P, 3) the sum of its own points' envelope normals; per own
    point ``point`` (index in the tile), ``piece`` and ``on_face``."""

    size: np.ndarray
    least: np.ndarray
    halo: np.ndarray
    border: np.ndarray
    moments: np.ndarray
    reference: np.ndarray
    face: np.ndarray
    point: np.ndarray
    piece: np.ndarray
    on_face: np.ndarray

    def __len__(self) -> int:
        return len(self.size)


def grow_rough_tile(points, rows, own, box, envelope, spacing: float, join_angle: float,
                    core_box) -> RoughPieces:  # fmt: skip
    """One tile's rough groups (:func:`~.roughfacets.detect_rough_facets`' growing), over its
    ``points`` (core and halo; their ``rows`` in the cloud, ``own`` which are its own, the
    ``box`` they fill), their face normals ``envelope`` (N, 3), the whole cloud's
    ``spacing`` and ``join_angle``; ``core_box`` the box of its own points' cells."""
    normal, variation, _, neighbours, distances = point_normals(points)
    exact = distances[:, -1] <= inside_room(points, *box)
    on_face = np.abs(np.einsum("ij,ij->i", normal, envelope)) >= np.cos(np.radians(FACE_CONE))
    off = on_face | (variation > SURFACE_VARIATION) | ~(exact | own)
    close = distances[:, 1:] <= JOIN_RADIUS * spacing
    close &= exact[:, None]  # a point's list is the whole cloud's where its neighbours fit
    pairs = np.column_stack([np.nonzero(close)[0], neighbours[:, 1:][close]])
    pairs = pairs[~off[pairs[:, 0]] & ~off[pairs[:, 1]]]
    agree = np.abs(np.einsum("ij,ij->i", normal[pairs[:, 0]], normal[pairs[:, 1]])) >= np.cos(np.radians(join_angle))
    pairs = pairs[agree]
    graph = coo_matrix((np.ones(len(pairs), dtype=np.int8), (pairs[:, 0], pairs[:, 1])), shape=(len(points),) * 2)
    component = np.where(off, -1, connected_components(graph, directed=False)[1])
    grown = component >= 0
    owned = np.bincount(component[grown & own], minlength=len(points))
    kept = np.flatnonzero(owned >= 1)
    piece_of = np.full(len(points) + 1, -1)
    piece_of[kept] = np.arange(len(kept))
    piece = piece_of[component]
    n = len(kept)
    mine = np.flatnonzero(own)
    in_piece = own & (piece >= 0)
    least = np.full(n, np.iinfo(np.int64).max)
    np.minimum.at(least, piece[in_piece], rows[in_piece])
    near_border = inside_room(points, *core_box) <= (box[1] - core_box[1]).max()
    halo, border = ~own & (piece >= 0), in_piece & near_border
    reference = core_box[0]
    face = np.zeros((n, 3))
    np.add.at(face, piece[in_piece], envelope[in_piece])
    return RoughPieces(
        size=np.bincount(piece[in_piece], minlength=n),
        least=least,
        halo=np.column_stack([rows[halo], piece[halo]]),
        border=np.column_stack([rows[border], piece[border]]),
        moments=piece_moments(points[mine] - reference, piece[mine], n),
        reference=reference,
        face=face,
        point=mine,
        piece=piece[mine],
        on_face=on_face[mine],
    )


def join_rough_pieces(tiles: list, typical_residual: float):
    """Every tile's :class:`RoughPieces` joined into the cloud's rough facets: each tile's
    pieces' facet (0, 1, ... by size, ties by the least point; -1 for none), one array per
    tile, with the groups' sizes, planes and faces added over their pieces and kept as
    :func:`~.roughfacets.detect_rough_facets` keeps them; and the facets' planes from all
    their points (:class:`~.tilejoin.FacetPlanes`)."""
    starts, group = piece_groups(tiles)
    n = len(group)
    size = np.bincount(group, weights=np.concatenate([t.size for t in tiles] or [np.zeros(0)]), minlength=n)
    least = np.full(n, np.iinfo(np.int64).max)
    np.minimum.at(least, group, np.concatenate([t.least for t in tiles] or [np.zeros(0, np.int64)]))
    face = np.zeros((n, 3))
    np.add.at(face, group, np.concatenate([t.face for t in tiles] or [np.zeros((0, 3))]))
    candidate = np.flatnonzero(size >= MIN_FACET_POINTS)
    index = np.full(n, -1)
    index[candidate] = np.arange(len(candidate))
    per_tile = [index[group[s:e]] for s, e in zip(starts[:-1], starts[1:])]
    count, mean, covariance = added_moments(tiles, per_tile, len(candidate))
    values, vectors = np.linalg.eigh(covariance) if len(candidate) else (np.zeros((0, 3)), np.zeros((0, 3, 3)))
    thin = values[:, 0] <= SURFACE_VARIATION * np.maximum(values.sum(axis=1), 1e-300)
    rms = np.sqrt(np.maximum(values[:, 0], 0.0))
    mean_face = face[candidate] / np.maximum(np.linalg.norm(face[candidate], axis=1, keepdims=True), 1e-300)
    kept = candidate[steps_off_the_face(vectors[:, :, 0], mean_face, thin, rms, typical_residual)]
    kept = kept[np.lexsort((least[kept], -size[kept]))]
    number = np.full(n, -1)
    number[kept] = np.arange(len(kept))
    planes = FacetPlanes.of(count, mean, covariance).take(index[kept])
    return [number[group[s:e]] for s, e in zip(starts[:-1], starts[1:])], planes


def rough_facets_in_tiles(points: np.ndarray, spacing: float, edge: float, tile_cells: int) -> RoughFacets:
    """:func:`~.roughfacets.detect_rough_facets` in tiles of ``tile_cells`` cells of ``edge``
    on a side, each with a halo of :data:`HALO_SPACINGS` spacings, in memory: what a stream
    does tile by tile. The medians are read to within a bin (see the module)."""
    points = np.asarray(points, dtype=np.float64)
    lower = column_min(points)
    envelope = envelope_normals(points, spacing)
    halo = int(np.ceil(HALO_SPACINGS * spacing / edge))
    key = cell_keys(points, edge, lower) - 1
    tile = key // tile_cells
    boxes = []
    for index in np.unique(tile, axis=0):
        first = index * tile_cells
        held = np.flatnonzero(np.all((key >= first - halo) & (key < first + tile_cells + halo), axis=1))
        own = np.all(tile[held] == index, axis=1)
        core_box = (lower + first * edge, lower + (first + tile_cells) * edge)
        box = (core_box[0] - halo * edge, core_box[1] + halo * edge)
        boxes.append((held, own, box, core_box))
    reading = None
    for held, own, box, _ in boxes:
        part = read_rough_tile(points[held], own, box)
        reading = part if reading is None else reading + part
    assert reading is not None, "a cloud has at least one tile"
    angle, residual = rough_medians(reading)
    pieces = [grow_rough_tile(points[held], held, own, box, envelope[held], spacing, angle, core_box)
              for held, own, box, core_box in boxes]  # fmt: skip
    labels, on_face = np.full(len(points), -1), np.zeros(len(points), dtype=bool)
    numbers, _ = join_rough_pieces(pieces, residual)
    for (held, _, _, _), piece, number in zip(boxes, pieces, numbers):
        at = held[piece.point]
        labels[at] = np.where(piece.piece >= 0, number[np.maximum(piece.piece, 0)], -1) if len(number) else -1
        on_face[at] = piece.on_face
    return RoughFacets(labels, on_face, envelope, angle)
