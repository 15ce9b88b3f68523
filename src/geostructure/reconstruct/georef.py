"""Georeferencing: tie an SfM model (arbitrary position, scale and rotation) to the world.

Three sources, best first:

- ground control points: world (E, N, Up) of marks seen in the images (pixel observations,
  triangulated in the model) or given in model coordinates; solved as a similarity
  transform (Umeyama 1991) with each point's residual;
- camera GPS from EXIF: camera centres against their GPS positions, with gravity taken
  from the cameras' horizontal x axes (people hold cameras without roll); approximate;
- a manual frame: the model's up and north vectors and a scale.

World coordinates are the GCPs' own projected coordinates (E, N, Up), or, from WGS84
positions (EXIF GPS, OpenSfM GCP JSON), a local east-north-up frame in metres about the mean
latitude and longitude at altitude 0 (recorded as ``enu_origin``); either way the measuring
stage's ``enu`` frame applies to the transformed cloud.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from geostructure.core.alignment import similarity as umeyama  # the name control-point code and its tests know
from geostructure.core.geodesy import geodetic_to_enu
from geostructure.core.orientation import Frame
from geostructure.errors import InputError
from geostructure.io.usercsv import read_user_rows, user_text


@dataclass
class Georeference:
    """world = scale * rotation @ model + translation."""

    scale: float
    rotation: np.ndarray
    translation: np.ndarray
    source: str  # gcp | exif-gps | manual
    approximate: bool = False
    residuals: dict = field(default_factory=dict)  # control point -> residual (world units)
    enu_origin: tuple | None = None  # (lat, lon, alt) that world (0, 0, 0) stands for, when from WGS84

    def apply(self, points: np.ndarray) -> np.ndarray:
        return self.scale * np.asarray(points, float) @ self.rotation.T + self.translation

    def to_dict(self) -> dict:
        return {
            "source": self.source,
            "approximate": self.approximate,
            "scale": float(self.scale),
            "rotation": self.rotation.tolist(),
            "translation": self.translation.tolist(),
            "residuals": {k: float(v) for k, v in self.residuals.items()},
            "enu_origin": None if self.enu_origin is None else [float(v) for v in self.enu_origin],
            "rms_residual": float(np.sqrt(np.mean(np.square(list(self.residuals.values())))))
            if self.residuals
            else None,
        }


def describe_georeference(record: dict) -> str:
    """One line for a georeference record (``Georeference.to_dict``), for logs and the report."""
    text = f"{record['source']}, scale {record['scale']:.4g}"
    if record.get("rms_residual") is not None:
        text += f", RMS residual {record['rms_residual']:.3g} over {len(record['residuals'])} points"
    return text + (" (approximate)" if record.get("approximate") else "")


def unscaled(run_record: dict) -> bool:
    """Whether a run's cloud is in the reconstruction's own units, not metres: levelled from
    the cameras, or set up by hand, at scale 1 (no control points, GPS or ``--scale``)."""
    georef = (run_record.get("reconstruction") or {}).get("georef") or {}
    return georef.get("source") in ("cameras-level", "manual") and georef.get("scale") == 1.0


def check_control_layout(world_points: dict, source) -> None:
    """Refuse control points that can fix no georeference, before any reconstruction: fewer
    than three, or all on one line (the rotation about it is unknown). Found only after
    SfM, they left a half-made output folder behind.

    Examples
    --------
    >>> check_control_layout({"a": (0, 0, 0), "b": (1, 1, 0), "c": (2, 2, 0)}, "gcp.csv")
    Traceback (most recent call last):
    ...
    geostructure.errors.InputError: gcp.csv: the 3 control points lie on one line; the rotation about it is unknown. Add one off the line.
    """
    if len(world_points) < 3:
        raise InputError(f"{source}: {len(world_points)} control point(s); at least 3, not in a line, are needed.")
    world = np.array(list(world_points.values()), dtype=np.float64)
    spread = float(np.ptp(world, axis=0).max())
    if spread == 0 or np.linalg.matrix_rank(world - world.mean(axis=0), tol=1e-9 * spread) < 2:
        raise InputError(
            f"{source}: the {len(world)} control points lie on one line; the rotation about it is unknown. "
            f"Add one off the line."
        )


def solve_gcp(model_points: dict, world_points: dict) -> Georeference:
    """Similarity from control points seen in the model; residual per point."""
    names = sorted(set(model_points) & set(world_points))
    if len(names) < 3:
        raise InputError(
            f"ground control: {len(names)} point(s) located in the model; at least 3 "
            "(not in a line) are needed. Check the names match and each is seen in 2+ images."
        )
    src = np.array([model_points[n] for n in names])
    dst = np.array([world_points[n] for n in names])
    if np.linalg.matrix_rank(src - src.mean(axis=0), tol=1e-9 * np.ptp(src, axis=0).max()) < 2:
        raise InputError("ground control points lie on one line; the rotation about it is unknown.")
    s, r, t = umeyama(src, dst)
    fitted = s * src @ r.T + t
    residuals = dict(zip(names, np.linalg.norm(fitted - dst, axis=1).tolist()))
    return Georeference(s, r, t, "gcp", False, residuals)


def manual(up, north, scale: float = 1.0) -> Georeference:
    """The user's word on which model directions are up and north, and the model's scale."""
    if not (np.isfinite(scale) and scale > 0):
        raise InputError(f"`scale` must be a positive finite number, not {scale}.")
    frame = Frame.from_up_north(up, north)
    return Georeference(float(scale), frame.matrix, np.zeros(3), "manual", approximate=False)


def read_gcp_csv(path) -> tuple[dict, list, dict]:
    """A GCP CSV: ``name, E, N, Up`` and either ``x, y, z`` (model coordinates) or
    ``image, u, v`` (pixel observations; one row per image a point is seen in).

    Returns (world by name, pixel observations [(name, image, u, v)], model points by name).
    """
    path = Path(path)
    table = [r for r in read_user_rows(path, "control-point") if any(c.strip() for c in r)]
    width = len(table[0]) if table else 0  # a short row's missing cells are None, as csv.DictReader gives them
    rows = [dict(zip(table[0], r + [None] * (width - len(r)))) for r in table[1:]]
    if not rows:
        raise InputError(f"{path}: holds no control points.")
    columns = {c.strip().lower(): c for c in rows[0] if c is not None}  # None: cells past the header
    need = ["name", "e", "n", "up"]
    has_model, has_pixels = all(c in columns for c in "xyz"), all(c in columns for c in ("image", "u", "v"))
    if not all(c in columns for c in need) or not (has_model or has_pixels):
        raise InputError(
            f"{path}: needs columns name, E, N, Up and either x, y, z (model) or image, u, v "
            f"(pixels); it has {', '.join(columns.values())}."
        )
    world, observations, model = {}, [], {}
    for line, row in enumerate(rows, start=2):
        get = lambda c: row[columns[c]].strip()  # noqa: E731
        try:
            name = get("name")
            world[name] = [float(get("e")), float(get("n")), float(get("up"))]
            if has_pixels and get("image"):
                observations.append((name, get("image"), float(get("u")), float(get("v"))))
            if has_model and get("x"):
                model[name] = [float(get("x")), float(get("y")), float(get("z"))]
        except (ValueError, TypeError, AttributeError):
            raise InputError(f"{path}, line {line}: a coordinate is missing or not a number.") from None
        values = (
            world[name]
            + (list(observations[-1][2:]) if observations and observations[-1][0] == name else [])
            + model.get(name, [])
        )
        if not np.isfinite(values).all():
            raise InputError(f"{path}, line {line}: a coordinate is NaN or infinite.")
    return world, observations, model


def read_gcp(path, image_dir=None) -> tuple[dict, list, dict, tuple | None]:
    """Control points from our CSV or from OpenSfM's ``ground_control_points.json``.

    Returns (world by name, pixel observations, model points by name, ENU origin or None);
    the origin (latitude, longitude, altitude) is set when the file gives WGS84 positions,
    which are turned into east-north-up metres about it.
    """
    if Path(path).suffix.lower() == ".json":
        return read_opensfm_gcp(path, image_dir)
    return (*read_gcp_csv(path), None)


def read_opensfm_gcp(path, image_dir) -> tuple[dict, list, dict, tuple | None]:
    """OpenSfM's GCP JSON: ``points`` with ``position`` {latitude, longitude, altitude} and
    ``observations`` [{shot_id, projection}] in OpenSfM's normalised image coordinates
    (pixel + 0.5 - size / 2, over the longer side); points without a position are skipped."""
    import json

    from PIL import Image

    path = Path(path)
    try:
        points = json.loads(user_text(path, "control-point"))["points"]
        located = [p for p in points if p.get("position")]
        fixes = np.array(
            [
                [p["position"]["latitude"], p["position"]["longitude"], p["position"].get("altitude", 0.0)]
                for p in located
            ],
            float,
        ).reshape(-1, 3)
    except FileNotFoundError:
        raise InputError(f"{path}: no such file.") from None
    except (ValueError, KeyError, TypeError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: not an OpenSfM ground_control_points.json ({exc}).") from None
    if not len(located):
        raise InputError(f"{path}: no control point has a position.")
    if not np.isfinite(fixes).all():
        raise InputError(f"{path}: a control point's latitude, longitude or altitude is NaN or infinite.")
    origin = (float(fixes[:, 0].mean()), float(fixes[:, 1].mean()), 0.0)
    enu = geodetic_to_enu(fixes[:, 0], fixes[:, 1], fixes[:, 2], origin)
    world = {str(p["id"]): e.tolist() for p, e in zip(located, enu)}
    sizes, observations = {}, []
    for p in located:
        for obs in p.get("observations", []):
            shot = obs["shot_id"]
            if shot not in sizes:
                try:
                    with Image.open(Path(image_dir or path.parent / "images") / shot) as image:
                        sizes[shot] = image.size
                except OSError:
                    raise InputError(
                        f"{path}: image {shot} of control point {p['id']} not found in {image_dir}."
                    ) from None
            width, height = sizes[shot]
            x, y = obs["projection"]
            observations.append(
                (str(p["id"]), shot, x * max(width, height) + width / 2, y * max(width, height) + height / 2)
            )
    return world, observations, {}, origin


def triangulate_observations(reconstruction, observations) -> dict:
    """Model coordinates of each control point seen in 2+ registered images (linear DLT on
    undistorted, normalised image coordinates)."""
    by_name = {img.name: img for img in reconstruction.images.values() if img.has_pose}
    rows: dict[str, list] = {}
    for name, image_name, u, v in observations:
        image = by_name.get(image_name)
        if image is None:
            continue
        x, y = image.camera.cam_from_img(np.array([[u, v]], float))[0]
        pose = image.cam_from_world().matrix()
        rows.setdefault(name, []).extend([x * pose[2] - pose[0], y * pose[2] - pose[1]])
    points = {}
    for name, equations in rows.items():
        if len(equations) >= 4:
            _, _, vt = np.linalg.svd(np.array(equations))
            points[name] = vt[-1, :3] / vt[-1, 3]
    return points


def gps_from_exif(path) -> tuple[float, float, float] | None:
    """(latitude, longitude, altitude m) from a photo's EXIF, or None."""
    from PIL import Image
    from PIL.ExifTags import IFD

    try:
        with Image.open(path) as image:
            gps = image.getexif().get_ifd(IFD.GPSInfo)
    except OSError:
        return None
    if not gps or 2 not in gps or 4 not in gps:
        return None
    lat = sum(float(v) / 60**i for i, v in enumerate(gps[2])) * (-1 if gps.get(1) == "S" else 1)
    lon = sum(float(v) / 60**i for i, v in enumerate(gps[4])) * (-1 if gps.get(3) == "W" else 1)
    alt = float(gps.get(6, 0.0)) * (-1 if gps.get(5) == b"\x01" else 1)
    return lat, lon, alt


