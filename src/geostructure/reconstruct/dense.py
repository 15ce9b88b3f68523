"""Dense cloud from a sparse SfM model.

Two paths on the same undistorted images (``pycolmap.undistort_images``):

- ``colmap`` (needs a CUDA build of pycolmap): PatchMatch stereo and COLMAP's fusion;
- ``sgbm`` (any machine): each image with its best neighbours, rectified pairwise, OpenCV
  semi-global block matching with its left-right check (``disp12MaxDiff``), triangulated;
  the pair clouds are then fused on a fine grid, keeping only cells that at least
  ``min_pairs`` different pairs agree on (one pair's mismatch rarely repeats in another's);
- ``sweep`` (any machine): a plane-sweep depth map per image (:mod:`.planesweep`), fused the
  same way; for cameras that move along their view, which rectification cannot take.
  ``auto`` without CUDA picks it when fewer than half the images have a sideways partner.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from geostructure.errors import GeoStructureError
from geostructure.reconstruct.planesweep import SweepOptions, depth_map, seen_depths, sweep_partners
from geostructure.reconstruct.sfm import pair_angle, quiet_colmap

SWEEP_MIN_ANGLE = 2.0  # degrees; forward steps give small angles on the shared points


@dataclass(frozen=True)
class DenseOptions:
    method: str = "auto"  # auto (colmap with CUDA, else sgbm or sweep) | colmap | sgbm | sweep
    max_image_size: int = 1200  # matching resolution (px, longest side)
    neighbours: int = 2  # stereo partners per image
    min_angle: float = 5.0  # degrees of triangulation angle a pair needs
    best_angle: float = 15.0  # depth noise falls as the angle grows; matching gets harder past this
    max_angle: float = 40.0
    block_size: int = 5
    min_pairs: int = 2  # pairs that must agree on a fused cell
    cell_pixels: float = 2.0  # fused cell edge, in pixel footprints at the median depth
    canvas: float = 1.4  # rectified image size over the input's, per side


@dataclass
class DenseReport:
    method: str
    points: int
    pairs: int
    seconds: float

    def summary(self) -> str:
        unit = "stereo pairs" if self.method == "sgbm" else "depth maps"
        return f"{self.points:,} dense points from {self.pairs} {unit} ({self.method}) in {self.seconds:.1f} s"


def undistort(sparse_dir, image_dir, workdir) -> Path:
    """COLMAP's undistortion: pinhole images and model under ``workdir`` (reused if present)."""
    import pycolmap

    workdir = Path(workdir)
    if not (workdir / "sparse").exists():
        pycolmap.undistort_images(workdir, sparse_dir, image_dir)
    return workdir


def dense_cloud(sparse_dir, image_dir, workdir, options: DenseOptions = DenseOptions(), progress=None):
    """Returns ((N, 3) points in model coordinates, DenseReport)."""
    import pycolmap

    t = time.perf_counter()
    method = options.method
    if method == "colmap" and not pycolmap.has_cuda:
        raise GeoStructureError(
            "`dense='colmap'` needs pycolmap built with CUDA (pip install pycolmap-cuda12 on a "
            "machine with an NVIDIA GPU); use `dense='sgbm'` or `dense='sweep'` here."
        )
    if method not in ("auto", "colmap", "sgbm", "sweep"):
        raise GeoStructureError(f"unknown dense method '{method}'; use auto, colmap, sgbm or sweep.")

    with quiet_colmap():
        workdir = undistort(sparse_dir, image_dir, workdir)
        if method == "colmap" or (method == "auto" and pycolmap.has_cuda):
            method, (points, pairs) = "colmap", _colmap(workdir, options, progress)
        else:  # the CPU paths share the model and the points each pair of images sees
            model = pycolmap.Reconstruction(workdir / "sparse")
            shared = shared_points(model)
            chosen = choose_pairs(model, options, shared)
            if method == "auto":
                # sgbm when at least half the images have a partner beside them to rectify
                # with, else the plane sweep (a walk along the view: a street, towards a cliff)
                paired = {i for pair in chosen for i in pair}
                method = "sgbm" if 2 * len(paired) >= model.num_reg_images() else "sweep"
            if method == "sgbm":
                points, pairs = _sgbm(model, shared, chosen, workdir / "images", options, progress)
            else:
                points, pairs = _sweep(model, shared, workdir / "images", options, progress)
    if len(points) < 100:
        unit = "stereo pairs" if method == "sgbm" else "depth maps"
        raise GeoStructureError(
            f"the dense stage found {len(points)} points from {pairs} {unit}; the images may be "
            "too few, too far apart, or taken walking straight towards the scene (stereo "
            "needs sideways steps). Try `dense_neighbours=4`, or measure the sparse cloud "
            "(`dense='none'`)."
        )
    return points, DenseReport(method, len(points), pairs, time.perf_counter() - t)


