"""One call for what ``geostructure measure`` does with files: the engine chosen (in memory
when the survey fits in ``max_memory``, else streamed in chunks, or on a Dask cluster), the
survey measured and its folder written as one set, the evaluation and the report included.
The command line parses its options, calls :func:`measure_survey` and prints.

The engines, in the order :func:`measure_survey` tries them:

1. ``memory``: the files read whole (:func:`~geostructure.io.survey_files.read_tiles`), measured
   (:func:`~geostructure.workflows.outcrop.measure_outcrop`) and saved;
2. with the sets, the kinematics or a detector that does not stream, on a survey too large
   for memory: the survey thinned to what fits (:mod:`geostructure.workflows.thinned`),
   measured in memory, every point labelled;
3. ``stream`` or ``dask``: the voxel detector chunk by chunk
   (:func:`~geostructure.stream.stream_planes`), the point files written as the chunks go.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

from geostructure.core.orientation import Frame
from geostructure.core.params import Params
from geostructure.detect.pipeline import Measurement
from geostructure.detect.registry import STREAMED_DETECTOR, detector_spec
from geostructure.errors import GeoStructureNote
from geostructure.evaluation.groundtruth import Evaluation, evaluate
from geostructure.evaluation.scoring import write_evaluation_into
from geostructure.io.crs import cloud_unit, describe_north
from geostructure.io.outdir import output_set
from geostructure.io.readers import DEFAULT_MESH_SAMPLES
from geostructure.io.survey_files import describe, read_tiles
from geostructure.io.truth import read_truth
from geostructure.io.writers import write_result
from geostructure.stream import DaskExecutor, SerialExecutor, stream_planes
from geostructure.stream.engine import StreamedMeasurement
from geostructure.stream.output import RegionsLaz, RegionsPly
from geostructure.workflows.advice import say_after
from geostructure.workflows.engine_choice import check_engine_options, choose_engine, chunk_points, measures_in_memory
from geostructure.workflows.outcrop import OutcropRun, measure_outcrop
from geostructure.workflows.saving import write_report_into
from geostructure.workflows.thinned import thinned_survey


@dataclass
class SurveyRun:
    """What :func:`measure_survey` measured and wrote.

    Parameters
    ----------
    engine : str
        The engine that measured it: ``memory``, ``stream`` or ``dask``.
    result : Measurement or StreamedMeasurement
        The planes, counts and the frame used.
    outcrop : OutcropRun, optional
        In memory (and on a thinned survey): the measure with its sets, rock mass and
        kinematics; None when streamed.
    evaluation : Evaluation, optional
        Against the ground truth, when one was given.
    record : dict
        What ``run.json`` says of the run beyond the measure (the unit, north, a thinned
        survey's ``thinned``).
    paths : dict
        Output kind -> path of each file written.
    """

    engine: str
    result: Measurement | StreamedMeasurement | None = None
    outcrop: OutcropRun | None = None
    evaluation: Evaluation | None = None
    record: dict = field(default_factory=dict)
    paths: dict = field(default_factory=dict)


def save_outcrop(
    run: OutcropRun, outdir, *, truth=None, truth_path=None, report: bool = False, extra: dict | None = None,
    inputs=(), point_files=True, progress=None,
):  # fmt: skip
    """Evaluate ``run`` against ``truth`` (read again from ``truth_path`` in the frame turned
    to true north, when the CRS turned it) and write its folder as one set; returns the
    evaluation (None without a truth)."""
    if truth is not None and truth_path is not None and run.record.get("north"):  # a compass's azimuths are true
        truth = read_truth(truth_path, run.result.frame)
    evaluation = evaluate(run.result.planes, truth) if truth is not None else None
    run.save(outdir, extra=extra, evaluation=evaluation, report=report, inputs=inputs, point_files=point_files,
             progress=progress)  # fmt: skip
    return evaluation


def measure_survey(
    paths,
    outdir,
    *,
    engine: str = "auto",
    max_memory: int | None = None,
    thin: bool = False,
    detector: str | None = None,
    frame: Frame = Frame(),
    params: Params | None = None,
    auto: bool = True,
    given: dict | None = None,
    crs: str | None = None,
    unit: str | None = None,
    grid_north: bool = False,
    sets: bool = False,
    n_sets: int | None = None,
    kinematics: dict | None = None,
    scheduler: str | None = None,
    workers: int | None = None,
    spill_dir=None,
    mesh_samples: int | None = DEFAULT_MESH_SAMPLES,
    truth=None,
    truth_path=None,
    report: bool = False,
    extra: dict | None = None,
    inputs=(),
    progress=None,
    on_choice=None,
) -> SurveyRun:
    """Measure the files ``paths`` (tiles of one survey) and write ``outdir``.

    Parameters
    ----------
    paths : list of paths
        The survey's files.
    outdir : path
        The output folder; its previous set is replaced as a whole.
    engine : str
        ``auto`` (memory when the survey fits in ``max_memory``, else ``stream``),
        ``memory``, ``stream`` (chunks in this process) or ``dask`` (chunks as tasks on a
        cluster).
    max_memory : int, optional
        The most bytes the run may take (default: half the machine's): what chooses the
        engine, sizes the chunks and the thinned survey.
    thin : bool
        Streamed, with the facet detector: find the facets on the thinned survey too, not
        on every point.
    detector : str, optional
        The detector asked for (:data:`~geostructure.detect.registry.DETECTORS`), over
        ``params``'s; None: ``params``'s in memory, the streamed one when streamed without
        the sets or kinematics.
    frame, params, auto, given, crs, unit, grid_north, sets, n_sets, kinematics, on_choice
        As :func:`~geostructure.workflows.outcrop.measure_outcrop` takes them; streamed,
        the detector is the voxel growing's.
    scheduler, workers
        For ``dask``: a running scheduler's address, or a local cluster of ``workers``.
    spill_dir : path, optional
        Where a streamed run spills the points (the temporary folder by default).
    mesh_samples : int or None
        Points sampled on a PLY mesh's faces.
    truth, truth_path
        A ground truth already read (:func:`~geostructure.io.truth.read_truth`), or its
        file alone (read here, once the engine's options are checked); read again in the
        frame turned to true north when the CRS turns it.
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
    >>> from geostructure.testing.examples import scene_laz
    >>> path = scene_laz(40_000)
    >>> run = measure_survey([path], path.parent / "out", engine="stream", max_memory=2**30)
    >>> run.engine, len(run.result) >= 5, sorted(run.paths)[:2]
    ('stream', True, ['dips', 'planes'])
    >>> measure_survey([path], path.parent / "mem").engine
    'memory'
    """
    paths = [Path(p) for p in paths]
    check_engine_options(engine, scheduler=scheduler, workers=workers, thin=thin, spill_dir=spill_dir)
    params = params or Params()
    if detector is not None:
        params = params.with_(detector=detector)
    rock = bool(sets or kinematics)
    chosen = choose_engine(engine, paths, max_memory=max_memory, rock=rock, mesh_samples=mesh_samples)
    if truth is None and truth_path is not None:
        truth = read_truth(truth_path, frame)
    outcrop = dict(frame=frame, params=params, auto=auto, given=given, crs=crs, unit=unit, grid_north=grid_north,
                   sets=sets, n_sets=n_sets, kinematics=kinematics, on_choice=on_choice)  # fmt: skip
    saving = dict(truth=truth, truth_path=truth_path, report=report, inputs=inputs, progress=progress)
    extra = {**({"inputs": [str(p) for p in paths]} if len(paths) > 1 else {}), **(extra or {})} or None
    if chosen == "memory":
        t = time.perf_counter()
        cloud = read_tiles(paths, mesh_samples=mesh_samples, progress=progress if len(paths) > 1 else None)
        run = measure_outcrop(cloud, progress=progress, seconds={"read": time.perf_counter() - t}, **outcrop)
        evaluation = save_outcrop(run, outdir, extra=extra, **saving)
        say_after(run.result)
        return SurveyRun("memory", run.result, run, evaluation, paths=run.paths)
    if measures_in_memory(sets=sets, kinematics=kinematics is not None, detector=detector or STREAMED_DETECTOR):
        t = time.perf_counter()
        # The facets on every point of the survey, in tiles; the rest on the thinned cloud.
        full = not detector_spec(params.detector).streams and not thin
        with thinned_survey(paths, chosen, max_memory=max_memory, rock=rock, full_resolution=full,
                            scheduler=scheduler, workers=workers, mesh_samples=mesh_samples, spill_dir=spill_dir,
                            unit=unit, progress=progress) as survey:  # fmt: skip
            record = {**(extra or {}), "engine": chosen, "thinned": survey.record()}
            run = measure_outcrop(survey.cloud(), progress=progress, seconds={"read": time.perf_counter() - t},
                                  facets=survey.full_resolution_facets if full else None, **outcrop)  # fmt: skip
            evaluation = save_outcrop(run, outdir, extra=record, point_files=survey.write_points, **saving)
        say_after(run.result)
        return SurveyRun(chosen, run.result, run, evaluation, record={"thinned": record["thinned"]}, paths=run.paths)
    if engine == "auto":
        warnings.warn(
            f"{describe(paths)} holds more points than fit in --max-memory; measuring it streamed, in chunks, "
            f"with the voxel detector.",
            GeoStructureNote,
            stacklevel=2,
        )
    streamed = _measure_streamed(paths, outdir, frame=frame, params=params, auto=auto, given=given, engine=chosen,
                             chunk_points=chunk_points(max_memory), scheduler=scheduler, workers=workers,
                             spill_dir=spill_dir, mesh_samples=mesh_samples, crs=crs, unit=unit,
                             grid_north=grid_north, extra=extra, **saving)  # fmt: skip
    say_after(streamed.result)
    return streamed


def _measure_streamed(
    paths, outdir, *, frame: Frame, params: Params, auto: bool, given: dict | None, engine: str, chunk_points: int,
    scheduler, workers, spill_dir, mesh_samples, crs, unit, grid_north, truth, truth_path, report: bool,
    extra: dict | None, inputs, progress,
) -> SurveyRun:  # fmt: skip
    """The voxel detector chunk by chunk, the point files written as the chunks go."""
    params = params.with_(detector=STREAMED_DETECTOR)
    if given:
        params = params.with_(**given)
    executor = DaskExecutor(scheduler, workers) if engine == "dask" else SerialExecutor()
    run = SurveyRun(engine)
    try:
        with output_set(outdir, inputs=inputs) as outputs:
            writers = [RegionsPly(outputs.path("regions.ply")), RegionsLaz(outputs.path("regions.laz"))]
            result = stream_planes(
                paths,
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
                run.paths.update(write_evaluation_into(outputs, run.evaluation, None))
            if report:
                run.paths.update(write_report_into(outputs, outputs.staging, None))
    finally:
        executor.close()
    return run
