"""Surveys larger than memory: read once into a spill file, measured in passes over chunks
(:mod:`.engine`), on this machine or a Dask cluster (:mod:`.executor`).
"""

from __future__ import annotations

from geostructure.core.orientation import Frame
from geostructure.core.params import Params
from geostructure.io.crs import given_crs, true_north_frame
from geostructure.io.readers import DEFAULT_MESH_SAMPLES
from geostructure.stream.engine import DEFAULT_CHUNK_POINTS, StreamedMeasurement, spill_planes
from geostructure.stream.executor import DaskExecutor, SerialExecutor
from geostructure.stream.source import Spill, spill_inputs

__all__ = [
    "DaskExecutor",
    "SerialExecutor",
    "Spill",
    "StreamedMeasurement",
    "spill_planes",
    "stream_planes",
    "spill_inputs",
]


def stream_planes(
    paths,
    params: Params = Params(detector="voxel"),
    frame: Frame = Frame(),
    *,
    auto: dict | None = None,
    chunk_points: int = DEFAULT_CHUNK_POINTS,
    executor=None,
    progress=None,
    writers=(),
    spill_dir=None,
    mesh_samples: int | None = DEFAULT_MESH_SAMPLES,
    crs: str | None = None,
    true_north: bool = False,
) -> StreamedMeasurement:
    """Measure the files ``paths`` (tiles of one survey) without holding their points.

    The files are read chunk by chunk into a spill file in ``spill_dir`` (a temporary
    folder by default, removed afterwards), then measured by :func:`.engine.spill_planes`,
    whose parameters these are. ``crs``, when given, is the survey's (over any its files
    declare); with ``true_north``, a projected survey's azimuths are read against true north
    (:func:`~geostructure.io.crs.true_north_frame`, recorded in the result's ``north``).

    Parameters
    ----------
    paths : sequence of paths
        The survey's files.
    params, frame, auto, chunk_points, executor, progress, writers
        As :func:`~geostructure.stream.engine.spill_planes` takes them.
    spill_dir : path, optional
        Where the points are spilled (the temporary folder by default).
    mesh_samples : int or None
        Points sampled on a PLY mesh's faces.
    crs : str, optional
        The survey's CRS, over any its files declare.
    true_north : bool
        Read a projected survey's azimuths against true north.

    Returns
    -------
    StreamedMeasurement

    Examples
    --------
    >>> from geostructure.testing.examples import scene_laz
    >>> path = scene_laz(40_000)
    >>> result = stream_planes([path], chunk_points=10_000)
    >>> len(result) >= 5, result.engine
    (True, 'stream')
    """
    report = progress or (lambda stage, done, total: None)
    spill = spill_inputs(paths, chunk_points, mesh_samples=mesh_samples, progress=report, folder=spill_dir)
    spill.crs = given_crs(crs, spill.crs, spill.source)
    north = None
    if true_north:
        frame, north = true_north_frame(frame, spill.crs, spill.lower, spill.upper)
    try:
        result = spill_planes(
            spill,
            params,
            frame,
            auto=auto,
            chunk_points=chunk_points,
            executor=executor,
            progress=report,
            writers=writers,
        )
    finally:
        spill.close()
    result.north = north
    return result
