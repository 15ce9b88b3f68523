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

from dataclasses import dataclass
from itertools import product

import numpy as np
from scipy.sparse import csr_matrix

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
        """Distance of each point to the block plane of the cell given for it."""
        return np.abs(np.einsum("ij,ij->i", points - self.block_centroid[cells], self.normal[cells]))


def cell_planes(points: np.ndarray, edge: float) -> CellPlanes:
    """The grid of ``edge`` over ``points`` (N, 3) and each occupied cell's block plane.

    Examples
    --------
    >>> g = np.mgrid[0:1:40j, 0:1:40j].reshape(2, -1).T
    >>> cells = cell_planes(np.c_[g, 0.5 * g[:, 0]], 0.05)
    >>> bool(np.allclose(np.abs(cells.normal @ [-0.5, 0, 1]) / np.hypot(0.5, 1), 1))
    True
    """
    points = np.asarray(points, dtype=np.float64)
    lower = points.min(axis=0)
    key = np.floor((points - lower) / edge).astype(np.int64) + 1  # +1: a ring of empty cells round the grid
    dims = key.max(axis=0) + 2
    code = (key[:, 0] * dims[1] + key[:, 1]) * dims[2] + key[:, 2]
    codes, point_cell = np.unique(code, return_inverse=True)
    n_cells = len(codes)
    cell_key = np.stack([codes // (dims[1] * dims[2]), (codes // dims[2]) % dims[1], codes % dims[2]], axis=1)
    corner = lower + (cell_key - 1) * edge

    # The neighbours forward of each cell by search; those behind it by symmetry.
    neighbour = np.full(
        (n_cells, 27), -1, dtype=np.int64, order="F"
    )  # column by column: one offset's cells are contiguous
    neighbour[:, CENTRE] = np.arange(n_cells)
    steps = (OFFSETS[:, 0] * dims[1] + OFFSETS[:, 1]) * dims[2] + OFFSETS[:, 2]
    for o in FORWARD:
        target = codes + steps[o]
        at = np.minimum(np.searchsorted(codes, target), n_cells - 1)
        found = np.flatnonzero(codes[at] == target)
        neighbour[found, o] = at[found]
        neighbour[at[found], 26 - o] = found

    # Additive moments (count, sums, sums of products) about the cloud's centre, one row per
    # cell and a row of zeros for "no neighbour"; a block's are the sum of its 27 cells'.
    # About the centre, the covariance loses about extent^2 * 1e-16 m^2: 1e-10 at a
    # kilometre, far below any surface's noise.
    rel = points - points.mean(axis=0)
    columns = [None, 0, 1, 2, (0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)]
    moments = np.zeros((n_cells + 1, 10))
    for c, col in enumerate(columns):
        weights = None if col is None else rel[:, col] if isinstance(col, int) else rel[:, col[0]] * rel[:, col[1]]
        moments[:n_cells, c] = np.bincount(point_cell, weights, n_cells)
    # As one sparse product (27 ones a row; "no neighbour" picks the row of zeros): a
    # single pass in C instead of 27 gathers of the whole table.
    columns_of = np.where(neighbour >= 0, neighbour, n_cells).ravel(order="C")
    adjacency = csr_matrix(
        (np.ones(len(columns_of)), columns_of, np.arange(0, len(columns_of) + 1, 27)), shape=(n_cells, n_cells + 1)
    )
    block = adjacency @ moments
    count, n_b = moments[:n_cells, 0], block[:, 0]
    mean = block[:, 1:4] / n_b[:, None]
    cov = np.empty((n_cells, 3, 3))
    for c, col in enumerate(columns[4:], start=4):
        a, b = col
        cov[:, a, b] = cov[:, b, a] = block[:, c] / n_b - mean[:, a] * mean[:, b]
    centre = points.mean(axis=0)
    own = moments[:n_cells, 1:4] / count[:, None] + centre
    values, normal = smallest_eigenpair(cov)
    return CellPlanes(
        edge=float(edge),
        point_cell=point_cell,
        corner=corner,
        count=count,
        centroid=own,
        normal=normal,
        block_centroid=centre + mean,
        variation=values[:, 0] / np.maximum(values.sum(axis=1), 1e-300),
        residual=np.sqrt(values[:, 0]),
        defined=(n_b >= MIN_BLOCK_POINTS) & (values[:, 1] >= MIN_SPREAD_RATIO * values[:, 2]),
        neighbour=neighbour,
    )


def smallest_eigenpair(cov: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues (n, 3), ascending and clipped at 0, and the unit eigenvector of the
    smallest, of symmetric 3 x 3 matrices (n, 3, 3), in closed form.

    The trigonometric solution of the characteristic cubic (Smith 1961), then the vector
    orthogonal to two rows of ``cov - lambda_0 I`` (the pair whose cross product is
    longest): 15 times faster than ``numpy.linalg.eigh`` on many small matrices, which
    calls LAPACK once per matrix. Where lambda_0 = lambda_1 the vector is any one of their
    plane, as with ``eigh``.

    Examples
    --------
    >>> a = np.diag([3.0, 1.0, 2.0])[None]
    >>> values, vector = smallest_eigenpair(a)
    >>> values.round(6).tolist(), np.abs(vector).round(6).tolist()
    ([[1.0, 2.0, 3.0]], [[0.0, 1.0, 0.0]])
    """
    a = np.asarray(cov, dtype=np.float64)
    xx, yy, zz, xy, xz, yz = a[:, 0, 0], a[:, 1, 1], a[:, 2, 2], a[:, 0, 1], a[:, 0, 2], a[:, 1, 2]
    q = (xx + yy + zz) / 3.0
    dx, dy, dz = xx - q, yy - q, zz - q
    off = xy**2 + xz**2 + yz**2
    p = np.sqrt((dx**2 + dy**2 + dz**2 + 2.0 * off) / 6.0)
    safe = np.where(p > 0, p, 1.0)
    det = dx * (dy * dz - yz**2) - xy * (xy * dz - yz * xz) + xz * (xy * yz - dy * xz)
    r = np.clip(det / safe**3 / 2.0, -1.0, 1.0)
    phi = np.arccos(r) / 3.0
    largest = q + 2.0 * p * np.cos(phi)
    smallest = q + 2.0 * p * np.cos(phi + 2.0 * np.pi / 3.0)
    middle = 3.0 * q - largest - smallest
    values = np.maximum(np.stack([smallest, middle, largest], axis=1), 0.0)
    # Rows of cov - lambda_0 I and their three cross products, component by component.
    ax, by, cz = xx - smallest, yy - smallest, zz - smallest
    rows = ((ax, xy, xz), (xy, by, yz), (xz, yz, cz))
    crosses = []
    for i, j in ((0, 1), (0, 2), (1, 2)):
        (u0, u1, u2), (v0, v1, v2) = rows[i], rows[j]
        crosses.append(np.stack([u1 * v2 - u2 * v1, u2 * v0 - u0 * v2, u0 * v1 - u1 * v0], axis=1))
    crosses = np.stack(crosses, axis=1)
    norms = np.einsum("nij,nij->ni", crosses, crosses)
    best = norms.argmax(axis=1)
    index = np.arange(len(a))
    length = np.sqrt(norms[index, best])
    vector = crosses[index, best] / np.where(length > 0, length, 1.0)[:, None]
    vector[length == 0] = (0.0, 0.0, 1.0)  # a multiple of the identity (or zero): any direction
    return values, vector


def neighbour_pairs(cells: CellPlanes) -> tuple[np.ndarray, np.ndarray]:
    """Every pair of touching cells (26-connected) whose planes are defined, each pair once."""
    source = np.repeat(np.arange(len(cells)), len(FORWARD))
    target = cells.neighbour[:, FORWARD].ravel()
    ok = (target >= 0) & cells.defined[source]
    ok[ok] &= cells.defined[target[ok]]
    return source[ok], target[ok]


def far_scatter(cells: CellPlanes) -> float:
    """Median angle (degrees) between a cell's normal and that of the cell two steps along
    each axis: how much the local planes wander over about a block's width."""
    angles = []
    for axis_offset in (CENTRE + 9, CENTRE + 3, CENTRE + 1):  # +x, +y, +z
        one = cells.neighbour[:, axis_offset]
        two = np.where(one >= 0, cells.neighbour[np.maximum(one, 0), axis_offset], -1)
        ok = (two >= 0) & cells.defined
        ok[ok] &= cells.defined[two[ok]]
        cosine = np.abs(np.einsum("ij,ij->i", cells.normal[ok], cells.normal[two[ok]]))
        angles.append(np.arccos(np.clip(cosine, 0.0, 1.0)))
    angles = np.concatenate(angles)
    return float(np.degrees(np.median(angles))) if len(angles) else 0.0