def _colmap(workdir: Path, options: DenseOptions, progress):
    import pycolmap

    report = progress or (lambda stage, done, total: None)
    report("dense", 0, None)
    patch_match = pycolmap.PatchMatchOptions()
    patch_match.max_image_size = options.max_image_size  # the same resolution as the sgbm path
    pycolmap.patch_match_stereo(workdir, options=patch_match)
    fused_dir = workdir / "fused"
    fused_dir.mkdir(exist_ok=True)  # fusion writes a COLMAP model (a folder) when output_type is bin
    fused = pycolmap.stereo_fusion(fused_dir, workdir)
    points = np.array([p.xyz for p in fused.points3D.values()]).reshape(-1, 3)
    return points, len(fused.images)


def shared_points(reconstruction) -> dict[tuple[int, int], list[int]]:
    """Sparse point ids seen by each pair of registered images (a < b), from one pass over the tracks."""
    posed = {i for i, img in reconstruction.images.items() if img.has_pose}
    shared: dict[tuple[int, int], list[int]] = {}
    for pid, point in reconstruction.points3D.items():
        ids = sorted({el.image_id for el in point.track.elements if el.image_id in posed})
        for a in range(len(ids)):
            for b in range(a + 1, len(ids)):
                shared.setdefault((ids[a], ids[b]), []).append(pid)
    return shared


def choose_pairs(reconstruction, options: DenseOptions, shared=None) -> list[tuple[int, int]]:
    """Each image with its ``neighbours`` best partners: those sharing most sparse points,
    weighted by triangulation angle up to ``best_angle`` (a short baseline gives noisy depth),
    among those whose angle on the shared points is within [min_angle, max_angle]."""
    images = {i: img for i, img in reconstruction.images.items() if img.has_pose}
    shared = shared_points(reconstruction) if shared is None else shared
    scored = []
    for (a, b), pids in shared.items():
        if len(pids) < 30:
            continue
        angle = pair_angle(reconstruction, a, b, pids)
        if options.min_angle <= angle <= options.max_angle and _sideways(images[a], images[b]):
            scored.append((len(pids) * min(angle, options.best_angle) / options.best_angle, a, b))
    scored.sort(reverse=True)
    count: dict[int, int] = {}
    pairs = []
    for _, a, b in scored:
        if count.get(a, 0) < options.neighbours or count.get(b, 0) < options.neighbours:
            pairs.append((a, b))
            count[a], count[b] = count.get(a, 0) + 1, count.get(b, 0) + 1
    return pairs


def _sideways(img_a, img_b, min_ratio: float = 0.8) -> bool:
    """Whether b sits mostly beside a (not ahead or behind): pairs moving along the view
    axis rectify badly, their epipoles falling inside the images."""
    for first, second in ((img_a, img_b), (img_b, img_a)):
        baseline = np.asarray(first.cam_from_world() * second.projection_center())
        if np.hypot(baseline[0], baseline[1]) < min_ratio * np.linalg.norm(baseline):
            return False
    return True


def _sweep(reconstruction, shared, image_dir: Path, options: DenseOptions, progress):

    report = progress or (lambda stage, done, total: None)
    sweep = SweepOptions(partners=options.neighbours)
    partners = sweep_partners(
        reconstruction, shared, sweep.partners, SWEEP_MIN_ANGLE, options.best_angle, options.max_angle
    )
    clouds, footprints = [], []
    for n, (ref, others) in enumerate(sorted(partners.items())):
        report("dense", n, len(partners))
        depths = seen_depths(reconstruction, ref)
        if len(depths) < 10:
            continue
        points, footprint = depth_map(reconstruction, ref, others, depths, image_dir, sweep)
        clouds.append(points)
        footprints.append(footprint)
    report("dense", len(partners), len(partners))
    if not any(len(c) for c in clouds):
        return np.zeros((0, 3)), len(clouds)
    cell = options.cell_pixels * float(np.nanmedian(footprints))
    return fuse(clouds, cell, options.min_pairs), len(clouds)


def _sgbm(reconstruction, shared, pairs, image_dir: Path, options: DenseOptions, progress):
    report = progress or (lambda stage, done, total: None)
    clouds, footprints = [], []
    for n, (a, b) in enumerate(pairs):
        report("dense", n, len(pairs))
        xyz = np.array([reconstruction.points3D[p].xyz for p in shared[(a, b)]]).reshape(-1, 3)
        points, footprint = pair_points(reconstruction, a, b, xyz, image_dir, options)
        clouds.append(points)
        footprints.append(footprint)
    report("dense", len(pairs), len(pairs))
    if not clouds:
        return np.zeros((0, 3)), 0
    if not any(len(c) for c in clouds):
        return np.zeros((0, 3)), len(pairs)
    cell = options.cell_pixels * float(np.nanmedian(footprints))
    return fuse(clouds, cell, options.min_pairs), len(pairs)


