"""The facet detector's grid in tiles with halos (docs/tiles.md, step 1 of issue 46).

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
from geostructure.detect.cells import CellGrid, CellPlanes, grid_planes, with_sparse_cells_filled

#: Cells of halo round a tile: a sparse cell's coarse block reaches three fine cells out.
HALO_CELLS = 4


@dataclass
class CellTile:
    """One tile's cells: ``points`` (the indices into the cloud of the tile's points, core
    and halo), their grid's planes ``cells`` (:class:`~geostructure.detect.cells.CellPlanes`),
    each cell's key on the whole cloud's grid ``key`` (C, 3) and whether it is a ``core``
    cell of this tile (C,), which no other tile has as its own."""

    points: np.ndarray
    cells: CellPlanes
    key: np.ndarray
    core: np.ndarray


def cell_keys(points: np.ndarray, edge: float, lower) -> np.ndarray:
    """Each point's cell key on the grid of ``edge`` anchored at ``lower``, as
    :class:`~geostructure.detect.cells.CellGrid` numbers its cells (a ring of empty cells
    round the grid: the least key is 1)."""
    return (
        np.floor((np.asarray(points, dtype=np.float64) - np.asarray(lower, dtype=np.float64)) / edge).astype(np.int64)
        + 1
    )


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
        grid = CellGrid.of(points[held], edge, lower)
        cells = with_sparse_cells_filled(grid_planes(grid), grid)
        cell_key = grid.cell_key
        core = np.all((cell_key >= first) & (cell_key < first + tile_cells), axis=1)
        if core.any():
            yield CellTile(held, cells, cell_key, core)


def key_codes(key: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """One integer per cell key (C, 3), the keys' bound ``upper`` (3,) exclusive."""
    upper = np.asarray(upper, dtype=np.int64)
    return (key[:, 0] * upper[1] + key[:, 1]) * upper[2] + key[:, 2]


def key_bound(points: np.ndarray, edge: float, lower) -> np.ndarray:
    """An exclusive bound on the cell keys of ``points``, for :func:`key_codes`."""
    return cell_keys(column_max(np.asarray(points, dtype=np.float64))[None], edge, lower)[0] + 2
