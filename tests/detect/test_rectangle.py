import numpy as np
import pytest

from geostructure.core.hulls import segment_hulls
from geostructure.detect.rectangle import (
    bounding_perimeter,
    exact_angle,
    golden_angle,
    hull_2d,
    region_plane,
    region_planes_of_segments,
    rodrigues,
)


def test_rodrigues_is_a_rotation_about_its_axis():
    axis = np.array([1.0, 2.0, 2.0]) / 3.0
    r = rodrigues(axis, 0.7)
    np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(r) == pytest.approx(1.0)
    np.testing.assert_allclose(r @ axis, axis, atol=1e-12)


@pytest.mark.parametrize("seed", range(25))
def test_golden_section_within_half_a_percent_of_the_exact_minimum(seed):
    rng = np.random.default_rng(seed)
    # Irregular outlines: random blobs, stretched and rotated.
    uv = rng.normal(size=(400, 2)) * [rng.uniform(1, 8), rng.uniform(0.5, 3)]
    uv = uv @ np.array([[np.cos(seed), -np.sin(seed)], [np.sin(seed), np.cos(seed)]])
    hull = hull_2d(uv)
    normal, axes = np.array([0.0, 0, 1]), np.array([[1.0, 0, 0], [0, 1.0, 0]])
    exact = bounding_perimeter(hull, exact_angle(hull))
    golden = bounding_perimeter(hull, golden_angle(hull, normal, axes))
    assert exact <= golden * (1 + 1e-9)
    assert golden <= exact * 1.005


def test_exact_rectangle_beats_a_brute_force_scan():
    rng = np.random.default_rng(1)
    hull = hull_2d(rng.random((200, 2)) * [5, 2])
    scan = min(bounding_perimeter(hull, a) for a in np.linspace(0, np.pi / 2, 20001))
    assert bounding_perimeter(hull, exact_angle(hull)) <= scan + 1e-9


@pytest.mark.parametrize("method", ["exact", "golden"])
def test_region_plane_recovers_a_rotated_tilted_rectangle(method):
    g = np.mgrid[0:6:61j, 0:2:21j].reshape(2, -1).T - [3, 1]
    tilt = rodrigues(np.array([1.0, 0, 0]), 0.6) @ rodrigues(np.array([0, 0, 1.0]), 0.4)
    pts = np.c_[g, np.zeros(len(g))] @ tilt.T + [10, 20, 30]
    rp = region_plane(pts, method)
    assert rp.width == pytest.approx(6, abs=1e-6) and rp.height == pytest.approx(2, abs=1e-6)
    assert rp.area == pytest.approx(12, abs=1e-6)
    np.testing.assert_allclose(rp.center, [10, 20, 30], atol=1e-9)
    assert abs(rp.normal @ (tilt @ [0, 0, 1])) == pytest.approx(1, abs=1e-12)
    corners = rp.corners
    assert np.linalg.norm(corners[1] - corners[0]) == pytest.approx(6, abs=1e-6)


@pytest.mark.parametrize("shape", ["disc", "thin rotated strip", "triangle", "few distinct points"])
def test_the_octagon_prefilter_keeps_every_hull_vertex(shape):
    from scipy.spatial import ConvexHull

    from geostructure.detect.rectangle import OCTAGON_POINTS, hull_2d

    rng = np.random.default_rng(7)
    p = rng.uniform(-1, 1, (20 * OCTAGON_POINTS, 2))
    if shape == "disc":
        p = p[(p**2).sum(axis=1) < 1]
    elif shape == "thin rotated strip":
        c, s = np.cos(0.3), np.sin(0.3)
        p = (p * [50.0, 0.01]) @ np.array([[c, -s], [s, c]]) + [6.6e5, 5.1e6]  # UTM-sized
    elif shape == "triangle":
        p = p[p[:, 1] < 1 - 2 * np.abs(p[:, 0])]
    else:
        p = p[rng.integers(0, 5, len(p))]  # five points, repeated
    whole = p[ConvexHull(p).vertices]
    assert len(p) > OCTAGON_POINTS
    assert set(map(tuple, hull_2d(p))) == set(map(tuple, whole))