def solve_exif_gps(reconstruction, image_dir) -> Georeference:
    """Camera centres against EXIF GPS: up from the cameras (:func:`camera_up`), then heading,
    scale and shift from the horizontal GPS track. Approximate (GPS is good to metres)."""
    centres, gps = [], []
    for image in reconstruction.images.values():
        fix = gps_from_exif(Path(image_dir) / image.name) if image.has_pose else None
        if fix is not None:
            centres.append(image.projection_center())
            gps.append(fix)
    if len(gps) < 3:
        raise InputError(f"{image_dir}: {len(gps)} registered photo(s) carry GPS in EXIF; at least 3 are needed.")
    gps = np.array(gps)
    origin = (float(gps[:, 0].mean()), float(gps[:, 1].mean()), 0.0)  # so Up stays the GPS altitude
    enu = geodetic_to_enu(gps[:, 0], gps[:, 1], gps[:, 2], origin)
    up = camera_up(reconstruction)
    centres = np.array(centres)
    level = _rotation_between(up, np.array([0.0, 0.0, 1.0]))
    flat = centres @ level.T
    s, r2, _ = umeyama(np.c_[flat[:, :2], np.zeros(len(flat))], np.c_[enu[:, :2], np.zeros(len(enu))])
    rotation = r2 @ level
    translation = enu.mean(axis=0) - s * rotation @ centres.mean(axis=0)
    geo = Georeference(s, rotation, translation, "exif-gps", approximate=True, enu_origin=origin)
    residual = np.linalg.norm(geo.apply(centres) - enu, axis=1)
    geo.residuals = {f"camera {i}": float(v) for i, v in enumerate(residual)}
    return geo


