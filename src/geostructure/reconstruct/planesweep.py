"""Plane-sweep stereo on the CPU, for views that rectified pairs cannot handle.

Stereo rectification fails when a camera moves along its view (walking up a street or
towards a cliff): the epipole falls inside the image. A plane sweep has no such limit.
For each reference image, fronto-parallel planes at depths spread evenly in inverse depth
(over the range of the sparse points it sees) carry its best partners' images onto it by
homography (OpenCV ``warpPerspective``); the zero-mean normalised cross-correlation (ZNCC)
in a small window scores each depth, and each pixel keeps its best. A pixel is kept only
when its window is textured, its score high, and the sweep moved it far enough across the
partner image for depth to be decided (pixels near the epipole barely move). The depth
maps are then fused like the SGBM pair clouds: a point survives only where several
reference views agree (Collins 1996 for the sweep; Gallup et al. 2007 for ZNCC sweeps).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from geostructure.errors import GeoStructureError
from geostructure.reconstruct.sfm import pair_angle


@dataclass(frozen=True)
class SweepOptions:
    image_size: int = 800  # working resolution (px, longest side)
    min_planes: int = 64  # depth hypotheses: about one per pixel of travel, within these
    max_planes: int = 256
    window: int = 7  # ZNCC window (px)
    min_score: float = 0.6  # mean ZNCC over the partners
    min_texture: float = 4.0  # grey-level standard deviation in the window
    min_sweep_px: float = 12.0  # how far the sweep must carry a pixel across every partner
    partners: int = 2


def pinhole(camera, scale: float) -> np.ndarray:
    """OpenCV intrinsics (pixel centres at integers) of a COLMAP pinhole camera resized by ``scale``."""
    k = np.array(camera.calibration_matrix(), dtype=np.float64)
    k[:2] *= scale
    k[0, 2] -= 0.5
    k[1, 2] -= 0.5
    return k


def _load(image_dir: Path, image, size: int):
    import cv2

    grey = cv2.imread(str(image_dir / image.name), cv2.IMREAD_GRAYSCALE)
    if grey is None:
        raise GeoStructureError(f"{image_dir}: cannot read {image.name}.")
    scale = min(1.0, size / max(grey.shape))
    grey = cv2.resize(grey, (round(grey.shape[1] * scale), round(grey.shape[0] * scale)), interpolation=cv2.INTER_AREA)
    return grey.astype(np.float32), pinhole(image.camera, scale)


def _box(image, window):
    import cv2

    return cv2.boxFilter(image, cv2.CV_32F, (window, window), borderType=cv2.BORDER_REFLECT)


def sweep_depth(
    grey: np.ndarray,
    k_ref: np.ndarray,
    pose_ref: np.ndarray,
    partners: list,
    near: float,
    far: float,
    options: SweepOptions = SweepOptions(),
) -> np.ndarray:
    """Depth map (NaN where undecided) of a reference image by plane sweep.

    Parameters
    ----------
    grey : (H, W) float32 reference image.
    k_ref : (3, 3) OpenCV intrinsics; pose_ref : (3, 4) camera-from-world.
    partners : list of (image, intrinsics, pose) of the other views.
    near, far : depth range swept (evenly in inverse depth).
    """
    import cv2

    h, w = grey.shape
    win = options.window
    mean_r = _box(grey, win)
    var_r = np.maximum(_box(grey * grey, win) - mean_r**2, 0)
    grid = np.stack(np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64)), -1).reshape(-1, 1, 2)
    sweep_px = np.full((h, w), np.inf, np.float32)
    geometry = []
    for src, k_src, pose in partners:
        rotation = pose[:, :3] @ pose_ref[:, :3].T
        translation = pose[:, 3] - rotation @ pose_ref[:, 3]
        geometry.append(
            (
                np.asarray(src, np.float32),
                k_src @ rotation @ np.linalg.inv(k_ref),
                np.outer(k_src @ translation, np.linalg.inv(k_ref)[2]),
            )
        )
        ends = [
            cv2.perspectiveTransform(grid, geometry[-1][1] + geometry[-1][2] / d).reshape(h, w, 2) for d in (near, far)
        ]
        # how far the sweep carries the pixel across this partner: the further, the surer the depth
        sweep_px = np.minimum(sweep_px, np.linalg.norm(ends[0] - ends[1], axis=2).astype(np.float32))
    # about one pixel of travel per plane where the travel is large, so no depth falls between planes
    planes = int(np.clip(np.percentile(sweep_px[np.isfinite(sweep_px)], 90), options.min_planes, options.max_planes))
    inverse = np.linspace(1 / near, 1 / far, planes)
    scores = np.empty((planes, h, w), np.float32)
    for i, inv in enumerate(inverse):
        total = np.zeros((h, w), np.float32)
        for src, rotation_part, translation_part in geometry:
            warped = cv2.warpPerspective(
                src,
                rotation_part + translation_part * inv,
                (w, h),
                flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
                borderValue=-1.0,
            )
            inside = _box((warped >= 0).astype(np.float32), win) > 0.999
            mean_s = _box(warped, win)
            var_s = np.maximum(_box(warped * warped, win) - mean_s**2, 0)
            zncc = (_box(grey * warped, win) - mean_r * mean_s) / np.sqrt(var_r * var_s + 1e-6)
            total += np.where(inside, zncc, -1.0)
        scores[i] = total / len(geometry)
    best_index = scores.argmax(axis=0)
    inner = np.clip(best_index, 1, planes - 2)
    below, best, above = (np.take_along_axis(scores, (inner + d)[None], 0)[0] for d in (-1, 0, 1))
    curvature = below - 2 * best + above
    # the parabola through the best score and its neighbours puts the depth between planes
    shift = np.where(curvature < 0, 0.5 * (below - above) / np.where(curvature < 0, curvature, -1.0), 0.0)
    best = np.take_along_axis(scores, best_index[None], 0)[0]
    keep = (
        (best >= options.min_score)
        & (np.sqrt(var_r) >= options.min_texture)
        & (sweep_px >= options.min_sweep_px)
        & (best_index > 0)
        & (best_index < planes - 1)
    )
    step = inverse[1] - inverse[0]
    return np.where(keep, 1.0 / (inverse[inner] + np.clip(shift, -0.5, 0.5) * step), np.nan)


def depth_map(
    reconstruction,
    ref: int,
    partners: list[int],
    depths_seen: np.ndarray,
    image_dir: Path,
    options: SweepOptions = SweepOptions(),
):
    """Points (model coordinates) of one registered image's depth map, and its pixel footprint
    (model units per pixel) at the median depth. ``depths_seen`` are the depths of the
    sparse points the image sees, which bound the sweep."""
    image = reconstruction.images[ref]
    grey, k_ref = _load(image_dir, image, options.image_size)
    pose_ref = image.cam_from_world().matrix()
    others = [
        (
            *_load(image_dir, reconstruction.images[p], options.image_size),
            reconstruction.images[p].cam_from_world().matrix(),
        )
        for p in partners
    ]
    near, far = np.percentile(depths_seen, [2, 98]) * [0.8, 1.25]
    depth = sweep_depth(grey, k_ref, pose_ref, others, near, far, options)
    v, u = np.nonzero(np.isfinite(depth))
    camera_points = np.c_[u, v, np.ones(len(u))] @ np.linalg.inv(k_ref).T * depth[v, u][:, None]
    world = (camera_points - pose_ref[:, 3]) @ pose_ref[:, :3]
    return world, float(np.median(depths_seen) / k_ref[0, 0])


def sweep_partners(
    reconstruction, shared: dict, partners: int, min_angle: float, best_angle: float, max_angle: float
) -> dict[int, list[int]]:
    """Each registered image's best partners for the sweep: most shared sparse points, weighted
    by triangulation angle up to ``best_angle``; no sideways condition (that is the point)."""

    scored: dict[int, list] = {}
    for (a, b), pids in shared.items():
        if len(pids) < 30:
            continue
        angle = pair_angle(reconstruction, a, b, pids)
        if min_angle <= angle <= max_angle:
            score = len(pids) * min(angle, best_angle) / best_angle
            scored.setdefault(a, []).append((score, b))
            scored.setdefault(b, []).append((score, a))
    return {ref: [p for _, p in sorted(options, reverse=True)[:partners]] for ref, options in scored.items()}


def seen_depths(reconstruction, ref: int) -> np.ndarray:
    """Depths, in the reference camera, of the sparse points it sees."""
    image = reconstruction.images[ref]
    ids = [pt.point3D_id for pt in image.points2D if pt.has_point3D()]
    if not ids:
        return np.zeros(0)
    xyz = np.array([reconstruction.points3D[i].xyz for i in ids])
    pose = image.cam_from_world().matrix()
    depth = xyz @ pose[2, :3] + pose[2, 3]
    return depth[depth > 0]
