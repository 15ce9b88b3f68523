"""The commands that measure made-up or swept clouds: ``demo`` (the bundled synthetic
observatory, measured and scored against its exact surfaces) and ``sweep`` (the paper's
experiments, one factor varied, written as ``sweep.csv`` and its figures)."""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field
from pathlib import Path

from geostructure.core.orientation import Frame
from geostructure.core.params import Params
from geostructure.detect.pipeline import Measurement, measure
from geostructure.evaluation.groundtruth import Evaluation, match_scene
from geostructure.evaluation.sweep import plot_sweep, rows_as_dicts
from geostructure.evaluation.sweep import run_sweep as sweep
from geostructure.io.outdir import output_set
from geostructure.io.writers import write_table_csv
from geostructure.synthetic import observatory_scene
from geostructure.workflows.outcrop import chosen_params
from geostructure.workflows.saving import save_measurement


@dataclass
class DemoRun:
    """What :func:`run_demo` measured, how it matched the scene's surfaces, and the files."""

    result: Measurement
    match: Evaluation
    paths: dict = field(default_factory=dict)


def run_demo(
    outdir, *, points: int = 300_000, seed: int = 0, frame: Frame = Frame(), params: Params | None = None,
    auto: bool = True, given: dict | None = None, crs: str | None = None, report: bool = True, progress=None,
    on_choice=None,
) -> DemoRun:  # fmt: skip
    """Measure the synthetic observatory scene of ``points`` points (``seed``), match its
    planes to the scene's exact surfaces, and write ``outdir``; ``crs`` places the made-up
    scene on the map, to try the GIS files.

    Examples
    --------
    >>> import tempfile
    >>> run = run_demo(tempfile.mkdtemp(), points=40_000, report=False)
    >>> run.match.all_found
    True
    """
    report_stage = progress or (lambda stage, done, total: None)
    scene = observatory_scene(points, seed=seed)
    if crs is not None:
        scene.cloud = dataclasses.replace(scene.cloud, crs=crs)
    base = params or Params()
    chosen, auto_record, moments = chosen_params(scene.cloud, base, auto, dict(given or {}), on_choice)
    result = measure(scene.cloud, chosen, frame, progress, moments=moments)
    match = match_scene(result, scene)
    report_stage("write", 0, None)
    paths = save_measurement(
        result,
        outdir,
        extra={"auto": auto_record, "demo": {"points": points, "seed": seed}},
        evaluation=match,
        evaluation_extra={"truth": "the scene's exact surfaces"},
        report=report,
    )
    return DemoRun(result, match, paths)


def sweep_and_save(
    cloud, truth, frame: Frame, factors, base: Params, outdir, *, ranges: dict | None = None, workers: int = 2,
    input_name: str = "demo", inputs=(), progress=None, stem: str = "all",
):  # fmt: skip
    """The paper's experiments on ``cloud`` against ``truth``: each of ``factors`` varied over
    its range (``ranges``: factor -> start, end, step), written to ``outdir`` as
    ``sweep.csv``, its figures (``sweep_<stem>.*``) and ``sweep.json``; returns the rows and
    the files written."""
    t = time.perf_counter()
    rows = sweep(cloud, truth, frame, factors, base, ranges=ranges or {}, workers=workers, progress=progress)
    with output_set(outdir, record_name="sweep.json", inputs=inputs) as outputs:
        write_table_csv(rows_as_dicts(rows), outputs.path("sweep.csv"))
        figures = plot_sweep(rows, outputs.staging / f"sweep_{stem}")
        outputs.record = {
            "input": input_name,
            "base_params": base.to_dict(),
            "seconds": round(time.perf_counter() - t, 2),
            "runs": rows_as_dicts(rows),
        }
    return rows, [outputs.final("sweep.csv"), *(Path(outputs.final(p.name)) for p in figures)]
