"""Convex hulls of many small 2-D point sets at once, for the rectangles of small regions.

Qhull (:func:`~geostructure.detect.rectangle.hull_2d`) spends a quarter of a millisecond setting up each call,
more than the hull of a few hundred points takes: on a rough outcrop's 1,500 facets that
was most of the planes' stage. Here the sets lie one after another in one array
(``starts`` as for :func:`numpy.add.reduceat`) and every step is one numpy operation over
all of them:

1. **Akl-Toussaint** (1978): the points inside the octagon of each set's extremes along u,
   v, u + v and u - v are no hull vertices and are dropped (nearly all of them);
2. **gift wrapping** (Jarvis 1973) of what is left, all sets side by side: from the lowest
   leftmost point, each step takes the point that turns least from the last edge (the
   farthest of points in line, so that, as in Qhull's output, no vertex lies in the middle
   of an edge), until the walk is back at its start.

A set that does not close, or whose hull has under three vertices (its points in line), is
reported with ``closed`` false: its caller measures it the way it measures a large region.
"""

from __future__ import annotations

import numpy as np

#: Two turns closer than this (radians) are taken as points in line.
SAME_TURN = 1e-12
#: Sets wrapped side by side in one block.
WRAP_BLOCK = 128


def segment_argext(values: np.ndarray, segment: np.ndarray, starts: np.ndarray, largest: bool) -> np.ndarray:
    """The index of the first largest (or smallest) of ``values`` in each segment.

    Examples
    --------
    >>> segment_argext(np.array([3.0, 5.0, 5.0, 1.0, 0.0]), np.array([0, 0, 0, 1, 1]), np.array([0, 3, 5]), True)
    array([1, 3])
    """
    reduce = np.maximum if largest else np.minimum
    extreme = reduce.reduceat(values, starts[:-1])
    hit = np.flatnonzero(values == extreme[segment])
    return hit[np.r_[True, segment[hit][1:] != segment[hit][:-1]]]


