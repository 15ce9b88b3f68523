"""The automatic parameters against the sweep, on scenes made with seeds the method was not tuned on
(it was tuned on seed 101)."""

import numpy as np
import pytest

from geostructure.detect.auto import choose_params
from geostructure.synthetic import observatory_scene
from geostructure.testing.autocheck import check_variant


@pytest.mark.parametrize(
    "variant,seed,size",
    [
        ("bundled", 7, 0.5),
        ("scale 0.1x", 8, 0.5),
        ("scale 10x", 9, 0.5),
        ("sparse (1/25 density)", 10, 1.0),
        ("noisy (8 cm)", 11, 0.5),
        ("sparse and noisy", 12, 1.0),
    ],
)
def test_auto_lands_near_the_best_the_sweep_finds(variant, seed, size):
    check = check_variant(variant, seed, size)
    assert check.found_auto == 6, check
    assert check.auto_ok, check


def test_the_fixed_defaults_do_not_on_a_noisy_scene():
    # sparse scenes no longer defeat them: the coplanar merge puts their pieces back together
    check = check_variant("noisy (8 cm)", 11, 0.5)
    assert not check.default_ok, check


def test_auto_choice_does_not_depend_on_scale():
    a = choose_params(observatory_scene(60_000, seed=3).cloud.local).params
    b = choose_params(observatory_scene(60_000, seed=3, scale=10).cloud.local).params
    assert a.zeta == pytest.approx(b.zeta, rel=1e-3) and a.psi == pytest.approx(b.psi, rel=0.02)


def test_the_drawn_voxels_are_whole_voxels_of_the_cloud():
    """:func:`auto.noise_sample` draws whole voxels: their planes are exactly some of the
    whole cloud's, about the share asked for, and the same in any point order."""
    from geostructure.detect.auto import noise_sample
    from geostructure.detect.voxel import accumulate_moments, voxel_planes_from_moments

    points = observatory_scene(200_000, seed=2).cloud.local
    lower, edge = points.min(axis=0), 0.01 * float(np.ptp(points, axis=0).max())
    drawn = noise_sample(points, lower, edge, n_points=len(points) * 100)  # as if 20M: 5% drawn
    assert 0.02 < drawn.mean() < 0.1
    assert (noise_sample(points[::-1], lower, edge, len(points) * 100) == drawn[::-1]).all()
    whole = voxel_planes_from_moments(accumulate_moments(points, edge, lower)[0])[0]
    part = voxel_planes_from_moments(accumulate_moments(points[drawn], edge, lower)[0])[0]
    rows = {tuple(k): i for i, k in enumerate(whole.keys.tolist())}
    index = np.array([rows[tuple(k)] for k in part.keys.tolist()])
    assert len(part) > 50
    assert np.allclose(part.centroid, whole.centroid[index], atol=1e-12, rtol=0)
    assert (part.count == whole.count[index]).all()
