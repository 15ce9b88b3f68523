"""One call for what ``geostructure measure --engine stream`` (or ``--engine dask``) does: a
survey larger than memory measured in chunks with the voxel detector, its folder written
as one set as the chunks go (the point files chunk by chunk), the automatic parameters
included. The command line parses its options, calls :func:`measure_survey` and prints.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from pathlib import Path

from geostructure.core.orientation import Frame
from geostructure.core.params import Params
from geostructure.errors import GeoStructureNote
from geostructure.evaluation.groundtruth import evaluate
from geostructure.evaluation.scoring import stage_evaluation
from geostructure.io.crs import cloud_unit, describe_north
from geostructure.io.outdir import output_set
from geostructure.io.readers import DEFAULT_MESH_SAMPLES
from geostructure.io.truth import read_truth
from geostructure.io.writers import write_result
from geostructure.stream import DaskExecutor, SerialExecutor, measure_stream
from geostructure.stream.engine import DEFAULT_CHUNK_POINTS
from geostructure.stream.output import RegionsLaz, RegionsPly
from geostructure.workflows.saving import stage_report


@dataclass
class SurveyRun:
    """What :func:`measure_survey` measured and wrote: the streamed result (planes, counts,
    the frame used), the evaluation against a ground truth when one was given, what
    ``run.json`` says of the CRS (``record``: unit, north) and the files written."""

    result: object
    evaluation: object = None
    record: dict = field(default_factory=dict)
    paths: dict = field(default_factory=dict)


def measure_survey(
    paths,
    outdir,
    *,
    frame: Frame = Frame(),
    params: Params | None = None,
    auto: bool = True,
    given: dict | None = None,
    engine: str = "stream",
    chunk_points: int = DEFAULT_CHUNK_POINTS,
    scheduler: str | None = None,
    workers: int | None = None,
    spill_dir=None,
    mesh_samples: int | None = DEFAULT_MESH_SAMPLES,
    crs: str | None = None,
    unit: str | None = None,
    grid_north: bool = False,
    truth=None,
    truth_path=None,
    report: bool = False,
    extra: dict | None = None,
    inputs=(),
    progress=None,
) -> SurveyRun:
    """Measure the files ``paths`` (tiles of one survey) streamed, and write ``outdir``.

    Parameters
    ----------
    paths : list of paths
        The survey's files.
    outdir : path
        The output folder; its previous set is replaced as a whole.
    frame, params, auto, given, crs, unit, grid_north
        As :func:`~geostructure.workflows.outcrop.measure_outcrop` takes them; the detector
        is the voxel growing's.
    engine : str
        ``stream`` (chunks in this process) or ``dask`` (chunks as tasks on a cluster).
    chunk_points : int
        Points a chunk holds (what ``--max-memory`` sizes).
    scheduler, workers
        For ``dask``: a running scheduler's address, or a local cluster of ``workers``.
    spill_dir : path, optional
        Where the points are spilled (the temporary folder by default).
    mesh_samples : int or None
        Points sampled on a PLY mesh's faces.
    truth, truth_path
        A ground truth already read (:func:`~geostructure.io.truth.read_truth`) and its
        file, read again in the frame turned to true north when the CRS turns it.
    report : bool
        Also write the report.
    extra : dict, optional
        More entries for ``run.json``.
    inputs : sequence of paths
        Files the run read, refused if they are among its outputs.
    progress : callable, optional
        ``progress(stage, done, total)``.

    Returns
    -------
    SurveyRun

    Raises
    ------
    GeoStructureError
        A file that cannot be read, an option that means nothing, a folder that cannot hold
        the outputs.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from geostructure.synthetic import observatory_scene
    >>> from geostructure.io.laz import write_laz
    >>> cloud = observatory_scene(40_000, seed=1).cloud
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> _ = write_laz(folder / "scene.laz", cloud.points, {}, offset=cloud.offset)
    >>> run = measure_survey([folder / "scene.laz"], folder / "out", chunk_points=10_000)
    >>> len(run.result) >= 5, sorted(run.paths)[:2]
    (True, ['dips', 'planes'])
    """
    params = (params or Params()).with_(detector="voxel")
    if given:
        params = params.with_(**given)
    executor = DaskExecutor(scheduler, workers) if engine == "dask" else SerialExecutor()
    run = SurveyRun(None)
    try:
        with output_set(outdir, inputs=inputs) as outputs:
            writers = [RegionsPly(outputs.path("regions.ply")), RegionsLaz(outputs.path("regions.laz"))]
            result = measure_stream(
                [Path(p) for p in paths],
                params,
                frame,
                auto=dict(given or {}) if auto else None,
                chunk_points=chunk_points,
                executor=executor,
                progress=progress,
                writers=writers,
                spill_dir=spill_dir,
                mesh_samples=mesh_samples,
                crs=crs,
                true_north=not grid_north,
            )
            run.result = result
            if result.cloud.crs is not None or unit is not None:
                run.record["unit"] = cloud_unit(result.cloud.crs, unit)
            if result.north:
                run.record["north"] = result.north
                warnings.warn(describe_north(result.north), GeoStructureNote, stacklevel=2)
                if truth is not None and truth_path is not None:  # a compass's azimuths are true
                    truth = read_truth(truth_path, result.frame)
            run.evaluation = evaluate(result.planes, truth) if truth is not None else None
            record = {"engine": engine, **(extra or {}), **({"auto": result.auto} if result.auto else {}), **run.record}
            run.paths = write_result(result, outputs, record, point_files=False)
            if run.evaluation is not None:
                run.paths.update(stage_evaluation(outputs, run.evaluation, None))
            if report:
                run.paths.update(stage_report(outputs, outputs.staging, None))
    finally:
        executor.close()
    return run
