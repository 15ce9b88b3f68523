"""``measure --sets`` (or ``--kinematics``, or ``--detector facets``) on a survey larger than
memory: read chunk by chunk, thinned to a cloud that fits (:mod:`geostructure.stream.thin`),
measured in memory, and every point of the survey labelled in ``regions.ply`` and
``regions.laz`` by the point that stood for its cell."""

from __future__ import annotations

from contextlib import contextmanager

from geostructure.cli.engine import MEMORY_BASE_BYTES, chunk_points, default_max_memory, memory_bytes_per_point
from geostructure.cli.options import base_params
from geostructure.cli.progress import StageProgress
from geostructure.errors import ParameterError
from geostructure.stream import DaskExecutor, SerialExecutor, spill_inputs
from geostructure.stream.survey import ThinnedSurvey
from geostructure.stream.thin import thin_spill

#: The fewest points a rock mass is measured on: fewer cannot show joints of a metre.
MIN_THINNED_POINTS = 20_000


def thinned_points(args) -> int:
    """The points a thinned survey may keep: what ``--max-memory`` holds in memory."""
    limit = args.max_memory or default_max_memory()
    points = (limit - MEMORY_BASE_BYTES) // memory_bytes_per_point(args)
    if points < MIN_THINNED_POINTS:
        raise ParameterError(
            f"--max-memory {limit >> 20}M holds too few points to measure a rock mass in: give at least "
            f"{(MEMORY_BASE_BYTES + MIN_THINNED_POINTS * memory_bytes_per_point(args)) >> 20}M."
        )
    return int(points)


@contextmanager
def thinned_survey(args, paths, engine: str):
    """Spill ``paths`` and thin them to what ``--max-memory`` holds; the spill is removed
    when the block ends, however it ends."""
    target = thinned_points(args)  # a bound too small is refused before any work
    executor = DaskExecutor(args.scheduler, args.workers, background=True) if engine == "dask" else SerialExecutor()
    spill = None
    rows = chunk_points(args)
    try:
        with StageProgress(enabled=not args.quiet) as progress:
            spill = spill_inputs(paths, rows, mesh_samples=args.mesh_samples or None, progress=progress,
                                 folder=args.spill_dir)  # fmt: skip
            thinned = thin_spill(spill, target, rows, executor, progress)
        # A facet tile is worked while the thinned cloud is held, before its rock mass (which
        # takes the most): a tile of at most 4/5 of the thinned points stays under that peak.
        survey = ThinnedSurvey(spill, thinned, executor, rows, tile_points=min(rows, max(1, target * 4 // 5)))
        full = base_params(args).detector == "facets" and not args.thin
        survey.note(args.max_memory or default_max_memory(), args.unit, full_resolution=full)
        yield survey
    finally:
        if spill is not None:
            spill.close()
        executor.close()
