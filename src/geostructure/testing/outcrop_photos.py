"""The synthetic rough outcrop (:func:`~geostructure.synthetic.outcrop_scene`) photographed
from a drone, so that ``geostructure run`` rebuilds it with real SfM artefacts (matching
noise, smoothed edges, holes where the views miss) over exact truth.

The face is drawn as a dense cloud of its own surface (a few millimetres apart, roughness
included, no measurement noise), each point coloured by a texture fixed in space (value
noise at four scales, so every view sees the same rock) and shaded by its facet's normal
under a sun; each photo is those points splatted into a pinhole camera through a z-buffer,
its few empty pixels filled from their neighbours. The drone flies rows parallel to the
face, looking at it, as a photogrammetric survey of a rock face is flown. Ground control
points are facet centres, observed where a photo sees them.
"""

from __future__ import annotations

import csv
from dataclasses import replace
from pathlib import Path

import numpy as np

from geostructure.synthetic import outcrop_scene
from geostructure.testing.render import Camera, look_at

#: Value noise: wavelengths (m) and weights of its octaves.
TEXTURE_OCTAVES = ((0.012, 0.5), (0.04, 1.0), (0.13, 1.3), (0.5, 1.0))
#: A table of random values the lattice hashes into.
TABLE_SIZE = 1 << 20


def value_noise(points: np.ndarray, seed: int = 0) -> np.ndarray:
    """Multi-scale value noise (N,) at 3-D ``points``, about 0 with unit spread: a texture
    fixed in space, so every photo sees the same rock.

    Examples
    --------
    >>> p = np.random.default_rng(0).random((1000, 3))
    >>> bool(np.allclose(value_noise(p), value_noise(p))), bool(abs(value_noise(p).mean()) < 0.5)
    (True, True)
    """
    table = np.random.default_rng(seed).standard_normal(TABLE_SIZE)
    total = np.zeros(len(points))
    for wavelength, weight in TEXTURE_OCTAVES:
        scaled = points / wavelength
        base = np.floor(scaled).astype(np.int64)
        frac = scaled - base
        smooth = frac * frac * (3.0 - 2.0 * frac)  # smoothstep: no creases at the lattice
        for corner in range(8):
            offset = np.array([(corner >> a) & 1 for a in range(3)])
            key = base + offset
            index = (key[:, 0] * 73856093) ^ (key[:, 1] * 19349663) ^ (key[:, 2] * 83492791)
            w = np.prod(np.where(offset, smooth, 1.0 - smooth), axis=1)
            total += weight * w * table[index % TABLE_SIZE]
    return total / np.sqrt(sum(w * w for _, w in TEXTURE_OCTAVES))


def drone_path(scene, distance: float = 7.0, rows: int = 2, per_row: int = 12, focal: float = 900.0,
               size=(1024, 768)) -> list[Camera]:  # fmt: skip
    """Rows of views parallel to the face, ``distance`` from it, each looking at the point
    of the face straight ahead (slightly inwards at the row's ends), as a survey is flown."""
    along, up_dip = scene.face_axes
    width, height = scene.face_size
    normal = scene.face_normal
    origin = scene.offset
    cameras = []
    for r in range(rows):
        b = height * (r + 1) / (rows + 1)
        for a in np.linspace(0.1 * width, 0.9 * width, per_row):
            target = origin + a * along + b * up_dip
            eye = target + distance * normal + 0.08 * (a - width / 2) * along
            cameras.append(look_at(eye, target, focal, *size))
    return cameras


