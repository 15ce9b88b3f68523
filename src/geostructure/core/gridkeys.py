"""Integer grid keys and grouping, the bookkeeping under every grid of this package: a
coordinate's cell index without a temporary the cloud's size, ``np.unique`` of integer codes
without the sort where their space allows, a stable order of labels, and sums by bin.

The voxel fit (:mod:`.voxel`), the facet detector's cells (:mod:`.cells`), the hash-drawn
samples (:mod:`.sampling`) and the streamed passes all group points by these.
"""

from __future__ import annotations

import math
from functools import partial

import numpy as np

from geostructure.core.bounds import column_max
from geostructure.core.threads import MIN_ROWS_PER_THREAD, run_blocks, run_tasks, task_workers
from geostructure.errors import ParameterError

#: Index pairs of the 6 distinct entries of a symmetric 3x3 matrix.
_I, _J = np.triu_indices(3)


def floor_index(column: np.ndarray, lower: float, edge: float, out: np.ndarray, scratch: np.ndarray, shift=0.0):
    """``floor((column - lower) / edge + shift)`` into ``out`` (an integer row), as
    ``astype(np.int64)`` gives it, through ``scratch`` (a float64 row of the same length):
    one coordinate's grid index with no temporary the cloud's length, its rows split over
    the cores (:func:`~geostructure.core.threads.run_blocks`)."""

    run_blocks(lambda rows: floor_rows(column[rows], lower, edge, out[rows], scratch[rows], shift),
               len(column), min_rows=4 * MIN_ROWS_PER_THREAD)  # fmt: skip
    return out


def floor_rows(column: np.ndarray, lower: float, edge: float, out: np.ndarray, scratch: np.ndarray, shift=0.0):
    """:func:`floor_index` in the calling thread (for work already split over the cores)."""
    np.subtract(column, lower, out=scratch)
    scratch /= edge
    if shift:
        scratch += shift
    np.copyto(out, np.floor(scratch, out=scratch), casting="unsafe")
    return out


#: Codes below this many per point are grouped by a table over the whole code space
#: (:func:`group_codes`), 8 bytes a code.
DENSE_CODES_PER_POINT = 4


