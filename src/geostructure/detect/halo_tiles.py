"""The facet detector in tiles with halos, in memory (docs/tiles.md): the grid's cells, the
thresholds and the growing tile by tile, as a stream does them over a spilled survey
(:mod:`geostructure.stream.tiledfacets`).

A cloud is cut into tiles of whole cells of the detector's grid, all anchored at one
corner, so that a cell has the same key in every tile. Each tile is read with a halo of
:data:`HALO_CELLS` cells, enough for every plane its own (core) cells take: a cell's 3 x 3
x 3 block reaches one cell out, and a sparse cell's block on the grid twice as coarse
(:func:`~geostructure.detect.cells.with_sparse_cells_filled`) three. A core cell's plane is
then the one the whole cloud's grid gives it, to rounding (the moments are summed about
the tile's centre, not the cloud's).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from geostructure.core.bounds import column_max, column_min
from geostructure.core.density import point_spacing
from geostructure.detect.bins import angle_counts, angle_quantile, log_counts, log_quantile
from geostructure.detect.cells import (
    CENTRE,
    SURFACE_VARIATION,
    CellGrid,
    CellPlanes,
    grid_planes,
    neighbour_pairs,
    with_sparse_cells_filled,
)
from geostructure.detect.facets import (
    CELL_EDGE,
    MAX_CELL_SCATTER,
    SCATTER_SAMPLE_POINTS,
    FacetDetection,
    FacetThresholds,
    coarsened_planes,
    sampled_edge,
    thresholds_from_medians,
)
from geostructure.detect.gridscatter import SCATTER_PERCENTILE, SURFACE_SHARE
from geostructure.detect.roughtiles import rough_facets_in_tiles
from geostructure.detect.tilejoin import UNSURE_CELLS, cell_keys, grow_tile, joined_labels

#: Cells of halo round a tile: a sparse cell's coarse block reaches three fine cells out.
HALO_CELLS = 4


@dataclass
class CellTile:
    """One tile's cells: ``points`` (the indices into the cloud of the tile's points, core
    and halo), their grid's planes ``cells`` (:class:`~geostructure.detect.cells.CellPlanes`),
    each cell's key on the whole cloud's grid ``key`` (C, 3), whether it is a ``core``
    cell of this tile (C,), which no other tile has as its own, and ``first`` (3,), the
    least key of its core."""

    points: np.ndarray
    cells: CellPlanes
    key: np.ndarray
    core: np.ndarray
    first: np.ndarray  # the least key of its own cells


def cell_tiles(points: np.ndarray, edge: float, tile_cells: int, lower=None, halo_cells: int = HALO_CELLS):
    """The cloud's grid of ``edge`` cut into tiles ``tile_cells`` cells on a side, each with
    its halo, one :class:`CellTile` at a time.

    Parameters
    ----------
    points : (N, 3) array
        The cloud (local coordinates).
    edge : float
        The grid's cell edge (the detector's, :func:`~geostructure.detect.facets.sampled_edge`).
    tile_cells : int
        Cells on a side of a tile's core; even, so that a coarse cell never straddles two
        tiles' cores.
    lower : (3,) array, optional
        The grid's anchor: the cloud's least corner unless given.
    halo_cells : int
        Cells of halo on every side.

    Yields
    ------
    CellTile
        Each tile that holds a point of its own, in key order.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> xy = rng.random((20_000, 2)) * 10.0
    >>> plane = np.c_[xy, 0.3 * xy[:, 0] + 0.002 * rng.standard_normal(len(xy))]
    >>> tiles = list(cell_tiles(plane, 0.25, tile_cells=8))
    >>> len(tiles), sum(int(t.core.sum()) for t in tiles) == len(np.unique(cell_keys(plane, 0.25, plane.min(0)), axis=0))
    (30, True)
    """
    if tile_cells < 2 or tile_cells % 2:
        raise ValueError(f"tile_cells must be an even number of at least 2, not {tile_cells}")
    points = np.asarray(points, dtype=np.float64)
    lower = column_min(points) if lower is None else np.asarray(lower, dtype=np.float64)
    key = cell_keys(points, edge, lower)
    # Tiles start at key 1, the grid's first cell: key 1 .. tile_cells is tile 0.
    tile = (key - 1) // tile_cells
    for index in np.unique(tile, axis=0):
        first = index * tile_cells + 1  # the tile's least core key
        reach = (key >= first - halo_cells) & (key < first + tile_cells + halo_cells)
        held = np.flatnonzero(reach.all(axis=1))
        found = tile_cells_of(points[held], edge, lower, first, tile_cells)
        if found.core.any():
            yield CellTile(held, found.cells, found.key, found.core, found.first)


def tile_cells_of(points: np.ndarray, edge: float, lower, first, tile_cells: int) -> CellTile:
    """One tile's :class:`CellTile` from its points (core and halo, ``points`` indexing them
    all): the grid of ``edge`` anchored at the cloud's ``lower``, and which cells are the
    tile's own, those from key ``first`` (3,) to ``first + tile_cells``."""
    grid = CellGrid.of(points, edge, lower)
    cells = with_sparse_cells_filled(grid_planes(grid), grid)
    cell_key = grid.cell_key
    first = np.asarray(first, dtype=np.int64)
    core = np.all((cell_key >= first) & (cell_key < first + tile_cells), axis=1)
    return CellTile(np.arange(len(points)), cells, cell_key, core, first)