def riser_points(points: np.ndarray, scene, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """Points on the risers between facets (N', 3) and their normals (N', 3): the synthetic
    face is a height field over the mean face, whose steps (up to metres deep) have no side
    walls; seen at an angle, the sky showed through them. Each step between two cells of a
    ``spacing`` grid over the face is walled with points ``spacing`` apart."""
    along, up_dip = scene.face_axes
    local = points - scene.offset
    ab = np.stack([local @ along, local @ up_dip], axis=1)
    depth = local @ scene.face_normal
    key = np.floor(ab / spacing).astype(np.int64)
    shape = key.max(axis=0) + 1
    grid = np.full(tuple(shape), np.nan)
    grid[key[:, 0], key[:, 1]] = depth
    walls, normals = [], []
    for axis, direction in ((0, along), (1, up_dip)):
        a = np.moveaxis(grid, axis, 0)
        near, far = a[:-1], a[1:]
        jump = np.abs(far - near) > 2.0 * spacing
        i, j = np.nonzero(jump)
        lo, hi = np.minimum(near[i, j], far[i, j]), np.maximum(near[i, j], far[i, j])
        count = np.ceil((hi - lo) / spacing).astype(np.int64)
        step = np.repeat(np.arange(len(count)), count)
        rank = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
        d = lo[step] + (rank + 0.5) * spacing
        cell = np.stack([i, j], axis=1) if axis == 0 else np.stack([j, i], axis=1)
        position = (cell[step] + 0.5) * spacing
        position[:, axis] += 0.5 * spacing  # on the boundary between the two cells
        walls.append(position[:, :1] * along + position[:, 1:] * up_dip + d[:, None] * scene.face_normal)
        normals.append(np.tile(direction, (len(d), 1)))
    return np.vstack(walls) + scene.offset, np.vstack(normals)


def render_points(camera: Camera, points: np.ndarray, grey: np.ndarray, sky: float = 200.0) -> np.ndarray:
    """(H, W) uint8 photo of coloured points through a z-buffer; pixels no point reached
    inside the rock are filled from their neighbours (OpenCV's inpainting)."""
    import cv2

    uv, z = camera.project(points)
    col, row = np.floor(uv[:, 0]).astype(np.int64), np.floor(uv[:, 1]).astype(np.int64)
    inside = (z > 0) & (col >= 0) & (row >= 0) & (col < camera.width) & (row < camera.height)
    pixel = row[inside] * camera.width + col[inside]
    order = np.argsort(-z[inside], kind="stable")  # far first: the nearest is written last
    image = np.full(camera.width * camera.height, -1.0)
    image[pixel[order]] = grey[inside][order]
    image = image.reshape(camera.height, camera.width)
    empty = image < 0
    # Holes inside the rock (a pixel between points) are filled; the sky stays sky.
    rock = cv2.morphologyEx((~empty).astype(np.uint8), cv2.MORPH_CLOSE, np.ones((5, 5), np.uint8)) > 0
    image[empty & ~rock] = sky
    filled = np.clip(image, 0, 255).astype(np.uint8)
    return cv2.inpaint(filled, (empty & rock).astype(np.uint8), 2, cv2.INPAINT_TELEA)


def write_outcrop_photos(outdir, *, width: float = 6.0, height: float = 4.0, surface_spacing: float = 0.005,
                         seed: int = 0, cameras=None, **scene_options):  # fmt: skip
    """Photograph a synthetic outcrop into ``outdir/photos`` (PNG), with ``gcp.csv`` (the
    facet centres each photo sees) and return (scene, photo folder, gcp path). The scene is
    :func:`~geostructure.synthetic.outcrop_scene` with ``scene_options``, drawn at
    ``surface_spacing`` without measurement noise (the photos and SfM make their own)."""
    import cv2

    outdir = Path(outdir)
    photos = outdir / "photos"
    photos.mkdir(parents=True, exist_ok=True)
    options = {"noise": 0.0, "correlated_noise": 0.0, "outlier_fraction": 0.0, "cameras": 0, **scene_options}
    scene = outcrop_scene(width=width, height=height, point_spacing=surface_spacing, seed=seed, **options)
    points = scene.cloud.points
    facet = scene.facet_index
    normal = np.where(facet[:, None] >= 0, scene.facet_normal[np.maximum(facet, 0)], scene.face_normal)
    sun = np.array([0.45, -0.55, 0.70])
    sun /= np.linalg.norm(sun)
    shade = 0.45 + 0.55 * np.abs(normal @ sun)
    walls, wall_normals = riser_points(points, scene, surface_spacing)
    points = np.vstack([points, walls])
    shade = np.r_[shade, 0.45 + 0.55 * np.abs(wall_normals @ sun)]
    grey = np.clip((128.0 + 42.0 * value_noise(points - scene.offset, seed)) * shade, 0, 255)
    cameras = drone_path(scene) if cameras is None else cameras
    # Control points: facet centres spread over the face, where the photos see them.
    chosen = _spread(scene.facet_center, 8, seed)
    rows = []
    for index, camera in enumerate(cameras):
        image = render_points(camera, points, grey)
        name = f"photo_{index:03d}.png"
        cv2.imwrite(str(photos / name), image)
        uv, z = camera.project(scene.facet_center[chosen])
        for k, (u, v), depth in zip(chosen, uv, z):
            if depth > 0 and 0 <= u < camera.width and 0 <= v < camera.height:
                rows.append((f"gcp_{k}", *scene.facet_center[k], name, u, v))
    gcp = outdir / "gcp.csv"
    with open(gcp, "w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(["name", "E", "N", "Up", "image", "u", "v"])
        writer.writerows(rows)
    return replace(scene), photos, gcp


def _spread(centres: np.ndarray, n: int, seed: int) -> np.ndarray:
    """``n`` of ``centres`` far from each other (farthest-point sampling from a random one)."""
    rng = np.random.default_rng(seed)
    chosen = [int(rng.integers(len(centres)))]
    distance = np.linalg.norm(centres - centres[chosen[0]], axis=1)
    for _ in range(min(n, len(centres)) - 1):
        chosen.append(int(distance.argmax()))
        distance = np.minimum(distance, np.linalg.norm(centres - centres[chosen[-1]], axis=1))
    return np.array(chosen)