def pair_points(reconstruction, a: int, b: int, xyz: np.ndarray, image_dir: Path, options: DenseOptions):
    """Points of one rectified pair in model coordinates, and the pixel footprint (model
    units per pixel) at the pair's median depth; ``xyz`` are the sparse points both see."""
    import cv2

    img_a, img_b = reconstruction.images[a], reconstruction.images[b]
    if (img_a.cam_from_world() * img_b.projection_center())[0] < 0:
        img_a, img_b, a, b = img_b, img_a, b, a  # SGBM wants the right camera on the right
    left = cv2.imread(str(image_dir / img_a.name), cv2.IMREAD_GRAYSCALE)
    right = cv2.imread(str(image_dir / img_b.name), cv2.IMREAD_GRAYSCALE)
    if left is None or right is None:
        raise GeoStructureError(f"{image_dir}: cannot read {img_a.name} or {img_b.name}.")
    scale = min(1.0, options.max_image_size / max(left.shape))
    size = (round(left.shape[1] * scale), round(left.shape[0] * scale))
    left = cv2.resize(left, size, interpolation=cv2.INTER_AREA)
    right = cv2.resize(
        right, (round(right.shape[1] * scale), round(right.shape[0] * scale)), interpolation=cv2.INTER_AREA
    )
    k1, k2 = _intrinsics(img_a.camera, scale), _intrinsics(img_b.camera, scale)
    pose_a, pose_b = img_a.cam_from_world().matrix(), img_b.cam_from_world().matrix()
    rotation = pose_b[:, :3] @ pose_a[:, :3].T
    translation = pose_b[:, 3] - rotation @ pose_a[:, 3]
    no_distortion = np.zeros(5)  # the images are already undistorted
    # alpha=1 keeps every pixel (convergent views would lose their edges), on a canvas large
    # enough that the rotated images keep their resolution
    canvas = (round(size[0] * options.canvas), round(size[1] * options.canvas))
    r1, r2, p1, p2, q, _, _ = cv2.stereoRectify(
        k1,
        no_distortion,
        k2,
        no_distortion,
        size,
        np.ascontiguousarray(rotation),
        translation.reshape(3, 1),
        flags=cv2.CALIB_ZERO_DISPARITY,
        alpha=1,
        newImageSize=canvas,
    )
    map_l = cv2.initUndistortRectifyMap(k1, no_distortion, r1, p1, canvas, cv2.CV_32FC1)
    map_r = cv2.initUndistortRectifyMap(k2, no_distortion, r2, p2, canvas, cv2.CV_32FC1)
    rect_l = cv2.remap(left, *map_l, cv2.INTER_LINEAR)
    rect_r = cv2.remap(right, *map_r, cv2.INTER_LINEAR)

    # disparity search range from the sparse points both images see
    cam = xyz @ pose_a[:, :3].T + pose_a[:, 3]
    rect = cam @ r1.T
    disparity = p1[0, 0] * rect[:, 0] / rect[:, 2] - (p2[0, 0] * rect[:, 0] + p2[0, 3]) / rect[:, 2]
    lo, hi = np.percentile(disparity, [1, 99]) if len(disparity) else (0, 64)
    margin = 0.15 * (hi - lo) + 4
    min_disp = int(np.floor(lo - margin))
    num_disp = int(np.ceil((hi - lo + 2 * margin) / 16) * 16)
    num_disp = int(np.clip(num_disp, 16, 512))
    block = options.block_size
    matcher = cv2.StereoSGBM_create(
        minDisparity=min_disp,
        numDisparities=num_disp,
        blockSize=block,
        P1=8 * block * block,
        P2=32 * block * block,
        disp12MaxDiff=1,
        uniquenessRatio=10,
        speckleWindowSize=100,
        speckleRange=2,
        mode=cv2.STEREO_SGBM_MODE_SGBM,
    )
    if (rect_l > 0).mean() < 0.1:  # rectification pushed the view off the canvas: no pair to match
        return np.zeros((0, 3)), np.nan
    disp = matcher.compute(rect_l, rect_r).astype(np.float32) / 16.0
    valid = (disp > min_disp) & (rect_l > 0)
    points = cv2.reprojectImageTo3D(disp, q)[valid]
    points = points[np.isfinite(points).all(axis=1) & (points[:, 2] > 0)]
    cam_a = points @ r1  # rectified -> camera a (r1 rotates camera a into the rectified frame)
    world = (cam_a - pose_a[:, 3]) @ pose_a[:, :3]
    depth = np.median(cam[:, 2]) if len(cam) else 1.0
    return world, float(abs(depth / p1[0, 0]))


def _intrinsics(camera, scale: float) -> np.ndarray:
    k = np.array(camera.calibration_matrix(), dtype=np.float64)
    k[:2] *= scale
    return k


def fuse(clouds: list[np.ndarray], cell: float, min_pairs: int) -> np.ndarray:
    """One point (the mean) per grid cell that ``min_pairs`` distinct pairs put points in."""
    points = np.concatenate(clouds)
    pair = np.repeat(np.arange(len(clouds)), [len(c) for c in clouds])
    keys = np.floor((points - points.min(axis=0)) / cell).astype(np.int64)
    _, cell_id = np.unique(keys, axis=0, return_inverse=True)
    cell_id = cell_id.ravel()
    distinct = np.unique(np.c_[cell_id, pair], axis=0)
    support = np.bincount(distinct[:, 0], minlength=cell_id.max() + 1)
    count = np.bincount(cell_id)
    means = np.stack([np.bincount(cell_id, points[:, i]) for i in range(3)], axis=1) / np.maximum(count, 1)[:, None]
    return means[support >= min_pairs]
