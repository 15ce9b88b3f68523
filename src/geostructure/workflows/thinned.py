"""A survey larger than memory, for what a streamed run cannot measure chunk by chunk (the
sets' rock mass, the kinematics, the facet detector): read chunk by chunk, thinned to a cloud
that fits (:mod:`geostructure.stream.thin`), measured in memory, and every point of the
survey labelled in ``regions.ply`` and ``regions.laz`` by the point that stood for its cell."""

from __future__ import annotations

from contextlib import contextmanager

from geostructure.errors import ParameterError
from geostructure.stream import DaskExecutor, SerialExecutor, spill_inputs
from geostructure.stream.thin import thin_spill
from geostructure.stream.thinnedsurvey import ThinnedSurvey
from geostructure.workflows.engine_choice import (
    MEMORY_BASE_BYTES,
    chunk_points,
    default_max_memory,
    memory_bytes_per_point,
)

#: The fewest points a rock mass is measured on: fewer cannot show joints of a metre.
MIN_THINNED_POINTS = 20_000


def thinned_points(max_memory: int | None, rock: bool) -> int:
    """The points a thinned survey may keep: what ``max_memory`` (default: half the
    machine's) holds in memory; ``rock``: with the sets' rock mass or the kinematics.

    Examples
    --------
    >>> thinned_points(4 * 2**30, rock=True)
    5368709
    """
    limit = max_memory or default_max_memory()
    points = (limit - MEMORY_BASE_BYTES) // memory_bytes_per_point(rock)
    if points < MIN_THINNED_POINTS:
        raise ParameterError(
            f"--max-memory {limit >> 20}M holds too few points to measure a rock mass in: give at least "
            f"{(MEMORY_BASE_BYTES + MIN_THINNED_POINTS * memory_bytes_per_point(rock)) >> 20}M."
        )
    return int(points)


@contextmanager
def thinned_survey(
    paths, engine: str, *, max_memory: int | None = None, rock: bool = False, full_resolution: bool = False,
    scheduler: str | None = None, workers: int | None = None, mesh_samples: int | None = None, spill_dir=None,
    unit: str | None = None, progress=None,
):  # fmt: skip
    """Spill ``paths`` and thin them to what ``max_memory`` holds; yields the
    :class:`~geostructure.stream.thinnedsurvey.ThinnedSurvey`. The spill is removed when the block
    ends, however it ends. ``full_resolution``: its facets are to be found on every point,
    in tiles (what its notes say)."""
    target = thinned_points(max_memory, rock)  # a bound too small is refused before any work
    executor = DaskExecutor(scheduler, workers, background=True) if engine == "dask" else SerialExecutor()
    spill = None
    rows = chunk_points(max_memory)
    try:
        spill = spill_inputs(paths, rows, mesh_samples=mesh_samples, progress=progress, folder=spill_dir)
        thinned = thin_spill(spill, target, rows, executor, progress)
        # A facet tile is worked while the thinned cloud is held, before its rock mass (which
        # takes the most): a tile of at most 4/5 of the thinned points stays under that peak.
        survey = ThinnedSurvey(spill, thinned, executor, rows, tile_points=min(rows, max(1, target * 4 // 5)))
        survey.note(max_memory or default_max_memory(), unit, full_resolution=full_resolution)
        yield survey
    finally:
        if spill is not None:
            spill.close()
        executor.close()
