"""The whole paper in one call: video or photos -> frames -> SfM -> dense -> surface ->
georeference -> measure.

Each finished stage is recorded in ``OUTDIR/reconstruct.json`` with the options it ran
with; a second run skips every stage whose record, options and files are unchanged, so an
interrupted run resumes from the last finished stage.
"""

from __future__ import annotations

import json
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from geostructure.errors import GeoStructureError
from geostructure.io.atomic import write_json
from geostructure.io.outdir import prepare_outdir
from geostructure.io.writers import write_vertex_ply
from geostructure.reconstruct.dense import DenseOptions, dense_cloud
from geostructure.reconstruct.frames import VIDEO_SUFFIXES, FrameOptions, extract_frames
from geostructure.reconstruct.georef import (
    camera_up,
    describe_georeference,
    manual,
    read_gcp,
    solve_exif_gps,
    solve_gcp,
    triangulate_observations,
)
from geostructure.reconstruct.sfm import SfmOptions, list_images, run_sfm, sparse_points
from geostructure.reconstruct.surface import SurfaceOptions, poisson_points

STAGES = ("frames", "sfm", "dense", "surface", "georef")


@dataclass(frozen=True)
class ReconstructOptions:
    frames: FrameOptions = FrameOptions()
    sfm: SfmOptions = SfmOptions()
    dense: DenseOptions = DenseOptions()
    surface: SurfaceOptions = SurfaceOptions()
    use_dense: bool = True  # False: measure the sparse SfM points (no mesh either)
    mesh: bool = True  # False (--no-mesh): measure the dense cloud directly
    gcp: str | None = None  # ground control CSV
    up: tuple | None = None  # manual frame, in model axes
    north: tuple | None = None
    scale: float = 1.0
    assume_level: bool = False  # up from the cameras, north along their mean view: approximate


@dataclass
class Reconstruction:
    """What ``reconstruct`` made: world points to measure and each stage's record."""

    points: np.ndarray
    georeference: object
    records: dict = field(default_factory=dict)
    cloud_path: Path | None = None


def reconstruct(
    source, outdir, options: ReconstructOptions = ReconstructOptions(), progress=None, log=print
) -> Reconstruction:
    """Run (or resume) the reconstruction stages; ``log`` gets one line per stage."""
    import pycolmap

    source, outdir = Path(source), prepare_outdir(outdir)
    state_path = outdir / "reconstruct.json"
    state = json.loads(state_path.read_text()) if state_path.exists() else {}
    work = outdir / "work"

    def done(stage, opts, *paths) -> bool:
        record = state.get(stage)
        return bool(record and record.get("options") == opts and all(Path(p).exists() for p in paths))

    def finish(stage, opts, report: dict):
        state[stage] = {"options": opts, **report}
        for later in STAGES[STAGES.index(stage) + 1 :]:
            state.pop(later, None)  # a redone stage invalidates what was built on it
        write_json(state, state_path)

    if not source.exists():
        raise GeoStructureError(f"{source}: no such file or folder.")
    if source.is_dir():
        image_dir = source
        list_images(image_dir)
        state.pop("frames", None)
    else:
        if source.suffix.lower() not in VIDEO_SUFFIXES:
            raise GeoStructureError(f"{source}: not a video (.mp4, .avi, .mov, ...) nor a folder of photos.")
        image_dir = outdir / "frames"
        opts = {"source": str(source.resolve()), **asdict(options.frames)}
        if done("frames", opts, image_dir):
            log(f"frames: done before ({state['frames']['summary']})")
        else:
            if image_dir.exists():
                for old in image_dir.glob("frame_*.jpg"):
                    old.unlink()
            t = time.perf_counter()
            report = extract_frames(source, image_dir, options.frames, progress)
            log(f"frames: {report.summary()}")
            finish(
                "frames",
                opts,
                {
                    "summary": report.summary(),
                    "kept": len(report.paths),
                    "decoded": report.decoded,
                    "seconds": time.perf_counter() - t,
                },
            )

    opts = {"images": str(image_dir.resolve()), **asdict(options.sfm), "after": state.get("frames", {}).get("summary")}
    if done("sfm", opts, work / "sparse" / "images.bin"):
        log(f"sfm: done before ({state['sfm']['summary']})")
    else:
        _, report = run_sfm(image_dir, work, options.sfm, progress)
        log(f"sfm: {report.summary()}")
        finish("sfm", opts, {"summary": report.summary(), **asdict(report)})
    model = pycolmap.Reconstruction(work / "sparse")
    viewpoints = np.array([im.projection_center() for im in model.images.values() if im.has_pose])

    points = sparse_points(model)
    if options.use_dense:
        opts = asdict(options.dense)
        dense_path = work / "dense_points.npy"
        if done("dense", opts, dense_path):
            log(f"dense: done before ({state['dense']['summary']})")
        else:
            points, report = dense_cloud(work / "sparse", image_dir, work / "dense", options.dense, progress)
            np.save(dense_path, points)
            log(f"dense: {report.summary()}")
            finish("dense", opts, {"summary": report.summary(), **asdict(report)})
        points = np.load(dense_path)

    if options.mesh and options.use_dense:  # a Poisson surface over a sparse cloud is mostly invented
        opts = {**asdict(options.surface), "dense": options.use_dense}
        sampled_path, mesh_path = work / "surface_points.npy", outdir / "surface.ply"
        if done("surface", opts, sampled_path, mesh_path):
            log(f"surface: done before ({state['surface']['summary']})")
        else:
            if progress:
                progress("surface", 0, None)
            sampled, mesh, report = poisson_points(points, viewpoints, options.surface)
            np.save(sampled_path, sampled)
            _write_mesh(mesh, mesh_path)
            log(f"surface: {report.summary()}")
            finish("surface", opts, {"summary": report.summary(), **asdict(report)})
        points = np.load(sampled_path)

    georeference = georeference_model(model, image_dir, options)
    log(f"georeference: {describe_georeference(georeference.to_dict())}")
    state["georef"] = georeference.to_dict()
    write_json(state, state_path)
    world = georeference.apply(points)
    cloud_path = write_cloud_ply(world, outdir / "cloud.ply")
    return Reconstruction(world, georeference, state, cloud_path)


