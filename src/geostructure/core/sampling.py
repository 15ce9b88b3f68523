"""Samples of a cloud that do not depend on the order of its points.

A survey read as tiles, or a file written by another program, holds the same points in
another order. A sample drawn by index (``rng.choice``) would then be another sample, and
the parameters read from it (the point spacing, the voxels' occupancy) would move a little,
enough to change which small facets are found. Here each point is drawn by a hash of its
position, so the same points give the same sample in any order, and about any offset.
"""

from __future__ import annotations

import numpy as np

from geostructure.core.bounds import column_max, column_min
from geostructure.core.gridkeys import floor_rows
from geostructure.core.threads import MIN_ROWS_PER_THREAD, run_blocks

_MULTIPLIERS = (np.uint64(0x9E3779B97F4A7C15), np.uint64(0xC2B2AE3D27D4EB4F), np.uint64(0x165667B19E3779F9))


#: Coordinates are hashed on a grid this many steps across the cloud (rounded to a power of
#: two in the cloud's units): fine enough that two points of a cloud seldom share a step,
#: coarse enough that rounding noise does not move a point to the next one when the cloud
#: is moved to UTM coordinates or read about another offset (about 1e-10 m there, against
#: a step of 0.3 mm on a 20 m face).
HASH_STEPS = 2**16


def coordinate_hash(points: np.ndarray, seed: int = 0, *, lower=None, extent: float | None = None) -> np.ndarray:
    """A 64-bit hash (N,) of each point's position on a fine grid anchored at the cloud's
    corner (splitmix64's finaliser over the three integers): the same for the same point
    wherever it sits in the array, and however the cloud is translated. A chunk of a larger
    cloud is hashed as the whole is when given the whole's ``lower`` corner and ``extent``."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if not len(points):
        return np.zeros(0, dtype=np.uint64)
    lower = column_min(points) if lower is None else np.asarray(lower, dtype=np.float64)
    extent = float((column_max(points) - lower).max()) if extent is None else float(extent)
    step = 2.0 ** np.ceil(np.log2(extent / HASH_STEPS)) if extent > 0 else 1.0
    return grid_hash(points, lower, step, seed)


def grid_hash(points: np.ndarray, lower, step: float, seed: int = 0, shift: float = 0.0) -> np.ndarray:
    """:func:`key_hash` of the keys ``floor((points - lower) / step + shift)``, a column at a
    time in three buffers the cloud's length: no (N, 3) keys and no temporaries (every
    fresh array costs the first touch of its pages, 2 s at 8M points on a cold machine).

    Examples
    --------
    >>> p = np.random.default_rng(0).normal(size=(1000, 3))
    >>> keys = np.floor((p - p.min(axis=0)) / 0.1 + 0.5).astype(np.int64)
    >>> bool((grid_hash(p, p.min(axis=0), 0.1, seed=3, shift=0.5) == key_hash(keys, seed=3)).all())
    True
    """
    points, lower = np.asarray(points, dtype=np.float64), np.asarray(lower, dtype=np.float64)
    scaled, key, term = np.empty(len(points)), np.empty(len(points), dtype=np.uint64), np.empty(len(points), np.uint64)
    with np.errstate(over="ignore"):  # the hash wraps by design, its seed's start too (seed 5 and up)
        h = np.full(len(points), np.uint64(seed) * _MULTIPLIERS[2] + _MULTIPLIERS[0], dtype=np.uint64)

    def hash_rows(rows: slice) -> None:  # elementwise: any split of the rows, the same hashes
        hr, kr, tr = h[rows], key[rows], term[rows]
        with np.errstate(over="ignore"):
            for axis in range(3):
                floor_rows(points[rows, axis], lower[axis], step, kr.view(np.int64), scaled[rows], shift)
                hr ^= np.multiply(kr, _MULTIPLIERS[axis], out=tr)
                hr ^= np.right_shift(hr, np.uint64(31), out=tr)
                hr *= _MULTIPLIERS[1]
            hr ^= np.right_shift(hr, np.uint64(29), out=tr)

    run_blocks(hash_rows, len(points), min_rows=4 * MIN_ROWS_PER_THREAD)
    return h


def key_hash(keys: np.ndarray, seed: int = 0) -> np.ndarray:
    """A 64-bit hash (N,) of integer grid keys (N, 3): splitmix64's finaliser over the three.

    Examples
    --------
    >>> h = key_hash(np.array([[0, 0, 0], [0, 0, 1], [0, 0, 0]]))
    >>> bool(h[0] == h[2]), bool(h[0] != h[1])
    (True, True)
    """
    keys = np.ascontiguousarray(keys, dtype=np.int64).view(np.uint64)
    with np.errstate(over="ignore"):
        h = np.full(len(keys), np.uint64(seed) * _MULTIPLIERS[2] + _MULTIPLIERS[0], dtype=np.uint64)
        for axis in range(3):
            h ^= keys[:, axis] * _MULTIPLIERS[axis]
            h ^= h >> np.uint64(31)
            h *= _MULTIPLIERS[1]
        h ^= h >> np.uint64(29)
    return h


def sampled_blocks(points: np.ndarray, lower, edge: float, fraction: float, seed: int = 0, shift: float = 0.0):
    """Which of ``points`` lie in the cubes of ``edge`` (anchored at ``lower``, moved back by
    ``shift`` of a cube) drawn by their key's hash with probability ``fraction``: a spatial
    sample of whole blocks, the same for the same points in any order.

    Examples
    --------
    >>> points = np.random.default_rng(0).random((20_000, 3)) * [100, 100, 1]
    >>> kept = sampled_blocks(points, np.zeros(3), 5.0, 0.25)
    >>> bool(0.1 < kept.mean() < 0.4), bool((sampled_blocks(points[::-1], np.zeros(3), 5.0, 0.25) == kept[::-1]).all())
    (True, True)
    """
    return grid_hash(points, lower, edge, seed, shift) < np.uint64(min(fraction, 1.0 - 2.0**-53) * 2.0**64)


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
    h = coordinate_hash(points, seed)
    chosen = np.arange(len(h)) if n >= len(h) else np.argpartition(h, n - 1)[:n]
    return chosen[np.argsort(h[chosen], kind="stable")]