def camera_up(reconstruction, min_spread: float = 0.01) -> np.ndarray:
    """Model up from the registered cameras, as OpenSfM's upright step does: people hold
    cameras without roll, so each camera's x axis is horizontal and up is the direction most
    nearly perpendicular to all of them. Pitch is not assumed level (people tilt cameras up at
    a cliff or a facade). When the x axes barely turn (second eigenvalue of their scatter under
    ``min_spread`` of the first: all cameras face one way), they leave the pitch open, and the
    cameras' mean up direction, made perpendicular to them, stands in."""
    xs, ups = [], []
    for image in reconstruction.images.values():
        if image.has_pose:
            world_from_cam = image.cam_from_world().inverse().matrix()
            xs.append(world_from_cam[:, 0])
            ups.append(-world_from_cam[:, 1])  # camera y points down the image
    if not xs:
        raise InputError("no registered camera to take up from.")
    xs, mean_up = np.array(xs), np.mean(ups, axis=0)
    values, vectors = np.linalg.eigh(xs.T @ xs)
    if values[1] >= min_spread * values[2]:
        up = vectors[:, 0]
    else:
        up = mean_up - (mean_up @ vectors[:, 2]) * vectors[:, 2]
    up /= np.linalg.norm(up)
    return up if up @ mean_up > 0 else -up


def _rotation_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The smallest rotation taking unit vector a onto unit vector b."""
    v, c = np.cross(a, b), float(a @ b)
    if np.linalg.norm(v) < 1e-12:
        return np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    k = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + k + k @ k / (1 + c)
