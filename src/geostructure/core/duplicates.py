"""Points written more than once: a scan merged twice, tiles that overlap, a cloud exported
into itself.

A copy is a point whose three coordinates are, bit for bit, another's. Copies are not more
rock: they doubled the weight of every voxel and cell they fell in, so the point spacing
read short (by sqrt 2 for a cloud written twice), the facet detector's grid came out too fine
for its points, and a flat 5 m square written twice came out as 1,937 planes instead of one.
Points a coarse coordinate step rounded onto one spot (a drone LAZ stored to 1 cm at 6 mm
spacing) are copies too: they say no more of the surface than one of them, and counted as
many they made each plane's standard error too small. The readers keep the first of each
point (:func:`without_copies`) and record how many they left out; the measurement is then
the distinct points'.

Finding them costs a sort, which a cloud without copies should not pay: :func:`has_copies`
first looks among the points whose x coordinate falls in a hash-drawn 1/256 of the values
(copies share their x, so a copy and its original are drawn together), which takes a few
numpy passes over one column.
"""

from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np

from geostructure.core.sampling import key_hash
from geostructure.errors import GeoStructureError, GeoStructureNote

#: Below this many points :func:`has_copies` looks at them all; above, at a drawn share.
ALL_POINTS_BELOW = 200_000
#: The share of x values :func:`has_copies` draws on a larger cloud: 1 in 2**DRAWN_BITS.
DRAWN_BITS = 8
#: An odd 64-bit multiplier (splitmix64's), whose top bits mix all of a value's bits.
_MIX = np.uint64(0x9E3779B97F4A7C15)


def has_copies(points: np.ndarray) -> bool:
    """Whether any point of ``points`` (N, 3) repeats another exactly, looked for on all of
    them below :data:`ALL_POINTS_BELOW` and on those whose x value is drawn above: a cloud
    with copies here and there may pass, one merged twice never does.

    Examples
    --------
    >>> points = np.random.default_rng(0).random((500_000, 3))
    >>> has_copies(points), has_copies(np.vstack([points, points[:100_000]]))
    (False, True)
    """
    points = np.ascontiguousarray(points, dtype=np.float64)  # rows viewed as 24-byte records
    if len(points) >= ALL_POINTS_BELOW:
        bits = np.ascontiguousarray(points[:, 0]).view(np.uint64)
        with np.errstate(over="ignore"):
            drawn = (bits * _MIX) >> np.uint64(64 - DRAWN_BITS) == 0
        points = points[drawn]
    return bool(len(points)) and len(np.unique(points.view(np.dtype((np.void, 24))).ravel())) < len(points)


def first_of_each(points: np.ndarray) -> np.ndarray:
    """A mask (N,) of the first of each distinct point of ``points`` (N, 3), in their order:
    False for a point that repeats, bit for bit, one before it.

    Examples
    --------
    >>> first_of_each(np.array([[0.0, 0, 0], [1, 0, 0], [0, 0, 0], [1, 0, 0], [2, 0, 0]])).tolist()
    [True, True, False, False, True]
    """
    points = np.ascontiguousarray(points, dtype=np.float64)
    order = np.argsort(key_hash(points.view(np.int64)), kind="stable")  # a point's copies after it
    rows = points[order].view(np.dtype((np.void, 24))).ravel()
    # Equal rows are neighbours in this order unless two different points share a hash
    # (a chance of about 1 in 500,000 at 8M points), which would leave a copy in, never drop
    # a point.
    repeats = np.r_[False, rows[1:] == rows[:-1]]
    first = np.ones(len(points), dtype=bool)
    first[order[repeats]] = False
    return first


def without_copies(cloud, source=None):
    """``cloud`` without the copies of its points (:func:`first_of_each`), their number
    added to its ``left_out`` record as ``copies`` and said in a note; the cloud itself
    when it has none."""
    if not has_copies(cloud.local):
        return cloud
    name = source or cloud.source
    first = first_of_each(cloud.local)
    n_distinct = int(np.count_nonzero(first))
    n_copies = len(first) - n_distinct  # at least the one has_copies found
    if n_distinct == 1:
        raise GeoStructureError(f"{name}: all points lie at one spot; there is no plane to measure.")
    if n_distinct < 3:
        raise GeoStructureError(
            f"{name}: its {len(first):,} points are copies of {n_distinct} distinct points; a plane needs at least 3."
        )
    warnings.warn(
        f"{name}: {n_copies:,} point(s) repeat others exactly (copies from a scan merged twice or tiles that "
        f"overlap, or points rounded onto one spot by the file's coordinate step); each spot was measured once.",
        GeoStructureNote,
        stacklevel=2,
    )
    left_out = {**(cloud.left_out or {}), "copies": (cloud.left_out or {}).get("copies", 0) + n_copies}
    return replace(cloud.subset(first), left_out=left_out)
