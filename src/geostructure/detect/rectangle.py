"""Region plane: the ideal plane and its minimum-perimeter bounding rectangle.

The ideal plane passes through the region's centroid with the normal of a least-squares
fit to all the region's points. The points move to region space (u, v, n), and the
rectangle is the one of smallest perimeter among those obtained by rotating (u, v) about n.

Two ways to find it:

- ``golden``: the paper's golden-section search over the rotation angle, each candidate
  axis pair built with the Rodrigues formula. The perimeter is not unimodal in the angle,
  so a plain golden-section search can stop in a local minimum; here a coarse scan first
  brackets the best valley and the golden-section search refines inside it.
- ``exact``: rotating calipers. A minimum-perimeter enclosing rectangle has a side on an
  edge of the convex hull, so trying every hull edge gives the true minimum.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from geostructure.core import params
from geostructure.core.hulls import segment_hulls

GOLDEN = (np.sqrt(5.0) - 1.0) / 2.0
METHODS = params.RECTANGLE_METHODS


@dataclass
class RegionPlane:
    """A bounded region plane in the cloud's local coordinates."""

    centroid: np.ndarray
    normal: np.ndarray
    u: np.ndarray
    v: np.ndarray
    width: float
    height: float
    center: np.ndarray
    residual: float
    area: float
    n_points: int

    @property
    def perimeter(self) -> float:
        return 2.0 * (self.width + self.height)

    @property
    def corners(self) -> np.ndarray:
        """(4, 3) corners of the rectangle, counter-clockwise seen from the normal."""
        hu, hv = self.u * self.width / 2, self.v * self.height / 2
        return self.center + np.array([-hu - hv, hu - hv, hu + hv, -hu + hv])