def key_codes(key: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """One integer per cell key (C, 3), the keys' bound ``upper`` (3,) exclusive."""
    upper = np.asarray(upper, dtype=np.int64)
    return (key[:, 0] * upper[1] + key[:, 1]) * upper[2] + key[:, 2]


def key_bound(points: np.ndarray, edge: float, lower) -> np.ndarray:
    """An exclusive bound on the cell keys of ``points``, for :func:`key_codes`."""
    return cell_keys(column_max(np.asarray(points, dtype=np.float64))[None], edge, lower)[0] + 2


def grow_in_tiles(
    points: np.ndarray, edge: float, thresholds, tile_cells: int, lower=None, halo_cells: int = HALO_CELLS
) -> tuple[np.ndarray, np.ndarray]:
    """The detector's growing, labelling and planarity test
    (:func:`~geostructure.detect.facets.grow_cells`,
    :func:`~geostructure.detect.facets.label_points`,
    :func:`~geostructure.detect.facets.planar_facets`) done tile by tile: each tile grows
    its pieces (:func:`~geostructure.detect.tilejoin.grow_tile`), the pieces are joined
    across the borders (:func:`~geostructure.detect.tilejoin.join_pieces`), and the planarity
    test adds the tiles' moments and counts.

    Parameters
    ----------
    points : (N, 3) array
        The cloud (local coordinates).
    edge : float
        The grid's cell edge.
    thresholds : FacetThresholds
        The whole cloud's (:func:`~geostructure.detect.facets.facet_thresholds`).
    tile_cells : int
        Cells on a side of a tile's core (even).
    lower : (3,) array, optional
        The grid's anchor: the cloud's least corner unless given.
    halo_cells : int
        Cells of halo, more than :data:`~geostructure.detect.tilejoin.UNSURE_CELLS`.

    Returns
    -------
    labels : (N,) int array
        Each point's planar facet (0, 1, ... by the points its cells hold) or -1, as
        :func:`~geostructure.detect.facets.detect_facets` gives them on a trusted grid.
    curved : (N,) bool array
        The points of grown groups that are not planar.

    Examples
    --------
    >>> from geostructure.detect.cells import cell_planes
    >>> from geostructure.detect.facets import facet_thresholds, grow_cells, label_points
    >>> g = np.mgrid[0:4:160j, 0:4:160j].reshape(2, -1).T
    >>> roof = np.c_[g, np.where(g[:, 0] < 2, 0.5 * g[:, 0], 2 - 0.5 * g[:, 0])]
    >>> cells = cell_planes(roof, 0.1)
    >>> thresholds = facet_thresholds(cells, 0.025)
    >>> whole = label_points(roof, cells, grow_cells(cells, thresholds), thresholds.max_offset)
    >>> tiled, curved = grow_in_tiles(roof, 0.1, thresholds, tile_cells=8)
    >>> int(tiled.max() + 1), bool((tiled == whole).all()), int(curved.sum())
    (2, True, 0)
    """
    points = np.asarray(points, dtype=np.float64)
    lower = column_min(points) if lower is None else np.asarray(lower, dtype=np.float64)
    bound = key_bound(points, edge, lower)
    tiles, pieces = [], []
    for tile in cell_tiles(points, edge, tile_cells, lower, halo_cells):
        codes = key_codes(tile.key, bound)
        pieces.append(grow_tile(tile, codes, tile.first, tile_cells, halo_cells, thresholds, points[tile.points]))
        tiles.append(tile.points)
    labels = np.full(len(points), -1, dtype=np.int64)
    for held, piece, found in zip(tiles, pieces, joined_labels(pieces, thresholds)):
        labels[held[piece.point]] = found
    return np.maximum(labels, -1), labels == -2


def detect_facets_in_tiles(points: np.ndarray, tile_cells: int, halo_cells: int = HALO_CELLS) -> FacetDetection:
    """:func:`~geostructure.detect.facets.detect_facets` with its growing and labelling done
    in tiles (:func:`grow_in_tiles`); the spacing, the grid's edge and the thresholds are the
    whole cloud's: the edge as in memory, the thresholds and the far scatter gathered over the
    tiles (:func:`grid_statistics_in_tiles`, docs/tiles.md, steps 1 to 3). On rock rough at
    every scale the grid tries, the rough facets in the same tiles
    (:func:`~geostructure.detect.roughtiles.rough_facets_in_tiles`).

    Parameters
    ----------
    points : (N, 3) array
        The cloud's local coordinates (filtered).
    tile_cells : int
        Cells on a side of a tile's core (even).
    halo_cells : int
        Cells of halo round each tile.

    Returns
    -------
    FacetDetection
        As :func:`~geostructure.detect.facets.detect_facets` gives it.

    Examples
    --------
    >>> g = np.mgrid[0:4:160j, 0:4:160j].reshape(2, -1).T
    >>> roof = np.c_[g, np.where(g[:, 0] < 2, 0.5 * g[:, 0], 2 - 0.5 * g[:, 0])]
    >>> from geostructure.detect.facets import detect_facets
    >>> found = detect_facets_in_tiles(roof, tile_cells=8)
    >>> bool((found.labels == detect_facets(roof).labels).all()), bool((found.labels >= 0).mean() > 0.9)
    (True, True)
    """
    points = np.asarray(points, dtype=np.float64)
    spacing = point_spacing(points)
    lower = column_min(points)
    # The grid's edge: on a sample of blocks above SCATTER_SAMPLE_POINTS (as a stream would
    # read it), else by coarsening the whole grid, as in memory.
    if len(points) > SCATTER_SAMPLE_POINTS:
        edge = sampled_edge(points, CELL_EDGE * spacing)
    else:
        edge = coarsened_planes(points, CELL_EDGE * spacing).edge
    thresholds, scatter = grid_statistics_in_tiles(points, edge, spacing, tile_cells, lower,
                                                   max(halo_cells, SCATTER_HALO_CELLS))  # fmt: skip
    if scatter > MAX_CELL_SCATTER:
        rough = rough_facets_in_tiles(points, spacing, edge, tile_cells)
        return FacetDetection(rough.labels, np.zeros(len(points), bool), thresholds, edge, scatter, rough)
    labels, curved = grow_in_tiles(points, edge, thresholds, tile_cells, lower, halo_cells)
    return FacetDetection(labels, curved, thresholds, edge, scatter)


#: A cell's far scatter pairs it with the cell two steps along each axis: the tiles that
#: read it need sure cells two out, so a halo this wide.
SCATTER_HALO_CELLS = UNSURE_CELLS + 2


def grid_statistics_in_tiles(
    points: np.ndarray, edge: float, spacing: float, tile_cells: int, lower=None,
    halo_cells: int = SCATTER_HALO_CELLS,
):  # fmt: skip
    """The detector's thresholds and its grid's far scatter, read tile by tile, equal to
    :func:`~geostructure.detect.facets.facet_thresholds` and
    :func:`~geostructure.detect.gridscatter.far_scatter` on the whole grid (docs/tiles.md,
    step 2). Each tile gives the values of its own core cells and of the pairs its core
    cells start: medians do not add, so the values are gathered and their medians taken
    once, exactly.

    Parameters
    ----------
    points : (N, 3) array
        The cloud (local coordinates).
    edge : float
        The grid's cell edge.
    spacing : float
        The cloud's point spacing.
    tile_cells : int
        Cells on a side of a tile's core (even).
    lower : (3,) array, optional
        The grid's anchor: the cloud's least corner unless given.
    halo_cells : int
        Cells of halo, at least :data:`SCATTER_HALO_CELLS`.

    Returns
    -------
    thresholds : FacetThresholds
        As the whole grid gives them.
    scatter : float
        The far scatter (degrees), as the whole grid gives it.

    Examples
    --------
    >>> from geostructure.detect.cells import CellGrid, grid_planes, with_sparse_cells_filled
    >>> from geostructure.detect.facets import facet_thresholds
    >>> from geostructure.detect.gridscatter import far_scatter
    >>> rng = np.random.default_rng(3)
    >>> xy = rng.random((30_000, 2)) * 6.0
    >>> wavy = np.c_[xy, 0.2 * np.sin(xy[:, 0]) + 0.003 * rng.standard_normal(len(xy))]
    >>> grid = CellGrid.of(wavy, 0.15)
    >>> cells = with_sparse_cells_filled(grid_planes(grid), grid)
    >>> thresholds, scatter = grid_statistics_in_tiles(wavy, 0.15, 0.035, tile_cells=8)
    >>> thresholds == facet_thresholds(cells, 0.035), abs(scatter - far_scatter(cells)) < 1e-9
    (True, True)
    """
    if halo_cells < SCATTER_HALO_CELLS:
        raise ValueError(f"halo_cells must be at least {SCATTER_HALO_CELLS}, not {halo_cells}")
    parts = [tile_statistics(tile) for tile in cell_tiles(points, edge, tile_cells, lower, halo_cells)]
    return combined_statistics(parts, spacing)


def tile_statistics(tile: CellTile) -> tuple:
    """What one tile gives :func:`combined_statistics`: its core cells' residuals (defined
    cells), variations, counts and whether defined, the angles of the touching pairs its
    core cells start, and the far pairs' angles (:func:`_far_pairs`). Its halo must be at
    least :data:`SCATTER_HALO_CELLS` wide."""
    cells, core = tile.cells, tile.core
    source, target = neighbour_pairs(cells)  # forward pairs: each counted in its source's tile
    mine = core[source]
    cosine = np.abs(np.einsum("ij,ij->i", cells.normal[source[mine]], cells.normal[target[mine]]))
    return (
        cells.residual[core & cells.defined],
        cells.variation[core],
        cells.count[core],
        cells.defined[core],
        np.arccos(np.clip(cosine, 0.0, 1.0)),
        _far_pairs(cells, core),
    )


def combined_statistics(parts, spacing: float) -> tuple[FacetThresholds, float]:
    """The thresholds and the far scatter of the whole grid from every tile's
    :func:`tile_statistics` (in any order): the medians and the percentile taken once."""
    residual, variation, count, defined, angles = (np.concatenate([p[i] for p in parts]) for i in range(5))
    far = [p[5] for p in parts]
    scatter = float(np.degrees(np.median(angles))) if len(angles) else 0.0
    any_defined = defined.any()
    thresholds = thresholds_from_medians(scatter, float(np.median(residual)) if any_defined else None,
                                         float(np.median(variation[defined])) if any_defined else None, spacing)  # fmt: skip
    # The far scatter on the surface's cells (gridscatter.surface_cells): the thin cells when
    # they hold half the points or more, a share that adds over the tiles.
    thin = defined & (variation <= SURFACE_VARIATION)
    surface = count[thin].sum() >= SURFACE_SHARE * count[defined].sum()
    far_angles = np.concatenate([pick[1] if surface else pick[0] for pick in far])
    far_scatter = float(np.degrees(np.percentile(far_angles, SCATTER_PERCENTILE))) if len(far_angles) else 0.0
    return thresholds, far_scatter


@dataclass
class BinnedStatistics:
    """:func:`tile_statistics` as counts in fine bins (:mod:`.bins`), which add over the tiles
    where the values themselves would not fit: a survey's cells each give about twenty
    numbers (at 100M points on a 1 cm face, gigabytes). The medians and the percentile come
    out within half a bin (1e-4 degree, 1e-4 of a decade) of the exact ones."""

    residual: np.ndarray
    variation: np.ndarray
    angles: np.ndarray
    far_defined: np.ndarray
    far_thin: np.ndarray
    thin_points: float
    defined_points: float
    defined: int

    def __add__(self, other: BinnedStatistics) -> BinnedStatistics:
        return BinnedStatistics(*(getattr(self, f) + getattr(other, f) for f in self.__dataclass_fields__))


def binned_statistics(part: tuple) -> BinnedStatistics:
    """One tile's :func:`tile_statistics` as :class:`BinnedStatistics`."""
    residual, variation, count, defined, angles, (far_defined, far_thin) = part
    thin = defined & (variation <= SURFACE_VARIATION)
    return BinnedStatistics(
        log_counts(residual),
        log_counts(variation[defined]),
        angle_counts(np.degrees(angles)),
        angle_counts(np.degrees(far_defined)),
        angle_counts(np.degrees(far_thin)),
        float(count[thin].sum()),
        float(count[defined].sum()),
        int(defined.sum()),
    )


def binned_thresholds(binned: BinnedStatistics, spacing: float) -> tuple[FacetThresholds, float]:
    """:func:`combined_statistics` from every tile's :class:`BinnedStatistics`, added."""
    some = binned.defined > 0
    thresholds = thresholds_from_medians(angle_quantile(binned.angles), log_quantile(binned.residual) if some else None,
                                         log_quantile(binned.variation) if some else None, spacing)  # fmt: skip
    surface = binned.thin_points >= SURFACE_SHARE * binned.defined_points
    far = binned.far_thin if surface else binned.far_defined
    return thresholds, angle_quantile(far, SCATTER_PERCENTILE / 100.0)


def _far_pairs(cells: CellPlanes, core: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The angles between each core cell's normal and that of the cell two steps along each
    axis (:func:`~geostructure.detect.gridscatter.far_scatter`'s pairs), among the defined
    cells and among the thin ones: which of the two counts is the whole cloud's choice."""
    thin = cells.defined & (cells.variation <= SURFACE_VARIATION)
    found: tuple[list, list] = ([], [])
    for axis_offset in (CENTRE + 9, CENTRE + 3, CENTRE + 1):  # +x, +y, +z
        one = cells.neighbour[:, axis_offset]
        two = np.where(one >= 0, cells.neighbour[np.maximum(one, 0), axis_offset], -1)
        for among, out in ((cells.defined, found[0]), (thin, found[1])):
            ok = core & (two >= 0) & among
            ok[ok] &= among[two[ok]]
            cosine = np.abs(np.einsum("ij,ij->i", cells.normal[ok], cells.normal[two[ok]]))
            out.append(np.arccos(np.clip(cosine, 0.0, 1.0)))
    return np.concatenate(found[0]), np.concatenate(found[1])