def group_codes(codes: np.ndarray, n_codes: int, minor: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """``np.unique(codes, return_inverse=True)`` for integer codes in [0, ``n_codes``).

    Where the code space is small against the number of codes (coarse voxels), a count
    table over it does in one pass what the sort does in several: at 8M points the
    sort took 1.2 s a grid. Where it is not, but codes pack a major and a minor part
    (``major * minor + minor part``: a grid key's x-y column and its z) and the majors'
    space is small, two tables do it (:func:`_group_by_major`). The result is the same,
    sorted codes and all.

    Examples
    --------
    >>> unique, inverse = group_codes(np.array([5, 2, 5, 0]), 6)
    >>> unique.tolist(), inverse.tolist()
    ([0, 2, 5], [2, 1, 2, 0])
    >>> codes = np.array([9_000_017, 17, 9_000_017, 4_000_003])
    >>> unique, inverse = group_codes(codes, 10**7, minor=1000)
    >>> unique.tolist(), inverse.tolist()
    ([17, 4000003, 9000017], [2, 0, 2, 1])
    """
    codes = np.asarray(codes, dtype=np.int64)
    dense = DENSE_CODES_PER_POINT * max(len(codes), 1) + 1024
    if n_codes > dense and minor > 1 and -(-n_codes // minor) <= dense:
        return _group_by_major(codes, n_codes, minor)
    if n_codes > dense:
        unique, inverse = np.unique(codes, return_inverse=True)
        return unique, inverse.ravel()
    occupied = np.zeros(n_codes, dtype=bool)  # a byte a code, not a count's eight
    occupied[codes] = True
    unique = np.flatnonzero(occupied)
    # The running count in 32 bits where it fits: at 40M codes the 64-bit cumsum took 1.2 s
    # and this one 0.2 s (half the table's pages, and no wider casting on the way).
    rank = np.cumsum(occupied, dtype=np.int32 if len(unique) < 2**31 else np.int64)
    inverse = rank[codes].astype(np.int64)
    inverse -= 1
    return unique, inverse


def _group_by_major(codes: np.ndarray, n_codes: int, minor: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`group_codes` of codes too sparse for one table, whose major parts (``codes //
    minor``, a grid's x-y columns) fit one. The occupied majors are ranked in a table; then
    each code is renumbered by its place within its major's own range of minor parts
    (from its least to its greatest, one range after another, in order). On a surface
    those ranges hold little more than its cells, so a second table groups them: at 8M
    points this replaced a sort of the codes. The renumbering keeps the codes' order, so
    the result is :func:`numpy.unique`'s."""
    major, low = np.divmod(codes, minor)
    major_codes, column = group_codes(major, -(-n_codes // minor))
    del major
    least = np.full(len(major_codes), minor, dtype=np.int64)
    greatest = np.full(len(major_codes), -1, dtype=np.int64)
    np.minimum.at(least, column, low)
    np.maximum.at(greatest, column, low)
    width = greatest - least + 1
    start = np.cumsum(width) - width
    low -= least[column]
    low += start[column]
    renumbered, inverse = group_codes(low, int(width.sum()))
    del low
    # Back to the codes: each renumbered code's column, and its place in that column's range.
    of = np.searchsorted(start, renumbered, side="right") - 1
    return major_codes[of] * minor + least[of] + (renumbered - start[of]), inverse


def label_order(labels: np.ndarray) -> np.ndarray:
    """``np.argsort(labels, kind="stable")`` for labels from -1 up: as 16-bit integers where
    they fit, which numpy sorts by radix in one pass (ten times as fast at 0.7M points).

    Examples
    --------
    >>> label_order(np.array([2, -1, 0, 2, 0])).tolist()
    [1, 2, 4, 0, 3]
    """
    labels = np.asarray(labels)
    if len(labels) and labels.min() >= -1 and labels.max() < 2**15:
        return np.argsort(labels.astype(np.int16), kind="stable")
    return np.argsort(labels, kind="stable")


def unique_keys(keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unique rows of an (N, 3) integer key array and the inverse map, via one int64 code
    per row (a 1-D unique is several times faster than ``np.unique(axis=0)``)."""
    return unique_key_rows(np.asarray(keys).T)


def unique_key_rows(key: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`unique_keys` of keys given as three rows (3, N), with one array for the codes."""
    low = key.min(axis=1)
    span = key.max(axis=1) - low + 1
    codes = np.subtract(key[0], low[0])
    for a in (1, 2):
        codes *= span[a]
        codes += key[a]
        codes -= low[a]
    unique_codes, inverse = group_codes(codes, math.prod(int(d) for d in span), minor=int(span[2]))
    kz = unique_codes % span[2]
    ky = (unique_codes // span[2]) % span[1]
    kx = unique_codes // (span[1] * span[2])
    return np.column_stack([kx, ky, kz]) + low, inverse


def binned_sums(rel: np.ndarray, inverse: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The sums (n, 3) of coordinates ``rel`` (3, N) in each of ``n`` bins (``inverse``,
    (N,)), and the sums (n, 6) of their products xx, xy, xz, yy, yz, zz.

    The coordinates come as rows, which ``bincount`` takes without a copy, and one buffer
    holds each product in turn: every fresh array the size of a large cloud costs the first
    touch of each of its pages (about 0.1 s per 64 MB on a 2-core machine), more than the
    sum itself.

    Examples
    --------
    >>> sums, products = binned_sums(np.array([[1.0, 2.0, 3.0], [0, 1, 0], [2, 0, 0]]), np.array([0, 0, 1]), 2)
    >>> sums.tolist(), products[:, 0].tolist(), products[:, 1].tolist()
    ([[3.0, 1.0, 2.0], [3.0, 0.0, 0.0]], [5.0, 9.0], [2.0, 0.0])
    """
    sums, products = np.empty((n, 3)), np.empty((n, 6))
    columns = [(sums, a, a, None) for a in range(3)] + [(products, c, i, j) for c, (i, j) in enumerate(zip(_I, _J))]
    # Each column's sum whole, in one thread (so the same bits in any split); a thread's
    # columns share one product buffer.
    workers = task_workers(rel.shape[1], at_most=3)

    def sum_columns(share: list) -> None:
        product = None
        for out, c, i, j in share:
            if j is None:
                out[:, c] = np.bincount(inverse, rel[i], n)
                continue
            product = np.empty(rel.shape[1]) if product is None else product
            out[:, c] = np.bincount(inverse, np.multiply(rel[i], rel[j], out=product), n)

    run_tasks([partial(sum_columns, columns[k::workers]) for k in range(workers)], workers=workers)
    return sums, products


#: Voxels along one axis at most: three such indices pack into one int64 code (unique_keys).
MAX_CELLS_PER_AXIS = 2**20


def voxel_keys(points: np.ndarray, edge: float, origin: np.ndarray) -> np.ndarray:
    """Integer voxel index (i, j, k) of every point."""
    check_voxel_count(points, edge, origin)
    return np.floor((points - origin) / edge).astype(np.int64)


def check_voxel_count(points: np.ndarray, edge: float, origin: np.ndarray) -> None:
    """Refuse an edge that makes more than :data:`MAX_CELLS_PER_AXIS` voxels along an axis."""
    if len(points):
        cells = float(np.max(column_max(points) - np.asarray(origin, float))) / edge if edge > 0 else np.inf
        if not cells <= MAX_CELLS_PER_AXIS:
            raise ParameterError(
                f"a voxel edge of {edge:.3g} is too small for a cloud this size (more than "
                f"{MAX_CELLS_PER_AXIS:,} voxels along an axis); take a larger zeta."
            )
