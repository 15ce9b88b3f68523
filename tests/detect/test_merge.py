"""Coplanar merge: a wall split by a projecting bay is one plane; steps and far look-alikes are not."""

import numpy as np
import pytest

from geostructure.core.cloud import Cloud
from geostructure.core.orientation import angle_between_normals
from geostructure.core.params import Params
from geostructure.detect.merge import merge_coplanar, summarise_regions
from geostructure.detect.pipeline import measure
from geostructure.synthetic import Surface, sample_rectangle

SOUTH = np.array([0.0, -1.0, 0.0])


def facade(seed=0, noise=0.004):
    """A south-facing wall in two halves (x -5..-1 and 1..5) with a bay 0.6 m proud between
    them, a coplanar panel 30 m away, and a floor so the cloud is not one plane."""
    rng = np.random.default_rng(seed)
    parts = {
        "left": Surface("left", np.array([-3.0, 0.0, 2.0]), SOUTH, 4.0, 4.0),
        "right": Surface("right", np.array([3.0, 0.0, 2.0]), SOUTH, 4.0, 4.0),
        "bay": Surface("bay", np.array([0.0, -0.6, 2.0]), SOUTH, 1.8, 4.0),
        "far": Surface("far", np.array([33.0, 0.0, 2.0]), SOUTH, 2.0, 2.0),
        "floor": Surface("floor", np.array([14.0, -4.0, -0.5]), np.array([0.0, 0.0, 1.0]), 40.0, 6.0),
    }
    density = 1500  # points per square metre
    points = [sample_rectangle(s, int(density * s.width * s.height), rng, noise) for s in parts.values()]
    labels = np.concatenate([np.full(len(p), i) for i, p in enumerate(points)])
    return Cloud.from_points(np.vstack(points) + [500_000.0, 4_000_000.0, 100.0], source="facade"), labels, list(parts)


@pytest.fixture(scope="module")
def scene():
    return facade()


def planes_holding(result, truth_labels, names, name):
    """Planes that hold at least a fifth of a surface's points."""
    index = names.index(name)
    kept = result.filter_result.keep
    labels = result.labels[truth_labels[kept] == index]
    counts = np.bincount(labels[labels >= 0], minlength=len(result))
    return set(np.flatnonzero(counts >= 0.2 * (truth_labels == index).sum()).tolist())


@pytest.mark.parametrize("merge", [True, False])
def test_the_two_halves_of_a_wall_are_one_plane_only_when_merging(scene, merge):
    cloud, truth, names = scene
    result = measure(cloud, Params(zeta=0.01, theta=5.0, psi=0.3, k=8, merge=merge))
    left, right = planes_holding(result, truth, names, "left"), planes_holding(result, truth, names, "right")
    bay, far = planes_holding(result, truth, names, "bay"), planes_holding(result, truth, names, "far")
    assert len(left) == 1 and len(right) == 1 and len(bay) == 1 and len(far) == 1
    assert (left == right) is merge
    assert not bay & left and not far & left  # a step 0.6 m proud, and a look-alike 30 m away
    wall = result.normals[next(iter(left))]
    assert angle_between_normals(wall, SOUTH)[0] < 0.5
    if merge:
        assert result.counts["merges"] >= 1


def test_merge_leaves_parallel_offset_planes_and_small_regions_alone():
    rng = np.random.default_rng(3)
    from geostructure.detect.voxel import fit_voxels

    step = [
        Surface("a", np.array([0.0, 0.0, 0.0]), SOUTH, 3.0, 3.0),
        Surface("b", np.array([4.0, -0.2, 0.0]), SOUTH, 3.0, 3.0),
    ]
    points = np.vstack([sample_rectangle(s, 20_000, rng, 0.002) for s in step])
    voxels = fit_voxels(points, 0.02)
    labels = (voxels.centroid[:, 0] > 2.0).astype(np.int64)
    merged, joins = merge_coplanar(voxels, labels, theta=5.0, offset_limit=0.05)
    assert joins == 0 and np.array_equal(merged, labels)
    merged, joins = merge_coplanar(voxels, labels, theta=5.0, offset_limit=0.3)
    assert joins == 1 and set(merged.tolist()) == {0}
    summary = summarise_regions(voxels, labels, 2)
    assert np.allclose(np.abs(summary.normal @ SOUTH), 1.0, atol=1e-4)
    assert np.allclose(summary.centroid[:, 1], [0.0, -0.2], atol=0.01)
