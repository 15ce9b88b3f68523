"""A synthetic outcrop filmed by a moving camera: textured planes of known orientation,
rendered by ray casting, written as a video, with ground control points seen in the frames.

It gives the reconstruction stages exact truth: every face's dip and dip direction, and the
pixel where each control point appears in each frame.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np

#: (name, centre E N Up, dip, dip direction, width, height): faces of an outcrop seen from the south.
FACES = (
    ("face_south", (0.0, 10.0, 2.2), 72.0, 185.0, 7.0, 4.5),
    ("face_east", (-5.2, 8.6, 2.0), 58.0, 125.0, 5.0, 4.0),
    ("face_west", (5.4, 8.8, 2.0), 64.0, 235.0, 5.0, 4.0),
    ("bench", (0.0, 5.5, 0.0), 8.0, 200.0, 16.0, 9.0),
)


@dataclass(frozen=True)
class Face:
    name: str
    centre: np.ndarray
    normal: np.ndarray  # upward unit normal, ENU
    u: np.ndarray  # strike direction
    v: np.ndarray  # up-dip direction in the plane
    width: float
    height: float
    dip: float
    dip_direction: float


def make_face(name, centre, dip, dip_direction, width, height) -> Face:
    d, dd = np.radians(dip), np.radians(dip_direction)
    normal = np.array([np.sin(d) * np.sin(dd), np.sin(d) * np.cos(dd), np.cos(d)])
    u = np.array([-np.cos(dd), np.sin(dd), 0.0])
    return Face(name, np.asarray(centre, float), normal, u, np.cross(normal, u), width, height, dip, dip_direction)


def faces() -> list[Face]:
    return [make_face(*f) for f in FACES]


@dataclass(frozen=True)
class Camera:
    """Pinhole camera in OpenCV/COLMAP axes (x right, y down, z forward)."""

    rotation: np.ndarray  # world -> camera
    centre: np.ndarray
    focal: float
    width: int
    height: int

    def project(self, points: np.ndarray):
        """Pixel coordinates and depth of world points."""
        cam = (np.asarray(points, float) - self.centre) @ self.rotation.T
        uv = self.focal * cam[:, :2] / cam[:, 2:3] + [self.width / 2, self.height / 2]
        return uv, cam[:, 2]


def look_at(centre, target, focal=520.0, width=640, height=480) -> Camera:
    forward = np.asarray(target, float) - centre
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    down = np.cross(forward, right)
    return Camera(np.vstack([right, down, forward]), np.asarray(centre, float), focal, width, height)


def camera_path(n_frames: int, radius: float = 13.0, sweep_deg: float = 70.0, height: float = 2.6):
    """An arc south of the outcrop, looking at its middle, as someone filming while walking."""
    target = np.array([0.0, 8.5, 1.6])
    angles = np.radians(np.linspace(-sweep_deg / 2, sweep_deg / 2, n_frames))
    return [
        look_at(target + [radius * np.sin(a), -radius * np.cos(a), height - target[2] + 0.3 * np.sin(3 * a)], target)
        for a in angles
    ]


def textures(n: int, size: int = 512, seed: int = 0) -> list[np.ndarray]:
    """Multi-scale noise, rich in corners at every scale SIFT looks at."""
    from scipy.ndimage import gaussian_filter

    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        t = sum(
            w * gaussian_filter(rng.normal(size=(size, size)), s, mode="wrap")
            for s, w in ((1.0, 0.6), (3.0, 2.0), (8.0, 5.0), (20.0, 9.0))
        )
        t = (t - t.mean()) / t.std()
        out.append(np.clip(128 + 45 * t, 0, 255))
    return out


def render(camera: Camera, scene_faces, scene_textures, texels_per_metre: float = 64.0):
    """(H, W) grey image and (H, W) depth (inf where the ray hits nothing)."""
    h, w = camera.height, camera.width
    px, py = np.meshgrid(np.arange(w) + 0.5 - w / 2, np.arange(h) + 0.5 - h / 2)
    rays = np.stack([px, py, np.full_like(px, camera.focal)], axis=-1) @ camera.rotation  # world directions
    rays = rays.reshape(-1, 3)
    depth = np.full(len(rays), np.inf)
    image = np.zeros(len(rays))
    sun = np.array([0.4, -0.5, 0.77])
    for face, texture in zip(scene_faces, scene_textures):
        denom = rays @ face.normal
        with np.errstate(divide="ignore", invalid="ignore"):
            t = ((face.centre - camera.centre) @ face.normal) / denom
        hit = camera.centre + t[:, None] * rays
        a, b = (hit - face.centre) @ face.u, (hit - face.centre) @ face.v
        inside = (t > 0) & (np.abs(a) <= face.width / 2) & (np.abs(b) <= face.height / 2)
        z = t * (rays @ camera.rotation[2])
        nearer = inside & (z < depth)
        depth[nearer] = z[nearer]
        size = texture.shape[0]
        ti = ((a[nearer] * texels_per_metre) % size).astype(int)
        tj = ((b[nearer] * texels_per_metre) % size).astype(int)
        image[nearer] = texture[tj, ti] * (0.55 + 0.45 * max(face.normal @ sun, 0))
    image[np.isinf(depth)] = 200.0  # featureless sky
    return image.reshape(h, w).astype(np.uint8), depth.reshape(h, w)


def control_points(scene_faces) -> dict[str, np.ndarray]:
    """Marks near the corners of the faces: what a surveyor would paint and measure."""
    points = {}
    for face in scene_faces[:3]:
        for i, (sa, sb) in enumerate(((-0.4, -0.35), (0.4, -0.35), (0.4, 0.35), (-0.4, 0.35))):
            points[f"{face.name}_{i}"] = face.centre + sa * face.width * face.u + sb * face.height * face.v
    return points


def write_video(path, frames, fps: float = 10.0) -> Path:
    """Grey frames as an MPEG-4 video (the codec every FFmpeg build has)."""
    import av

    path = Path(path)
    with av.open(str(path), "w") as container:
        stream = container.add_stream("mpeg4", rate=int(fps))
        stream.width, stream.height = frames[0].shape[1], frames[0].shape[0]
        stream.pix_fmt = "yuv420p"
        stream.bit_rate = 8_000_000
        for image in frames:
            frame = av.VideoFrame.from_ndarray(np.repeat(image[..., None], 3, axis=2), format="rgb24")
            for packet in stream.encode(frame):
                container.mux(packet)
        for packet in stream.encode():
            container.mux(packet)
    return path


def approach_path(n_frames: int, start: float = -6.0, end: float = 1.0, height: float = 2.0):
    """Walking straight at the outcrop's middle: the views move along their axis."""
    target = np.array([0.0, 8.5, 1.6])
    return [look_at(np.array([0.2, y, height]), target) for y in np.linspace(start, end, n_frames)]