def outside_octagons(uv: np.ndarray, segment: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """Which points lie on or outside their segment's octagon of extremes (the hull's only
    candidates); a segment with under three distinct extremes keeps all its points."""
    u, v = uv[:, 0], uv[:, 1]
    s, d = u + v, u - v
    # Counter-clockwise: east, north-east, north, north-west, west, south-west, south, south-east.
    order = [(u, True), (s, True), (v, True), (d, False), (u, False), (s, False), (v, False), (d, True)]
    corners = np.stack([segment_argext(x, segment, starts, top) for x, top in order], axis=1)  # (R, 8)
    poly = uv[corners]
    edge = np.roll(poly, -1, axis=1) - poly
    real = (edge != 0).any(axis=2)  # a corner repeated is no edge
    extent = np.maximum(np.ptp(poly[..., 0], axis=1), np.ptp(poly[..., 1], axis=1))
    tolerance = 1e-12 * extent**2  # a point within rounding of an edge is kept
    # Each edge as a line: side = a u + b v + c, at most 0 on or outside it; c infinite
    # for no edge. Repeated over the points, not gathered: a segment's points are contiguous.
    line = np.stack([-edge[..., 1], edge[..., 0], edge[..., 1] * poly[..., 0] - edge[..., 0] * poly[..., 1]], axis=2)
    line[..., 2] = np.where(real, line[..., 2] - tolerance[:, None], np.inf)
    sizes = np.diff(starts)
    keep = np.zeros(len(uv), dtype=bool)
    side = np.empty(len(uv))
    for k in range(8):
        a, b, c = (np.repeat(np.ascontiguousarray(line[:, k, j]), sizes) for j in range(3))
        np.multiply(a, u, out=side)
        side += b * v
        side += c
        keep |= side <= 0.0
    keep[corners.ravel()] = True
    keep |= np.repeat(real.sum(axis=1) < 3, sizes)
    return keep


def segment_hulls(uv: np.ndarray, starts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The convex hull of each segment of 2-D points ``uv``, counter-clockwise.

    Returns
    -------
    hulls : (R, H, 2) array
        Each segment's hull vertices, the rows after its last filled with its first vertex.
    n_vertices : (R,) int array
    closed : (R,) bool array
        False where the hull is degenerate or the walk did not close.

    Examples
    --------
    >>> square = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0.5], [0.5, 0]], dtype=float)
    >>> triangle = np.array([[0, 0], [2, 0], [0, 2], [0.5, 0.5]], dtype=float)
    >>> hulls, n, closed = segment_hulls(np.vstack([square, triangle]), np.array([0, 6, 10]))
    >>> n.tolist(), closed.tolist(), hulls[1, :3].tolist()
    ([4, 3], [True, True], [[0.0, 0.0], [2.0, 0.0], [0.0, 2.0]])
    """
    uv = np.asarray(uv, dtype=np.float64)
    n_sets = len(starts) - 1
    segment = np.repeat(np.arange(n_sets), np.diff(starts))
    kept = np.flatnonzero(outside_octagons(uv, segment, starts))
    owner = segment[kept]
    count = np.bincount(owner, minlength=n_sets)
    # Side by side in blocks of like counts, each padded to its own largest: one set of 300
    # candidates would otherwise widen every other set's rows to 300.
    by_count = np.argsort(count, kind="stable")
    hulls = np.zeros((n_sets, int(count.max(initial=1)) + 1, 2))
    n_vertices = np.zeros(n_sets, dtype=np.int64)
    closed = np.zeros(n_sets, dtype=bool)
    offsets = np.cumsum(count) - count
    for first in range(0, n_sets, WRAP_BLOCK):
        rows = by_count[first : first + WRAP_BLOCK]
        width = int(count[rows].max(initial=1))
        pts = np.zeros((len(rows), width, 2))
        valid = np.arange(width)[None, :] < count[rows][:, None]
        taken = offsets[rows][:, None] + np.minimum(np.arange(width)[None, :], count[rows][:, None] - 1)
        pts[:] = uv[kept[taken]]
        h, n_vertices[rows], closed[rows] = _wrap(pts, valid)
        hulls[rows, : h.shape[1]] = h
        hulls[rows, h.shape[1] :] = h[:, :1]
    widest = int(n_vertices.max(initial=1))
    return hulls[:, :widest], n_vertices, closed


def _wrap(pts: np.ndarray, valid: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Gift wrapping of padded rows of points (``valid`` marks the real ones)."""
    n_sets, width = valid.shape
    # The start: the leftmost point, the lowest of those; a hull vertex whatever the rounding.
    u = np.where(valid, pts[..., 0], np.inf)
    leftmost = valid & (u == u.min(axis=1)[:, None])
    start = np.where(leftmost, pts[..., 1], np.inf).argmin(axis=1)
    order = np.zeros((n_sets, width + 1), dtype=np.int64)
    order[:, 0] = start
    # Where each point came in the walk (-1: not yet): a walk closes on the point it meets
    # again, the start, or the next vertex where rounding put the start mid-edge.
    place = np.full((n_sets, width), -1, dtype=np.int64)
    place[np.arange(n_sets), start] = 0
    first = np.zeros(n_sets, dtype=np.int64)
    n_vertices = np.ones(n_sets, dtype=np.int64)
    closed = np.zeros(n_sets, dtype=bool)
    current, heading = start.copy(), np.full(n_sets, -np.pi / 2)
    live = np.arange(n_sets)
    for _ in range(width):
        if not len(live):
            break
        d = pts[live] - pts[live, current[live]][:, None, :]
        dist2 = (d * d).sum(axis=2)
        angle = np.arctan2(d[..., 1], d[..., 0])
        turn = np.mod(angle - heading[live][:, None], 2 * np.pi)
        turn[turn > 2 * np.pi - SAME_TURN] = 0.0  # in line ahead, a rounding behind
        turn = np.where(valid[live] & (dist2 > 0), turn, np.inf)
        least = turn.min(axis=1)
        step = np.where(turn <= least[:, None] + SAME_TURN, dist2, -1.0).argmax(axis=1)
        rows = np.arange(len(live))
        seen = place[live, step]
        back = (seen >= 0) | ~np.isfinite(least)
        closed[live[back]] = np.isfinite(least[back])
        first[live[back]] = np.maximum(seen[back], 0)
        go, step = live[~back], step[~back]
        order[go, n_vertices[go]] = step
        place[go, step] = n_vertices[go]
        n_vertices[go] += 1
        current[go], heading[go] = step, angle[rows[~back], step]
        live = go
    n_vertices -= first
    closed &= n_vertices >= 3
    h = int(n_vertices.max(initial=1))
    filled = np.arange(h)[None, :] < n_vertices[:, None]
    taken = np.take_along_axis(order, np.minimum(first[:, None] + np.arange(h)[None, :], width), axis=1)
    index = np.where(filled, taken, order[np.arange(n_sets), first][:, None])
    return pts[np.arange(n_sets)[:, None], index], n_vertices, closed
