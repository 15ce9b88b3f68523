"""Stray points: a point far from every other (a laser's return off a bird, a mistyped row).

One point 100 m below a 2.2 m cut of rock made the cloud's extent fifty times what the rock
spans, and every parameter read from it (the voxel edge is a fraction of the extent, the
grids an eighth of it) measured 15 planes where the clean cut gives 20. The cloud's own
spacing, read on a sample, does not move with one point; a stray is told by it: a point
with fewer than :data:`MIN_NEIGHBOURS` others within :data:`STRAY_RADIUS_SPACINGS` spacings.

Only the points outside the box that holds all but :data:`TAIL_SHARE` of the cloud along
each axis can be strays that move the extent, so only those are looked at: a cloud without
any costs a partition per axis.
"""

from __future__ import annotations

import numpy as np

#: A stray has no more than this many other points within :data:`STRAY_RADIUS_SPACINGS`.
MIN_NEIGHBOURS = 2
#: How far (in point spacings) a stray lies from the rest: a hundred spacings is a gap no
#: scan or reconstruction leaves inside one surface.
STRAY_RADIUS_SPACINGS = 100.0
#: The share of the points beyond each face of the box that the search starts from.
TAIL_SHARE = 0.001


def stray_points(points: np.ndarray, spacing: float) -> np.ndarray:
    """Which of ``points`` (N, 3) are strays, as a boolean mask: points beyond the box of all
    but the cloud's tails, with at most :data:`MIN_NEIGHBOURS` other points within
    :data:`STRAY_RADIUS_SPACINGS` times ``spacing`` (the cloud's point spacing).

    Examples
    --------
    >>> g = np.mgrid[0:5:0.05, 0:5:0.05].reshape(2, -1).T
    >>> rock = np.c_[g, 0.01 * g[:, 0]]
    >>> cloud = np.vstack([rock, [[2.0, 2.0, -100.0], [2.5, 2.5, 1e4]]])
    >>> np.flatnonzero(stray_points(cloud, 0.05)).tolist()
    [10000, 10001]
    >>> stray_points(rock, 0.05).any()  # the rock's own edges are no strays
    np.False_
    """
    p = np.asarray(points, dtype=np.float64)
    n = len(p)
    strays = np.zeros(n, dtype=bool)
    if n < 10 or not spacing > 0:
        return strays
    radius = STRAY_RADIUS_SPACINGS * spacing
    tail = max(1, int(TAIL_SHARE * n))
    low = np.array([np.partition(p[:, a], tail)[tail] for a in range(3)])
    high = np.array([np.partition(p[:, a], n - 1 - tail)[n - 1 - tail] for a in range(3)])
    outside = np.any((p < low) | (p > high), axis=1)  # the tails, where a stray can be
    far = np.any((p < low - radius) | (p > high + radius), axis=1)
    if not far.any():
        return strays
    from scipy.spatial import cKDTree  # lazy: most clouds have no far point

    # A far point's neighbours within the radius lie outside the box too.
    tails = np.flatnonzero(outside)
    candidates = np.flatnonzero(far)
    counts = cKDTree(p[tails]).query_ball_point(p[candidates], radius, return_length=True)
    strays[candidates[counts - 1 <= MIN_NEIGHBOURS]] = True
    return strays
