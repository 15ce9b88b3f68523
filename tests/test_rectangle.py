import numpy as np
import pytest

from geostructure.rectangle import bounding_perimeter, exact_angle, golden_angle, hull_2d, region_plane, rodrigues


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

    from geostructure.rectangle import OCTAGON_POINTS, hull_2d

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
