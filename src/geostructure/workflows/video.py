"""One call for what ``geostructure run`` does: a video or a folder of photos reconstructed
(frames, SfM, dense, surface, georeference: :func:`~geostructure.reconstruct.stages.reconstruct`)
and its cloud measured and saved as one set, as ``measure`` does. A reconstruction that
fails keeps its finished stages, and the same call resumes after them."""

from __future__ import annotations

import importlib.util
import shutil
import time
from pathlib import Path

from geostructure.core.cloud import Cloud
from geostructure.core.orientation import Frame
from geostructure.core.params import Params
from geostructure.errors import GeoStructureError, InputError
from geostructure.io.truth import read_truth
from geostructure.reconstruct.georef import check_control_layout, read_gcp, read_gcp_csv
from geostructure.reconstruct.sfm import list_images
from geostructure.reconstruct.stages import ReconstructOptions, reconstruct
from geostructure.workflows.advice import say_after
from geostructure.workflows.outcrop import measure_outcrop
from geostructure.workflows.survey import SurveyRun, save_outcrop

#: What ``run`` needs beyond the measuring core, by import name, and the package it comes in.
RECONSTRUCT_MODULES = {"pycolmap": "pycolmap", "cv2": "opencv-python-headless", "PIL": "pillow"}


def require_reconstruction_extra(needs_video: bool, needs_mesh: bool) -> None:
    """Say which extra to install when a reconstruction package is missing, before any work."""
    modules = dict(RECONSTRUCT_MODULES)
    if needs_video:
        modules["av"] = "av"
    if needs_mesh:
        modules["open3d"] = "open3d"
    missing = [package for module, package in modules.items() if importlib.util.find_spec(module) is None]
    if missing:
        raise GeoStructureError(
            f"reconstruction needs {', '.join(missing)}, which is not installed; "
            f"install it with: pip install 'geostructure[reconstruct]'."
        )


def check_reconstruct_options(options: ReconstructOptions) -> None:
    """Refuse, before any folder is made, what a reconstruction found only after its first
    stages (and left ``reconstruct.json`` and ``work/`` for): a scale without the axes it
    scales, a dense stage this machine cannot run."""
    if options.scale != 1.0 and not (options.up and options.north):
        raise GeoStructureError("--scale is the manual georeference's: give --up and --north with it, in model axes.")
    if options.use_dense and options.dense.method == "colmap":
        import pycolmap  # lazy: found installed by require_reconstruction_extra

        if not pycolmap.has_cuda:
            raise GeoStructureError(
                "--dense colmap needs pycolmap built with CUDA (pip install pycolmap-cuda12 on a machine with an "
                "NVIDIA GPU); use --dense sgbm or --dense sweep here."
            )


def check_reconstruction(source, options: ReconstructOptions) -> None:
    """Refuse, before any folder is made, a reconstruction that cannot run: a missing extra,
    a source that is not there, a control file that cannot place the model (three points not
    on one line), options that mean nothing together, a folder holding a file that is no
    image."""
    source = Path(source)
    require_reconstruction_extra(needs_video=source.is_file(), needs_mesh=options.mesh and options.use_dense)
    if not source.exists():
        raise InputError(f"{source}: no such file or folder.")
    gcp = Path(options.gcp) if options.gcp else None
    if gcp is not None:  # a bad control file is found now, not after SfM, dense and meshing
        if gcp.suffix.lower() != ".json":
            check_control_layout(read_gcp_csv(gcp)[0], gcp)
        elif source.is_dir():  # OpenSfM's JSON names the photos, so it is checked against them
            check_control_layout(read_gcp(gcp, source)[0], gcp)
        elif not gcp.is_file():
            raise InputError(f"{gcp}: no such file.")
    check_reconstruct_options(options)
    if source.is_dir():
        list_images(source)  # every photo is an image, before any folder is made


def reconstruct_and_measure(
    source, outdir, options: ReconstructOptions = ReconstructOptions(), *, declination: float = 0.0,
    params: Params | None = None, auto: bool = True, given: dict | None = None, crs: str | None = None,
    unit: str | None = None, grid_north: bool = False,
    truth=None, truth_path=None, report: bool = True, inputs=(), progress=None, log=print, on_choice=None,
) -> SurveyRun:  # fmt: skip
    """Reconstruct ``source`` (a video file or a folder of photos) into ``outdir`` and measure
    its cloud there, in the east-north-up frame its georeference gives.

    Parameters
    ----------
    source : path
        A video file or a folder of photos.
    outdir : path
        The folder for the reconstruction's stages, the cloud, the planes and the report.
    options : ReconstructOptions
        The reconstruction's stages and georeference.
    declination : float
        Magnetic declination in degrees, east positive: azimuths read against magnetic north.
    params, auto, given, crs, unit, grid_north, on_choice
        As :func:`~geostructure.workflows.outcrop.measure_outcrop` takes them.
    truth, truth_path, report, inputs
        As :func:`~geostructure.workflows.survey.measure_survey` takes them; the truth's file
        is read once the source and the options are checked, before any stage.
    progress : callable, optional
        ``progress(stage, done, total)``.
    log : callable
        Told each stage's result in a line.

    Returns
    -------
    SurveyRun
        Its ``record`` holds the reconstruction's stages.

    Examples
    --------
    >>> from geostructure.reconstruct.stages import ReconstructOptions
    >>> options = ReconstructOptions(assume_level=True)  # no control points: dips approximate
    >>> options.mesh, options.use_dense
    (True, True)
    >>> run = reconstruct_and_measure("walk.mp4", "out/walk", options)  # doctest: +SKIP
    >>> len(run.outcrop.planes)  # doctest: +SKIP
    212
    """
    check_reconstruction(source, options)
    if truth is None and truth_path is not None:  # a bad truth is refused before hours of reconstruction
        truth = read_truth(truth_path, Frame.named("enu", declination))
    outdir = Path(outdir)
    t = time.perf_counter()
    made = _resumable(lambda: reconstruct(source, outdir, options, progress, log), outdir)
    cloud = Cloud.from_points(made.points, source=made.cloud_path, enu_origin=made.georeference.enu_origin)
    record = {"reconstruction": {k: v for k, v in made.records.items()}}
    run = measure_outcrop(cloud, frame=Frame.named("enu", declination), params=params, auto=auto, given=given,
                          crs=crs, unit=unit,
                          grid_north=grid_north, progress=progress, on_choice=on_choice,
                          seconds={"reconstruct": time.perf_counter() - t})  # fmt: skip
    evaluation = save_outcrop(run, outdir, truth=truth, truth_path=truth_path, report=report, extra=record,
                              inputs=inputs, progress=progress)  # fmt: skip
    say_after(run.result)
    return SurveyRun("memory", run.result, run, evaluation, record=record, paths=run.paths)


def _resumable(stages, outdir: Path):
    """Run the reconstruction; on failure say what is kept and whether the same call resumes."""
    existed = outdir.exists()
    try:
        return stages()
    except GeoStructureError as exc:
        if not existed and outdir.is_dir() and not (outdir / "reconstruct.json").exists():
            shutil.rmtree(outdir, ignore_errors=True)  # nothing finished: leave no half-made folder
            raise GeoStructureError(f"{exc} Nothing was kept.") from None
        if (outdir / "reconstruct.json").exists():
            raise GeoStructureError(
                f"{exc} The finished stages are kept in {outdir}; the same command resumes after them."
            ) from None
        raise
