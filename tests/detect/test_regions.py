import numpy as np
from conftest import plane_points

from geostructure.detect.regions import grow_regions
from geostructure.detect.voxel import fit_voxels


def labels_of(points, zeta=0.02, **kw):
    vp = fit_voxels(points, zeta)
    growth = grow_regions(vp, kw.pop("theta", 5.0), kw.pop("psi", 0.1), kw.pop("k", 8), **kw)
    point_labels = np.where(vp.point_voxel >= 0, growth.labels[np.maximum(vp.point_voxel, 0)], -1)
    return point_labels


def dominant(labels):
    valid = labels[labels >= 0]
    return np.bincount(valid).argmax() if len(valid) else -1


def test_two_planes_meeting_at_an_edge_are_two_regions():
    floor = plane_points([0, 0, 1], n=40000, size=20, noise=0.005, seed=0)
    wall = plane_points([1, 0, 0], n=20000, size=10, noise=0.005, center=(0, 0, 5), seed=1)
    labels = labels_of(np.vstack([floor, wall]))
    a, b = dominant(labels[:40000]), dominant(labels[40000:])
    assert a != b
    assert (labels[:40000] == a).mean() > 0.8 and (labels[40000:] == b).mean() > 0.8


def test_regions_do_not_jump_across_a_gap():
    left = plane_points([0, 0, 1], n=20000, size=8, noise=0.003, center=(-6, 0, 0), seed=2)
    right = plane_points([0, 0, 1], n=20000, size=8, noise=0.003, center=(6, 0, 0), seed=3)
    labels = labels_of(np.vstack([left, right]), zeta=0.02, k=30)
    assert dominant(labels[:20000]) != dominant(labels[20000:])


def test_parallel_offset_planes_are_split_by_psi():
    low = plane_points([0, 0, 1], n=20000, size=10, noise=0.002, center=(-4.9, 0, 0), seed=4)
    step = plane_points([0, 0, 1], n=20000, size=10, noise=0.002, center=(5.1, 0, 0.15), seed=5)
    pts = np.vstack([low, step])
    split = labels_of(pts, psi=0.1)
    merged = labels_of(pts, psi=5.0)
    assert dominant(split[:20000]) != dominant(split[20000:])
    assert dominant(merged[:20000]) == dominant(merged[20000:])


def test_region_reference_stops_drift_round_a_curve_that_seed_reference_follows():
    rng = np.random.default_rng(6)
    angle = rng.uniform(0, np.pi / 2, 60000)  # a quarter cylinder of radius 10
    pts = np.c_[10 * np.cos(angle), rng.uniform(0, 10, 60000), 10 * np.sin(angle)]
    seed_ref = labels_of(pts, zeta=0.03, theta=8, psi=0.5, reference="seed")
    region_ref = labels_of(pts, zeta=0.03, theta=8, psi=0.5, reference="region")
    assert (seed_ref == dominant(seed_ref)).mean() > 0.9  # follows the curve all round
    assert (region_ref == dominant(region_ref)).mean() < 0.5  # stays a plane
