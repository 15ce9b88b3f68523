"""Plane sweep: depth from views that move along their axis (which rectification cannot take)."""

import numpy as np

from geostructure.reconstruct.planesweep import sweep_depth
from geostructure.testing.render import faces, look_at, render, textures


def _view(camera):
    k = np.array([[camera.focal, 0, camera.width / 2 - 0.5], [0, camera.focal, camera.height / 2 - 0.5], [0, 0, 1]])
    pose = np.c_[camera.rotation, -camera.rotation @ camera.centre]
    return k, pose


def test_walking_towards_the_outcrop_gives_its_depth():
    scene, texture = faces(), textures(4, seed=1)
    target = np.array([0.0, 10.0, 2.2])
    # three frames 1.2 m apart, walking straight at the south face (the epipole mid-image)
    cameras = [look_at(np.array([0.3, -1.0 + 1.2 * i, 2.0]), target + [0.3, 0, 0]) for i in range(3)]
    images = [render(c, scene, texture) for c in cameras]
    ref_image, true_depth = images[1]
    k_ref, pose_ref = _view(cameras[1])
    partners = [(images[i][0].astype(np.float32), *_view(cameras[i])) for i in (0, 2)]
    depth = sweep_depth(ref_image.astype(np.float32), k_ref, pose_ref, partners, near=4.0, far=30.0)
    seen = np.isfinite(true_depth)
    kept = np.isfinite(depth) & seen
    relative = np.abs(depth[kept] - true_depth[kept]) / true_depth[kept]
    assert kept.sum() > 0.5 * seen.sum()  # most of the view gets a depth (67%)
    assert np.median(relative) < 0.01 and np.percentile(relative, 90) < 0.04
    # near the epipole (the image centre) the sweep barely moves a pixel: no depth is claimed there
    h, w = depth.shape
    assert not np.isfinite(depth[h // 2 - 5 : h // 2 + 5, w // 2 - 5 : w // 2 + 5]).any()
