"""Samples of a cloud that do not depend on the order of its points.

A survey read as tiles, or a file written by another program, holds the same points in
another order. A sample drawn by index (``rng.choice``) would then be another sample, and
the parameters read from it (the point spacing, the voxels' occupancy) would move a little,
enough to change which small facets are found. Here each point is drawn by a hash of its
own coordinates, so the same points give the same sample in any order.
"""

from __future__ import annotations

import numpy as np

_MULTIPLIERS = (np.uint64(0x9E3779B97F4A7C15), np.uint64(0xC2B2AE3D27D4EB4F), np.uint64(0x165667B19E3779F9))


def coordinate_hash(points: np.ndarray, seed: int = 0) -> np.ndarray:
    """A 64-bit hash (N,) of each point's float64 coordinates (splitmix64's finaliser over
    their bits), the same for the same coordinates wherever the point sits in the array."""
    bits = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3).view(np.uint64)
    with np.errstate(over="ignore"):
        h = np.full(len(bits), np.uint64(seed) * _MULTIPLIERS[2] + _MULTIPLIERS[0], dtype=np.uint64)
        for axis in range(3):
            h ^= bits[:, axis] * _MULTIPLIERS[axis]
            h ^= h >> np.uint64(31)
            h *= _MULTIPLIERS[1]
        h ^= h >> np.uint64(29)
    return h


def order_free_sample(points: np.ndarray, n: int, seed: int = 0) -> np.ndarray:
    """Indices of ``n`` points chosen by their coordinates' hash, in the order of the hash:
    the same points, in the same order, however the cloud's rows are arranged.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> points = rng.random((1000, 3))
    >>> shuffled = rng.permutation(1000)
    >>> a = points[order_free_sample(points, 10)]
    >>> b = points[shuffled][order_free_sample(points[shuffled], 10)]
    >>> bool((a == b).all())
    True
    """
    points = np.asarray(points, dtype=np.float64)
    if n >= len(points):
        chosen = np.arange(len(points))
    else:
        h = coordinate_hash(points, seed)
        chosen = np.argpartition(h, n - 1)[:n]
    return chosen[np.argsort(coordinate_hash(points[chosen], seed), kind="stable")]