def _small_outlines(rng, n_sets):
    """2-D point sets as small regions give them: blobs, boxes, and grids with points in line
    along every edge (exact or within rounding, axis-aligned or turned)."""
    sets = []
    for k in range(n_sets):
        n = int(rng.integers(3, 600))
        kind = k % 4
        if kind == 0:
            p = rng.random((n, 2)) * rng.uniform(0.1, 3, 2)
        elif kind == 1:
            p = rng.normal(size=(n, 2)) * 0.3
        else:
            p = rng.integers(0, 12, (n, 2)) * 0.025
            p = p + rng.normal(0, 1e-9, p.shape) if kind == 2 else p @ rodrigues(np.array([0, 0, 1.0]), 0.3)[:2, :2]
        sets.append(p)
    return sets


def test_segment_hulls_match_qhull():
    rng = np.random.default_rng(3)
    sets = _small_outlines(rng, 200)
    hulls, n_vertices, closed = segment_hulls(np.vstack(sets), np.r_[0, np.cumsum([len(p) for p in sets])])
    area = lambda h: 0.5 * abs(h[:, 0] @ np.roll(h[:, 1], -1) - h[:, 1] @ np.roll(h[:, 0], -1))  # noqa: E731
    for p, hull, n, ok in zip(sets, hulls, n_vertices, closed):
        reference = hull_2d(p)
        assert ok
        mine = hull[:n]
        assert {tuple(x) for x in mine.tolist()} <= {tuple(x) for x in p.tolist()}  # vertices are points
        assert area(mine) == pytest.approx(area(reference), rel=1e-9)
        # Counter-clockwise, every point on or inside every edge.
        edge = np.roll(mine, -1, axis=0) - mine
        side = edge[:, 0, None] * (p[None, :, 1] - mine[:, 1, None]) - edge[:, 1, None] * (
            p[None, :, 0] - mine[:, 0, None]
        )
        assert side.min() >= -1e-9


def test_points_in_line_have_no_hull_and_are_left_to_the_caller():
    line = np.c_[np.linspace(0, 1, 20), np.linspace(0, 2, 20)]
    square = np.array([[0, 0], [1, 0], [1, 1], [0, 1.0]])
    _, n_vertices, closed = segment_hulls(np.vstack([line, square]), np.array([0, 20, 24]))
    assert closed.tolist() == [False, True] and n_vertices[1] == 4
    planes = region_planes_of_segments(np.c_[np.vstack([line, square]), np.zeros(24)], np.array([0, 20, 24]))
    assert planes[0] is None and planes[1].area == pytest.approx(1.0)


def test_regions_fitted_together_are_fitted_as_one_by_one():
    rng = np.random.default_rng(4)
    sets = _small_outlines(rng, 120)
    turns = [rodrigues(rng.normal(size=3) / np.sqrt(3), rng.uniform(0, 3)) for _ in sets]
    regions = [np.c_[p, rng.normal(0, 0.01, len(p))] @ r.T + rng.normal(0, 50, 3) for p, r in zip(sets, turns)]
    together = region_planes_of_segments(np.vstack(regions), np.r_[0, np.cumsum([len(p) for p in regions])])
    for points, plane in zip(regions, together):
        one = region_plane(points)
        np.testing.assert_allclose(plane.centroid, one.centroid, atol=1e-9)
        np.testing.assert_allclose(plane.center, one.center, atol=1e-9)
        assert abs(plane.normal @ one.normal) == pytest.approx(1.0, abs=1e-12)
        assert abs(plane.u @ one.u) == pytest.approx(1.0, abs=1e-9)
        for name in ("width", "height", "area", "residual"):
            assert getattr(plane, name) == pytest.approx(getattr(one, name), rel=1e-9, abs=1e-12)
        assert plane.n_points == one.n_points


def test_a_large_region_in_a_line_is_bounded_by_its_two_ends():
    """Qhull refuses points in a line; the hull is then the segment's two ends, not every
    point (which made the rectangle search an N x N array: 20,000 points, 3 GB each)."""
    t = np.random.default_rng(0).random(20_000) * 10.0
    plane = region_plane(np.c_[t, 2 * t, 3 * t])
    assert plane.width == pytest.approx(np.ptp(t) * np.sqrt(14.0), rel=1e-9)
    assert plane.height == pytest.approx(0.0, abs=1e-9) and plane.area == pytest.approx(0.0, abs=1e-9)
    assert hull_2d(np.zeros((5, 2))).tolist() == [[0.0, 0.0], [0.0, 0.0]]