def _render_scene(outdir: Path, cameras, seed: int):
    """Frames of ``cameras``, the control marks each sees (rows for gcp.csv), and truth.csv."""
    scene_faces = faces()
    scene_textures = textures(len(scene_faces), seed=seed)
    frames, observations = [], []
    marks = control_points(scene_faces)
    for index, camera in enumerate(cameras):
        image, depth = render(camera, scene_faces, scene_textures)
        frames.append(image)
        uv, z = camera.project(np.array(list(marks.values())))
        for name, (u, v), zz in zip(marks, uv, z):
            if 0 <= u < camera.width and 0 <= v < camera.height and zz > 0 and zz <= depth[int(v), int(u)] + 0.05:
                observations.append((name, *marks[name], f"frame_{index:06d}", u, v))
    truth = outdir / "truth.csv"
    with open(truth, "w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(["surface", "dip", "dip_direction", "center_x", "center_y", "center_z"])
        for f in scene_faces:
            writer.writerow([f.name, f.dip, f.dip_direction, *f.centre])
    return frames, observations, truth


def _write_gcp(path: Path, observations, suffix: str) -> Path:
    with open(path, "w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(["name", "E", "N", "Up", "image", "u", "v"])
        writer.writerows((*row[:4], row[4] + suffix, *row[5:]) for row in observations)
    return path


def write_scene_video(outdir, n_frames: int = 36, fps: float = 10.0, seed: int = 0):
    """Render the outcrop into ``outdir/outcrop.mp4``, with ``gcp.csv`` (pixel observations,
    by the name ``frames`` gives the frame: ``frame_000012.jpg`` for the 13th) and
    ``truth.csv``; returns their paths."""
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    frames, observations, truth = _render_scene(outdir, camera_path(n_frames), seed)
    video = write_video(outdir / "outcrop.mp4", frames, fps)
    return video, _write_gcp(outdir / "gcp.csv", observations, ".jpg"), truth


def write_scene_photos(outdir, cameras, seed: int = 0):
    """Render the outcrop from ``cameras`` as ``outdir/photos/frame_NNNNNN.png``, with
    ``gcp.csv`` and ``truth.csv``; returns (photo folder, gcp, truth)."""
    import cv2

    outdir = Path(outdir)
    photos = outdir / "photos"
    photos.mkdir(parents=True, exist_ok=True)
    frames, observations, truth = _render_scene(outdir, cameras, seed)
    for index, image in enumerate(frames):
        cv2.imwrite(str(photos / f"frame_{index:06d}.png"), image)
    return photos, _write_gcp(outdir / "gcp.csv", observations, ".png"), truth
