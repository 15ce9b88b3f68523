"""Local planes on a grid: each cell's plane from the moments of its 3 x 3 x 3 block of cells.

A per-point plane (the covariance of a point's ``k`` nearest neighbours, as DSE computes
it) costs a nearest-neighbour search over the whole cloud and a covariance per point: on an
outcrop of a million points that is most of the run. The same neighbourhood, to within its
shape, is the block of 27 grid cells around a point's cell: the moments of the cells are
additive (count, sum, sum of outer products, by ``bincount``), so every block's covariance
is 27 shifted sums of them, and one eigen-decomposition per cell (a few points each) gives
what the per-point fits gave, without a tree. With cells twice the point spacing wide a
block holds about as many points as 30 neighbours (it spans 3 cells, about 6 spacings).

Growing and labelling the points on these planes is :mod:`.facets`' work.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import partial
from itertools import product

import numpy as np

from geostructure.core.bounds import column_max, column_min
from geostructure.core.eigen import smallest_eigenpair
from geostructure.core.gridkeys import binned_sums, floor_index, group_codes
from geostructure.core.threads import run_blocks, run_tasks, task_workers

#: The 27 offsets of a block, the centre (0, 0, 0) at index 13; and the 13 that go "forward"
#: (lexicographically after the centre), so that each pair of neighbouring cells is met once.
OFFSETS = np.array(list(product((-1, 0, 1), repeat=3)), dtype=np.int64)
CENTRE = 13
FORWARD = np.arange(CENTRE + 1, 27)
#: A block's plane is defined when it holds this many points and they spread in two
#: directions (lambda_1 at least this share of lambda_2): a block of one or two points, or
#: of a line of points (a wall's edge), has a normal that rounding alone can turn round.
MIN_BLOCK_POINTS = 8
MIN_SPREAD_RATIO = 0.05
#: A block is part of a surface when its smallest eigenvalue is at most this share of their
#: sum (its thickness under a tenth of its width); the grid's scatter is read on such blocks
#: (:func:`~geostructure.detect.gridscatter.surface_cells`), and the face's clutter is what is not.
SURFACE_VARIATION = 0.05


@dataclass
class CellPlanes:
    """Per cell (C of them): its ``corner`` (C, 3), point ``count`` (C,), the mean of its own
    points ``centroid`` (C, 3); its block's plane: unit ``normal`` (C, 3) through
    ``block_centroid`` (C, 3), ``variation`` (C,) = lambda_0 / (lambda_0 + lambda_1 +
    lambda_2) and ``residual`` (C,) RMS distance of the block's points to it; ``neighbour``
    (C, 27), the index of the cell at each of :data:`OFFSETS` or -1; and, per point,
    ``point_cell`` (N,)."""

    edge: float
    point_cell: np.ndarray
    corner: np.ndarray
    count: np.ndarray
    centroid: np.ndarray
    normal: np.ndarray
    block_centroid: np.ndarray
    variation: np.ndarray
    residual: np.ndarray
    defined: np.ndarray
    neighbour: np.ndarray

    def __len__(self) -> int:
        return len(self.count)

    def point_offset(self, points: np.ndarray, cells: np.ndarray) -> np.ndarray:
        """Distance of each point to the block plane of the cell given for it: n . p - n . c,
        from four columns gathered per point rather than two rows of three (1.1 s to about
        half at 8M points; local coordinates keep the difference to 1e-14 m)."""
        normal = np.ascontiguousarray(self.normal.T)
        plane_height = np.einsum("ij,ij->i", self.normal, self.block_centroid)
        height = np.empty(len(cells))
        term = np.empty(len(height))  # one buffer for the three products (fresh pages cost)

        def offset_rows(rows: slice) -> None:
            h, t, c = height[rows], term[rows], cells[rows]
            np.take(plane_height, c, out=h, mode="clip")  # "raise" buffers a copy
            for axis in range(3):
                np.take(normal[axis], c, out=t, mode="clip")
                h -= np.multiply(t, points[rows, axis], out=t)
            np.abs(h, out=h)

        run_blocks(offset_rows, len(cells))
        return height


@dataclass
class CellGrid:
    """A grid of ``edge`` over a cloud, before any plane is fitted: the occupied cells'
    sorted ``codes`` (C,), each point's ``point_cell`` (N,), and the cells' additive
    ``moments`` (C + 1, 10: count, sums and sums of products about the cloud's ``centre``,
    the last row zeros for "no cell"). Keys are ``floor((p - lower) / edge) + 1``, a ring of
    empty cells round the grid, and a cell's code packs its key with ``dims``."""

    edge: float
    lower: np.ndarray
    dims: np.ndarray
    codes: np.ndarray
    point_cell: np.ndarray
    moments: np.ndarray
    centre: np.ndarray

    @classmethod
    def of(cls, points: np.ndarray, edge: float, lower=None) -> CellGrid:
        """The grid of ``points`` (N, 3) at ``edge``, with the cells' moments; anchored at
        ``lower`` (the points' least corner unless given: a sample's grid on its cloud's)."""
        points = np.asarray(points, dtype=np.float64)
        lower = column_min(points) if lower is None else np.asarray(lower, dtype=np.float64)
        # Column by column into one buffer of keys (rows), which then holds the codes and,
        # once they are grouped, the coordinates: no array the cloud's size is allocated
        # twice (each costs the first touch of its pages, about 0.1 s per 64 MB).
        key = np.empty((3, len(points)), dtype=np.int64)
        scaled = np.empty(len(points))
        for a in range(3):
            floor_index(points[:, a], lower[a], edge, key[a], scaled)
        del scaled
        key += 1
        dims = key.max(axis=1, initial=1) + 2
        code = key[0]
        code *= dims[1]
        code += key[1]
        code *= dims[2]
        code += key[2]
        codes, point_cell = group_codes(code, math.prod(int(d) for d in dims), minor=int(dims[2]))
        # About the cloud's centre, the covariance loses about extent^2 * 1e-16 m^2: 1e-10
        # at a kilometre, far below any surface's noise.
        centre = points.mean(axis=0)
        rel = key.view(np.float64)
        for a in range(3):
            np.subtract(points[:, a], centre[a], out=rel[a])
        moments = np.zeros((len(codes) + 1, 10))
        moments[:-1, 0] = np.bincount(point_cell, minlength=len(codes))
        moments[:-1, 1:4], moments[:-1, 4:] = binned_sums(rel, point_cell, len(codes))
        return cls(float(edge), lower, dims, codes, point_cell, moments, centre)

    def __len__(self) -> int:
        return len(self.codes)

    @property
    def cell_key(self) -> np.ndarray:
        c, d = self.codes, self.dims
        return np.stack([c // (d[1] * d[2]), (c // d[2]) % d[1], c % d[2]], axis=1)

    def coarser(self) -> CellGrid:
        return self.coarser_with_parent()[0]

    def coarser_with_parent(self) -> tuple[CellGrid, np.ndarray]:
        """The grid of twice the edge on the same points, from these cells' moments alone,
        and each of these cells' cell on it:
        floor(floor(x) / 2) = floor(x / 2), and halving is exact in binary floating point,
        so every point falls in the coarse cell it would fall in from scratch."""
        key = (self.cell_key - 1) // 2 + 1
        dims = column_max(key) + 2
        codes, parent = group_codes(
            (key[:, 0] * dims[1] + key[:, 1]) * dims[2] + key[:, 2], math.prod(int(d) for d in dims)
        )
        moments = np.zeros((len(codes) + 1, 10))
        for c in range(10):
            moments[:-1, c] = np.bincount(parent, self.moments[:-1, c], len(codes))
        coarse = CellGrid(2.0 * self.edge, self.lower, dims, codes, parent[self.point_cell], moments, self.centre)
        return coarse, parent

    def steps(self) -> np.ndarray:
        """The code offset of each of :data:`OFFSETS`."""
        return (OFFSETS[:, 0] * self.dims[1] + OFFSETS[:, 1]) * self.dims[2] + OFFSETS[:, 2]

    def find(self, target: np.ndarray) -> np.ndarray:
        """The cell index of each code in ``target``, -1 where no cell is."""
        at = np.minimum(np.searchsorted(self.codes, target), len(self.codes) - 1)
        return np.where(self.codes[at] == target, at, -1)


#: The moment columns: the count, the three sums, the six sums of products.
MOMENT_COLUMNS = (None, 0, 1, 2, (0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))


def block_fit(block: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Blocks' planes from their summed moments (B, 10): eigenvalues (B, 3) ascending, unit
    normal (B, 3), mean about the centre (B, 3), and whether each plane is defined (see
    :data:`MIN_BLOCK_POINTS`)."""
    values, normal, mean = np.empty((len(block), 3)), np.empty((len(block), 3)), np.empty((len(block), 3))
    defined = np.empty(len(block), dtype=bool)

    def fit(rows: slice) -> None:  # each block of rows on its own: the same bits in any split
        n_b = block[rows, 0]
        with np.errstate(invalid="ignore", divide="ignore"):  # an empty block: NaN, and undefined
            np.divide(block[rows, 1:4], n_b[:, None], out=mean[rows])
            cov = np.empty((len(n_b), 3, 3))
            for c, (a, b) in enumerate(MOMENT_COLUMNS[4:], start=4):
                cov[:, a, b] = cov[:, b, a] = block[rows, c] / n_b - mean[rows, a] * mean[rows, b]
        values[rows], normal[rows] = smallest_eigenpair(np.nan_to_num(cov, copy=False))
        defined[rows] = (n_b >= MIN_BLOCK_POINTS) & (values[rows, 1] >= MIN_SPREAD_RATIO * values[rows, 2])

    run_blocks(fit, len(block))
    return values, normal, mean, defined


def cell_planes(points: np.ndarray, edge: float) -> CellPlanes:
    """The grid of ``edge`` over ``points`` (N, 3) and each occupied cell's block plane.

    Examples
    --------
    >>> g = np.mgrid[0:1:40j, 0:1:40j].reshape(2, -1).T
    >>> cells = cell_planes(np.c_[g, 0.5 * g[:, 0]], 0.05)
    >>> bool(np.allclose(np.abs(cells.normal @ [-0.5, 0, 1]) / np.hypot(0.5, 1), 1))
    True
    """
    return grid_planes(CellGrid.of(points, edge))


def grid_planes(grid: CellGrid) -> CellPlanes:
    """Each occupied cell's block plane on ``grid``, with the cells' neighbour table."""
    codes, n_cells = grid.codes, len(grid)
    # The neighbours forward of each cell by search; those behind it by symmetry. 32-bit
    # and in rows, the block sums' gather index as it stands: every fresh megabyte costs
    # time (its pages are zeroed on first touch), and the 64-bit table and its two copies
    # were most of this function's time at 0.4M cells.
    index = np.int32 if n_cells < 2**31 - 1 else np.int64
    neighbour = np.full((n_cells, 27), -1, dtype=index)
    neighbour[:, CENTRE] = np.arange(n_cells)
    steps = grid.steps()

    def search(o: int) -> None:  # each offset fills its own two columns: the threads never meet
        target = codes + steps[o]
        at = np.minimum(np.searchsorted(codes, target), n_cells - 1)
        found = np.flatnonzero(codes[at] == target)
        neighbour[found, o] = at[found]
        neighbour[at[found], 26 - o] = found

    run_tasks([partial(search, int(o)) for o in FORWARD], workers=task_workers(n_cells))
    # A block's moments are the sum of its 27 cells' (-1, "no neighbour", picks the last
    # row, of zeros), the table itself the gather's index.
    block = neighbour_sums(grid.moments, neighbour)
    count = grid.moments[:n_cells, 0]
    return CellPlanes(
        edge=grid.edge,
        point_cell=grid.point_cell,
        corner=grid.lower + (grid.cell_key - 1) * grid.edge,
        count=count,
        centroid=grid.moments[:n_cells, 1:4] / count[:, None] + grid.centre,
        neighbour=neighbour,
        **block_planes(grid, block),
    )


#: Cells summed at a time by :func:`neighbour_sums`: their rows (80 bytes each) stay in cache.
SUM_CHUNK = 16384


def neighbour_sums(values: np.ndarray, neighbour: np.ndarray) -> np.ndarray:
    """Each row of ``neighbour`` (C, K) summed over the rows of ``values`` it indexes (-1 the
    last row), in column order: the K gathers a chunk of rows at a time into two buffers. A sparse
    product with K ones a row computes the same sums (in the same order, bit for bit) but
    casts its K * C ones to float64 first: at 0.4M cells 86 MB of fresh pages, a second on
    a machine whose memory is slow to touch, against 0.1 s here.

    Examples
    --------
    >>> values = np.array([[1.0, 10.0], [2.0, 20.0], [0.0, 0.0]])
    >>> neighbour_sums(values, np.array([[0, 1], [1, 2]])).tolist()
    [[3.0, 30.0], [2.0, 20.0]]
    """
    out = np.empty((len(neighbour), values.shape[1]))

    def sum_rows(block: slice) -> None:  # a thread's rows, a chunk at a time, its own buffer
        first, last = block.indices(len(neighbour))[:2]
        gathered = np.empty((min(SUM_CHUNK, last - first), values.shape[1]))
        for start in range(first, last, SUM_CHUNK):
            rows = neighbour[start : min(start + SUM_CHUNK, last)]
            total, part = out[start : start + len(rows)], gathered[: len(rows)]
            np.take(values, rows[:, 0], axis=0, out=total, mode="wrap")  # "raise" buffers a copy
            for k in range(1, neighbour.shape[1]):
                np.take(values, rows[:, k], axis=0, out=part, mode="wrap")
                total += part

    run_blocks(sum_rows, len(neighbour))
    return out


def block_planes(grid: CellGrid, block: np.ndarray) -> dict:
    """The :class:`CellPlanes` fields of blocks' planes from their summed moments (B, 10):
    ``normal``, ``block_centroid``, ``variation``, ``residual`` and ``defined``."""
    values, normal, mean, defined = block_fit(block)
    return {
        "normal": normal,
        "block_centroid": grid.centre + mean,
        "variation": values[:, 0] / np.maximum(values.sum(axis=1), 1e-300),
        "residual": np.sqrt(values[:, 0]),
        "defined": defined,
    }


def neighbour_pairs(cells: CellPlanes) -> tuple[np.ndarray, np.ndarray]:
    """Every pair of touching cells (26-connected) whose planes are defined, each pair once."""

    def pairs_of(rows: slice) -> tuple[np.ndarray, np.ndarray]:  # in order, a block of cells
        first, last = rows.indices(len(cells))[:2]
        source = np.repeat(np.arange(first, last), len(FORWARD))
        target = cells.neighbour[rows, FORWARD].ravel()
        ok = (target >= 0) & cells.defined[source]
        ok[ok] &= cells.defined[target[ok]]
        return source[ok], target[ok]

    pieces = run_blocks(pairs_of, len(cells))
    if len(pieces) == 1:
        return pieces[0]
    return np.concatenate([s for s, _ in pieces]), np.concatenate([t for _, t in pieces])


def block_moments(grid: CellGrid, cells: np.ndarray) -> np.ndarray:
    """The summed moments (len(cells), 10) of the 3 x 3 x 3 blocks of the given cells (sorted
    indices, so the searches run in order), found by search rather than by the whole grid's
    neighbour table."""
    codes = grid.codes[cells]
    index = np.empty((len(cells), len(OFFSETS)), dtype=np.int64)

    def search(k: int, step: int) -> None:  # a column each: the threads never meet
        index[:, k] = grid.find(codes + step)  # -1, "no cell": the row of zeros

    run_tasks([partial(search, k, step) for k, step in enumerate(grid.steps())], workers=task_workers(len(cells)))
    return neighbour_sums(grid.moments, index)


def with_sparse_cells_filled(cells: CellPlanes, grid: CellGrid) -> CellPlanes:
    """Cells whose block holds too few points for a plane take their parent's block plane on
    the grid twice as coarse, where that one is defined.

    A cloud's density varies: the grid is sized from its median spacing, so where the
    points are sparser (the ground around the observatory's walls, at a third of their
    density) 40% of the blocks held fewer than :data:`MIN_BLOCK_POINTS` and defined no
    plane, and the facets grown there broke into hundreds of pieces.
    """
    sparse = np.flatnonzero(~cells.defined)
    if not len(sparse) or len(grid) < 2:
        return cells
    coarse, parent = grid.coarser_with_parent()
    # Only the sparse cells' parents' blocks: at 8M points fitting the whole coarse grid took
    # 0.5 s for the few per cent of cells that need it.
    parents, source = np.unique(parent[sparse], return_inverse=True)
    wider = block_planes(coarse, block_moments(coarse, parents))
    take = wider["defined"][source]
    if not take.any():
        return cells
    source, take = source[take], sparse[take]
    filled = {name: getattr(cells, name).copy() for name in wider}
    for name, values in filled.items():
        values[take] = wider[name][source]
    return replace(cells, **filled)
