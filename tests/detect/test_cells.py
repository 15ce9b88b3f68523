"""The grid's local planes (cells.py) and the facets grown on them (facets.py)."""

import numpy as np
import pytest

from geostructure.core.density import point_spacing
from geostructure.core.eigen import smallest_eigenpair
from geostructure.detect.cells import CENTRE, OFFSETS, cell_planes
from geostructure.detect.facets import detect_facets


def test_the_closed_form_eigenpair_agrees_with_lapack():
    rng = np.random.default_rng(0)
    n = 20_000
    rotation = np.linalg.qr(rng.normal(size=(n, 3, 3)))[0]
    spread = np.sort(rng.uniform(0.0, 1.0, (n, 3)) ** 3, axis=1) * 1e-3  # planar, linear, round
    spread[:100, 0] = 0.0  # exactly planar blocks
    cov = np.einsum("nij,nj,nkj->nik", rotation, spread, rotation)
    values, vector = smallest_eigenpair(cov)
    expected_values, expected_vectors = np.linalg.eigh(cov)
    # to 1e-8 of the largest: the cubic's roots lose digits only where two of them meet
    scale = expected_values[:, 2:]
    assert (np.abs(values - np.maximum(expected_values, 0)) <= 1e-8 * scale).all()
    # the vector is defined where lambda_0 is apart from lambda_1
    apart = spread[:, 1] - spread[:, 0] > 1e-2 * spread[:, 2]
    cosine = np.abs(np.einsum("ij,ij->i", vector[apart], expected_vectors[apart, :, 0]))
    assert np.degrees(np.arccos(np.clip(cosine, 0, 1))).max() < 1e-3
    np.testing.assert_allclose(np.linalg.norm(vector, axis=1), 1.0)


def test_block_planes_on_a_tilted_plane_at_a_utm_offset():
    rng = np.random.default_rng(1)
    uv = rng.uniform(0, 2, (20_000, 2))
    normal = np.array([0.3, -0.2, 1.0]) / np.linalg.norm([0.3, -0.2, 1.0])
    u = np.cross(normal, [1.0, 0, 0])
    u /= np.linalg.norm(u)
    v = np.cross(normal, u)
    points = uv[:, :1] * u + uv[:, 1:] * v + 0.001 * rng.normal(size=(len(uv), 1)) * normal
    near = cell_planes(points, 0.05)
    far = cell_planes(points + [662_000.0, 5_103_000.0, 800.0], 0.05)
    defined = near.defined
    assert defined.mean() > 0.9
    cosine = np.abs(near.normal[defined] @ normal)
    assert np.degrees(np.arccos(np.clip(cosine, 0, 1))).max() < 2.0
    np.testing.assert_array_equal(near.point_cell, far.point_cell)  # the same grid, up to the offset
    assert np.abs(np.abs(np.einsum("ij,ij->i", near.normal, far.normal))[defined] - 1).max() < 1e-6
    # a cell's neighbour at an offset has its corner one edge away along that offset
    cell = np.flatnonzero(near.neighbour[:, CENTRE + 9] >= 0)[0]  # +x
    np.testing.assert_allclose(near.corner[near.neighbour[cell, CENTRE + 9]] - near.corner[cell], [0.05, 0, 0])
    assert tuple(OFFSETS[CENTRE + 9]) == (1, 0, 0)


def test_point_spacing_reads_regular_and_random_clouds():
    g = np.mgrid[0:6:0.02, 0:6:0.02].reshape(2, -1).T
    grid = np.c_[g, np.zeros(len(g))]
    assert 0.8 * 0.02 < point_spacing(grid) < 1.0 * 0.02
    random = np.c_[np.random.default_rng(2).uniform(0, 6, (len(g), 2)), np.zeros(len(g))]
    assert 0.9 * 0.02 < point_spacing(random) < 1.1 * 0.02  # 1 / sqrt(density), not the nearest gap


def test_a_step_between_parallel_faces_separates_them():
    g = np.mgrid[0:2:0.02, 0:1:0.02].reshape(2, -1).T
    z = np.where(g[:, 0] < 1.0, 0.0, 0.05)  # two horizontal faces, the second 5 cm higher
    points = np.c_[g, z + 0.001 * np.random.default_rng(3).normal(size=len(g))]
    found = detect_facets(points)
    left, right = found.labels[g[:, 0] < 0.9], found.labels[g[:, 0] > 1.1]
    assert np.bincount(left[left >= 0]).argmax() != np.bincount(right[right >= 0]).argmax()
    assert (left >= 0).mean() > 0.8 and (right >= 0).mean() > 0.8


def test_a_facet_label_left_without_points_is_no_plane_and_no_nan():
    """At 8M observatory points a grown facet lost all its points to the offset test; its
    empty label made the covariances NaN and the measure died in eigh."""
    import warnings

    from geostructure.detect.facets import FacetThresholds, planar_components

    rng = np.random.default_rng(0)
    points = np.c_[rng.uniform(0, 1, (200, 2)), rng.normal(0, 1e-3, 200)]
    normals = np.tile([0.0, 0.0, 1.0], (200, 1))
    labels = np.where(np.arange(200) < 100, 0, 2)  # label 1 holds no point
    thresholds = FacetThresholds(max_angle=5.0, max_offset=0.01, max_variation=0.01, spacing=0.05)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        planar = planar_components(points, normals, labels, thresholds)
    assert planar.tolist() == [True, False, True]


@pytest.mark.parametrize("noise, doublings", [(0.02, 1), (0.08, 2)])
def test_the_sampled_edge_is_the_edge_the_whole_grids_choose(noise, doublings):
    """Above a million points the grid's edge is chosen on sampled blocks, its scatter read on
    20,000 cells first and on 200,000 only near the limit (facets.sampled_edge). At 0.3M
    points every block is drawn: it must choose what fitting every grid whole chooses."""
    from geostructure.detect.facets import CELL_EDGE, coarsened_planes, sampled_edge
    from geostructure.synthetic import observatory_scene

    points = observatory_scene(300_000, seed=1, noise=noise).cloud.local
    edge = CELL_EDGE * point_spacing(points)
    assert coarsened_planes(points, edge).edge == sampled_edge(points, edge) == edge * 2**doublings
