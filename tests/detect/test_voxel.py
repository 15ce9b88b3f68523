import numpy as np
import pytest
from conftest import plane_points

from geostructure.core.orientation import angle_between_normals, normal_from_orientation
from geostructure.detect.voxel import accumulate_moments, add_moments, fit_planes, fit_voxels


@pytest.mark.parametrize("dd,dip", [(0, 0), (45, 30), (123, 60), (270, 89.9), (10, 90), (200, 75)])
def test_voxel_normals_follow_planes_at_many_orientations(dd, dip):
    normal = normal_from_orientation(dd, dip)
    pts = plane_points(normal, n=20000, size=10, noise=0.005, seed=1)
    vp = fit_voxels(pts, zeta=0.1)
    assert len(vp) > 20
    errors = angle_between_normals(vp.normal, np.repeat(normal[None], len(vp), 0))
    assert np.median(errors) < 1.0
    assert np.all(vp.residual < 0.02)


def test_moments_of_chunks_add_up_to_the_moments_of_the_whole():
    rng = np.random.default_rng(0)
    pts = rng.random((5000, 3)) * 4
    whole, _ = accumulate_moments(pts, 0.5, np.zeros(3))
    a, _ = accumulate_moments(pts[:2000], 0.5, np.zeros(3))
    b, _ = accumulate_moments(pts[2000:], 0.5, np.zeros(3))
    summed = add_moments(a, b)
    np.testing.assert_array_equal(summed.keys, whole.keys)
    np.testing.assert_allclose(summed.count, whole.count)
    np.testing.assert_allclose(summed.sums, whole.sums, rtol=1e-12)
    np.testing.assert_allclose(summed.products, whole.products, rtol=1e-12)


def test_sparse_and_linear_voxels_give_no_plane():
    line = np.c_[np.linspace(0, 1, 50), np.zeros(50), np.zeros(50)]
    moments, _ = accumulate_moments(line, 2.0, np.full(3, -0.5))
    keep, *_, curvature = fit_planes(moments, min_points=5)
    assert keep.all() and curvature[0] == 1.0  # a line is no plane
    pair = np.array([[0.1, 0.1, 0.1], [0.2, 0.3, 0.1]])
    moments, _ = accumulate_moments(pair, 2.0, np.zeros(3))
    keep, *_ = fit_planes(moments, min_points=5)
    assert not keep.any()


def test_large_coordinates_keep_precision():
    from geostructure.core.cloud import Cloud

    normal = normal_from_orientation(77, 33)
    pts = plane_points(normal, n=20000, size=10, noise=0.002, seed=2)
    near = fit_voxels(Cloud.from_points(pts).local, 0.1)
    far = fit_voxels(Cloud.from_points(pts + [500_000.0, 5_000_000.0, 300.0]).local, 0.1)
    assert len(near) == len(far)
    assert angle_between_normals(far.normal, near.normal).max() < 1e-3  # float32 would be off by metres


@pytest.mark.parametrize("seed", range(6))
def test_codes_grouped_by_their_columns_are_numpys_unique(seed):
    """group_codes with a minor part (a grid key's z under its x-y column) must give
    np.unique's sorted codes and inverse exactly, whichever of its ways it takes: one table,
    the columns' ranges in a second table, or a sort of those when they are sparse too."""
    from geostructure.core.gridkeys import group_codes

    rng = np.random.default_rng(seed)
    minor = int(rng.choice([7, 1000, 100_000]))
    n_major = int(rng.choice([50, 5_000]))
    n = int(rng.integers(1, 20_000))
    major = rng.integers(0, n_major, n)
    low = rng.integers(0, minor, n) if seed % 2 else rng.integers(0, 3, n) + (major * 13) % max(minor - 3, 1)
    codes = major * minor + low
    unique, inverse = group_codes(codes, n_major * minor, minor=minor)
    expected, expected_inverse = np.unique(codes, return_inverse=True)
    assert np.array_equal(unique, expected) and np.array_equal(inverse, expected_inverse.ravel())