def georeference_model(model, image_dir, options: ReconstructOptions):
    """GCPs if given, else a manual frame if given, else EXIF GPS; refuses when none exists."""
    if options.gcp:
        world, observations, model_points, origin = read_gcp(options.gcp, image_dir)
        located = {**triangulate_observations(model, observations), **model_points}
        geo = solve_gcp(located, world)
        geo.enu_origin = origin
        return geo
    if options.up is not None or options.north is not None:
        if options.up is None or options.north is None:
            raise GeoStructureError("give both `up` and `north` (model axes), or neither.")
        return manual(options.up, options.north, options.scale)
    if options.assume_level:
        return level_from_cameras(model, options.scale)
    try:
        return solve_exif_gps(model, image_dir)
    except GeoStructureError as exc:
        raise GeoStructureError(
            f"the model is not georeferenced, so strike and dip would mean nothing ({exc}) The cloud is "
            "reconstructed and kept; run the same command again with `gcp='GCP.csv'` (control points), or "
            "`up=(X, Y, Z)` and `north=(X, Y, Z)` [`scale=S`] (in model axes), or `assume_level=True` for a quick look (up from "
            "the cameras: dips approximate, azimuths relative to the view)."
        ) from None


def level_from_cameras(model, scale: float = 1.0):
    """Up from the cameras (held without roll, :func:`~.georef.camera_up`), north as their mean
    horizontal viewing direction: dips approximate, azimuths relative to where they looked."""
    views = [image.cam_from_world().inverse().matrix()[:, 2] for image in model.images.values() if image.has_pose]
    geo = manual(camera_up(model), np.mean(views, axis=0), scale)
    geo.source, geo.approximate = "cameras-level", True
    return geo


def write_cloud_ply(points: np.ndarray, path) -> Path:
    """The georeferenced points, double precision, for measuring and for other tools."""
    vertex = np.empty(len(points), dtype=[("x", "f8"), ("y", "f8"), ("z", "f8")])
    vertex["x"], vertex["y"], vertex["z"] = np.asarray(points, float).T
    return write_vertex_ply(path, vertex, ["written by geostructure run"])


def _write_mesh(mesh, path: Path) -> None:
    """Open3D picks the format by suffix, so the partial file keeps ``.ply``."""
    import os

    import open3d as o3d

    partial = path.with_name(f".{path.stem}.partial.ply")
    try:
        if not o3d.io.write_triangle_mesh(str(partial), mesh):
            raise GeoStructureError(f"{path}: could not write the mesh.")
        os.replace(partial, path)
    finally:
        partial.unlink(missing_ok=True)