def rodrigues(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation matrix about a unit ``axis`` by ``angle`` radians (Rodrigues' formula).

    Examples
    --------
    >>> r = rodrigues(np.array([0.0, 0.0, 1.0]), np.pi / 2)
    >>> np.round(r @ [1.0, 0.0, 0.0], 12).tolist()
    [0.0, 1.0, 0.0]
    """
    x, y, z = axis
    k = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return np.eye(3) + np.sin(angle) * k + (1.0 - np.cos(angle)) * (k @ k)


def fit_plane(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Centroid, unit normal, in-plane axes (2, 3) and RMS residual of a least-squares plane."""
    return _centred_fit(points)[:4]


def _centred_fit(points: np.ndarray):
    """:func:`fit_plane`'s four and the centred points, which :func:`region_plane` projects:
    one (N, 3) temporary instead of two (at 8M points the largest regions hold millions)."""
    centroid = points.mean(axis=0)
    centred = points - centroid
    values, vectors = np.linalg.eigh(centred.T @ centred / len(points))
    residual = float(np.sqrt(max(values[0], 0.0)))
    normal, u = vectors[:, 0], vectors[:, 2]
    # (u, v, n) right-handed, so a Rodrigues turn by phi about n is a 2-D turn by +phi.
    return centroid, normal, in_plane_axes(normal, u), residual, centred


def in_plane_axes(normal: np.ndarray, u: np.ndarray) -> np.ndarray:
    """(2, 3): ``u`` and ``normal x u``, the cross product written out (``np.cross`` on two
    3-vectors costs more than the rest of a small region's fit; the same products).

    Examples
    --------
    >>> in_plane_axes(np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0])).tolist()
    [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
    """
    (a0, a1, a2), (b0, b1, b2) = normal, u
    return np.array([[b0, b1, b2], [a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0]], dtype=np.float64)


#: Above this many points, :func:`hull_2d` first drops those inside the octagon of the
#: extremes in eight directions (Akl & Toussaint 1978): no such point is a hull vertex, and
#: on a large plane nearly all of them are, so Qhull reads a few thousand instead of millions.
OCTAGON_POINTS = 2000


def hull_2d(uv: np.ndarray) -> np.ndarray:
    """Convex-hull vertices of 2-D points, in order (the two ends of points in a line).

    Examples
    --------
    >>> g = np.mgrid[0:1:100j, 0:1:100j].reshape(2, -1).T  # 10,000 points, a unit square
    >>> sorted(map(tuple, hull_2d(g).round(6).tolist()))
    [(0.0, 0.0), (0.0, 1.0), (1.0, 0.0), (1.0, 1.0)]
    """
    uv = np.asarray(uv, dtype=np.float64)
    if len(uv) > OCTAGON_POINTS:
        uv = uv[outside_octagon(uv)]
    try:
        return uv[ConvexHull(uv).vertices]
    except (QhullError, ValueError):  # in a line, or one point: the hull is the segment's ends
        if len(uv) < 2:
            return uv
        along = uv - uv[0]
        t = along @ along[np.argmax(np.einsum("ij,ij->i", along, along))]
        return uv[[t.argmin(), t.argmax()]]


def outside_octagon(uv: np.ndarray) -> np.ndarray:
    """Which of 2-D points ``uv`` lie on or outside the octagon of their extremes along u, v,
    u + v and u - v (all of them where it is degenerate): the only candidates for the hull."""
    u, v = uv[:, 0], uv[:, 1]
    s, d = u + v, u - v
    # Counter-clockwise: east, north-east, north, north-west, west, south-west, south, south-east.
    corners = [u.argmax(), s.argmax(), v.argmax(), d.argmin(), u.argmin(), s.argmin(), v.argmin(), d.argmax()]
    corners = [c for i, c in enumerate(corners) if c != corners[i - 1]]  # cyclic: no zero-length edge
    if len(set(corners)) < 3:
        return np.ones(len(uv), dtype=bool)
    poly = uv[corners]
    # A point within rounding of an edge is kept: the tolerance is far below any extent.
    tolerance = 1e-12 * float(max(np.ptp(u), np.ptp(v))) ** 2
    keep = np.zeros(len(uv), dtype=bool)
    for a, b in zip(poly, np.roll(poly, -1, axis=0)):
        keep |= (b[0] - a[0]) * (v - a[1]) - (b[1] - a[1]) * (u - a[0]) <= tolerance
    keep[corners] = True
    return keep


def bounding_perimeter(uv: np.ndarray, angle: float) -> float:
    """Perimeter of the (u, v) bounding box after rotating the axes by ``angle``."""
    c, s = np.cos(angle), np.sin(angle)
    a = uv @ np.array([c, s])
    b = uv @ np.array([-s, c])
    return 2.0 * (np.ptp(a) + np.ptp(b))


def exact_angle(hull: np.ndarray) -> float:
    """Rotation angle of the minimum-perimeter rectangle: one side lies on a hull edge."""
    return float(exact_angles(np.asarray(hull, dtype=np.float64)[None])[0])


def exact_angles(hulls: np.ndarray) -> np.ndarray:
    """:func:`exact_angle` of each of padded hulls (R, H, 2): every hull edge's angle tried
    at once (the padding repeats a vertex, and its edges of no length are not tried)."""
    edges = np.roll(hulls, -1, axis=1) - hulls
    angles = np.mod(np.arctan2(edges[..., 1], edges[..., 0]), np.pi / 2)
    a, b = _turned(hulls, angles)  # (R, points, angles)
    real = (edges != 0).any(axis=2)
    perimeter = np.where(real, 2.0 * (np.ptp(a, axis=1) + np.ptp(b, axis=1)), np.inf)
    return np.take_along_axis(angles, perimeter.argmin(axis=1)[:, None], axis=1)[:, 0]


def _turned(hulls: np.ndarray, angles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The coordinates (R, H, A) of hulls (R, H, 2) along axes turned by each of ``angles``
    (R, A): u cos + v sin, and v cos - u sin."""
    c, s = np.cos(angles)[:, None, :], np.sin(angles)[:, None, :]
    u, v = hulls[..., 0][:, :, None], hulls[..., 1][:, :, None]
    return u * c + v * s, v * c - u * s


def rectangles_at(hulls: np.ndarray, phi: np.ndarray, centroid: np.ndarray, axes: np.ndarray):
    """The rectangles of padded hulls (R, H, 2), in the planes through ``centroid`` (R, 3)
    along ``axes`` (R, 2, 3), turned by ``phi`` (R,): width, height, the long side's axis
    ``u`` and the other ``v`` (R, 3 each), centre (R, 3) and the hull's area, the long side
    reported as the width."""
    a, b = (x[..., 0] for x in _turned(hulls, phi[:, None]))
    width, height = np.ptp(a, axis=1), np.ptp(b, axis=1)
    c, s = np.cos(phi)[:, None], np.sin(phi)[:, None]
    u, v = c * axes[:, 0] + s * axes[:, 1], -s * axes[:, 0] + c * axes[:, 1]
    center = (
        centroid
        + u * ((a.max(axis=1) + a.min(axis=1)) / 2)[:, None]
        + v * ((b.max(axis=1) + b.min(axis=1)) / 2)[:, None]
    )
    x, y = hulls[..., 0], hulls[..., 1]
    area = 0.5 * np.abs((x * np.roll(y, -1, axis=1) - y * np.roll(x, -1, axis=1)).sum(axis=1))
    swap = (height > width)[:, None]  # report the long side as the width
    u, v = np.where(swap, v, u), np.where(swap, -u, v)
    width, height = np.maximum(width, height), np.minimum(width, height)
    return width, height, u, v, center, area


def golden_angle(
    hull: np.ndarray, normal: np.ndarray, axes: np.ndarray, *, coarse: int = 12, tol: float = 1e-7
) -> float:
    """The paper's search: golden section over the Rodrigues rotation angle about ``normal``.

    ``hull`` are in-plane coordinates along ``axes``; candidate axes are ``rodrigues(normal,
    phi) @ axes``. A coarse scan of ``coarse`` angles brackets the search first.
    """
    pts3 = hull @ axes  # back to 3-D offsets in the plane

    def perimeter(phi: float) -> float:
        rot = rodrigues(normal, phi)
        u, v = rot @ axes[0], rot @ axes[1]
        return 2.0 * (np.ptp(pts3 @ u) + np.ptp(pts3 @ v))

    step = (np.pi / 2) / coarse
    grid = np.arange(coarse) * step
    best = grid[int(np.argmin([perimeter(p) for p in grid]))]
    lo, hi = best - step, best + step
    x1, x2 = hi - GOLDEN * (hi - lo), lo + GOLDEN * (hi - lo)
    f1, f2 = perimeter(x1), perimeter(x2)
    while hi - lo > tol:
        if f1 <= f2:
            hi, x2, f2 = x2, x1, f1
            x1 = hi - GOLDEN * (hi - lo)
            f1 = perimeter(x1)
        else:
            lo, x1, f1 = x1, x2, f2
            x2 = lo + GOLDEN * (hi - lo)
            f2 = perimeter(x2)
    return float(np.mod((lo + hi) / 2, np.pi / 2))


def region_plane(points: np.ndarray, method: str = "exact") -> RegionPlane:
    """Fit the ideal plane to a region's points and bound it by the minimum-perimeter rectangle.

    Examples
    --------
    >>> g = np.mgrid[0:4:41j, 0:2:21j].reshape(2, -1).T
    >>> pts = np.c_[g, np.zeros(len(g))] @ rodrigues(np.array([0, 0, 1.0]), 0.3).T
    >>> rp = region_plane(pts)
    >>> round(rp.width, 6), round(rp.height, 6)
    (4.0, 2.0)
    """
    centroid, normal, axes, residual, centred = _centred_fit(points)
    return bound_plane(centroid, normal, axes, residual, centred @ axes.T, len(points), method)


def plane_from_scatter(count: float, centroid, scatter) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """:func:`fit_plane`'s centroid, normal, axes and residual from a region's point count,
    centroid and scatter matrix (sum of outer products about the centroid), as sums over
    its parts give them."""
    values, vectors = np.linalg.eigh(np.asarray(scatter, dtype=np.float64) / count)
    normal, u = vectors[:, 0], vectors[:, 2]
    residual = float(np.sqrt(max(values[0], 0.0)))
    return np.asarray(centroid, dtype=np.float64), normal, in_plane_axes(normal, u), residual


def bound_plane(centroid, normal, axes, residual, uv: np.ndarray, n_points: int, method: str = "exact") -> RegionPlane:
    """The region plane through ``centroid`` whose points lie at ``uv`` (2-D, along ``axes``):
    all of them, or any set with the same convex hull (the hull of parts' hulls)."""
    hull = hull_2d(uv)[None]  # the extremes lie on the hull
    phi = np.array([golden_angle(hull[0], normal, axes)]) if method == "golden" else exact_angles(hull)
    width, height, u, v, center, area = rectangles_at(hull, phi, np.asarray(centroid)[None], axes[None])
    return RegionPlane(centroid, normal, u[0], v[0], float(width[0]), float(height[0]), center[0], residual,
                       float(area[0]), int(n_points))  # fmt: skip


def region_planes_of_segments(points: np.ndarray, starts: np.ndarray) -> list[RegionPlane | None]:
    """:func:`region_plane` (``exact``) of many small regions at once, their points one after
    another in ``points`` (region ``r`` at ``starts[r]:starts[r + 1]``): the fits by sums
    over the segments and one batched eigen-decomposition, the hulls by
    :func:`~geostructure.core.hulls.segment_hulls`, the rectangles over all hull edges of all regions
    together. None for a region whose hull is degenerate: :func:`region_plane` measures it.

    Examples
    --------
    >>> g = np.mgrid[0:4:41j, 0:2:21j].reshape(2, -1).T
    >>> flat = np.c_[g, np.zeros(len(g))]
    >>> pts = np.vstack([flat @ rodrigues(np.array([0, 0, 1.0]), 0.3).T, flat[:, [0, 2, 1]]])
    >>> a, b = region_planes_of_segments(pts, np.array([0, len(g), 2 * len(g)]))
    >>> round(a.width, 6), round(a.height, 6), round(b.area, 6), np.abs(b.normal).round(6).tolist()
    (4.0, 2.0, 8.0, [0.0, 1.0, 0.0])
    """
    sizes = np.diff(starts)
    count = sizes.astype(np.float64)
    centroid = np.add.reduceat(points, starts[:-1], axis=0) / count[:, None]
    centred = points - np.repeat(centroid, sizes, axis=0)
    pairs = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)]
    sums = np.add.reduceat(np.stack([centred[:, i] * centred[:, j] for i, j in pairs], axis=1), starts[:-1], axis=0)
    scatter = sums[:, [0, 1, 2, 1, 3, 4, 2, 4, 5]].reshape(-1, 3, 3) / count[:, None, None]
    values, vectors = np.linalg.eigh(scatter)
    residual = np.sqrt(np.maximum(values[:, 0], 0.0))
    normal, u = vectors[:, :, 0], vectors[:, :, 2]
    axes = np.stack([u, np.cross(normal, u)], axis=1)  # (R, 2, 3), as in_plane_axes
    uv = np.einsum("nk,njk->nj", centred, np.repeat(axes, sizes, axis=0))
    hull, n_vertices, closed = segment_hulls(uv, starts)
    width, height, ru, rv, center, area = rectangles_at(hull, exact_angles(hull), centroid, axes)
    planes: list[RegionPlane | None] = []
    for r in range(len(sizes)):
        if not closed[r]:
            planes.append(None)
            continue
        planes.append(RegionPlane(centroid[r], normal[r], ru[r], rv[r], float(width[r]), float(height[r]), center[r],
                                  float(residual[r]), float(area[r]), int(sizes[r])))  # fmt: skip
    return planes
