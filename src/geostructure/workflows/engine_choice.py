"""Which engine measures a survey: in memory, streamed in chunks, or on a Dask cluster, and
the memory model that chooses between them (``--engine auto``).

A run in memory holds every point with its neighbours; a streamed one holds a chunk at a
time. What a streamed run cannot measure chunk by chunk (the sets' rock mass, the slope's
kinematics, the facet detector) is measured on the survey thinned to what fits
(:mod:`geostructure.workflows.thinned`).
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from geostructure.errors import ParameterError
from geostructure.io.readers import estimate_points
from geostructure.stream.engine import DEFAULT_CHUNK_POINTS

#: The engines a survey is measured with; ``auto`` picks memory or stream.
ENGINES = ("auto", "memory", "stream", "dask")
#: A run in memory with the default options peaked at 1.10 GB for a 1M-point LAZ and 1.12 GB
#: for a 4M one, and at 2,064 MiB for the README's 8M-point PLY: about 1 GiB and at most
#: 300 bytes a point past it, which is what the automatic engine expects.
MEMORY_BASE_BYTES = 2**30
MEMORY_BYTES_PER_POINT = 300
#: With the sets' rock mass and the kinematics: 955 MB for a 1.65M-point outcrop, 521 MB for
#: 0.70M (2026-12-05), 460 bytes a point past the first; with a margin.
MEMORY_BYTES_PER_POINT_ROCK = 600
#: What the interpreter and the libraries take before any point, in a streamed run.
BASELINE_BYTES = 300 * 2**20
#: What a streamed run holds per point of a chunk (its temporaries, measured), and the
#: share of the bound left to the voxel tables.
CHUNK_BYTES_PER_POINT = 600


def default_max_memory() -> int:
    """Half the machine's memory."""
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE") // 2
    except (ValueError, OSError, AttributeError):
        return 4 * 2**30


def measures_in_memory(*, sets: bool, kinematics: bool, detector: str) -> bool:
    """What a streamed run cannot measure chunk by chunk: the sets' rock mass, the slope's
    kinematics and the facet detector, all on each point's neighbours. A survey too large
    for memory is thinned for them (:mod:`geostructure.workflows.thinned`).

    Examples
    --------
    >>> measures_in_memory(sets=False, kinematics=False, detector="voxel")
    False
    """
    from geostructure.detect.registry import detector_spec  # lazy: the detectors' modules

    return bool(sets or kinematics or not detector_spec(detector).streams)


def memory_bytes_per_point(rock: bool) -> int:
    """What a run in memory takes a point past :data:`MEMORY_BASE_BYTES`; ``rock``: with
    the sets' rock mass or the kinematics."""
    return MEMORY_BYTES_PER_POINT_ROCK if rock else MEMORY_BYTES_PER_POINT


def check_spill_dir(folder) -> None:
    """Refuse, before any work, a spill folder that is no writable folder (it was reported
    after the read as the output folder's failure)."""
    folder = Path(folder)
    if not folder.is_dir():
        raise ParameterError(f"--spill-dir {folder}: no such folder; give an existing folder with room for the points.")
    try:
        os.rmdir(tempfile.mkdtemp(prefix=".geostructure-probe-", dir=folder))
    except OSError as exc:
        raise ParameterError(f"--spill-dir {folder}: the folder is not writable ({exc.strerror}).") from None


def check_scheduler_address(address: str) -> None:
    """Refuse, before any work, a scheduler that is no Dask address (``tcp://HOST:PORT``)."""
    try:
        from distributed.comm.addressing import parse_address, parse_host_port
    except ImportError:
        return  # the Dask extra is missing: the engine says so itself
    try:
        scheme, location = parse_address(address)
        if scheme in ("tcp", "tls"):
            parse_host_port(location)
    except (ValueError, TypeError) as error:
        raise ParameterError(
            f"--scheduler {address!r} is no Dask scheduler address ({error}): give one as tcp://HOST:PORT."
        ) from None


def check_engine_options(
    engine: str, *, scheduler: str | None = None, workers: int | None = None, thin: bool = False, spill_dir=None
) -> None:
    """Refuse, before any work, engine options that mean nothing together."""
    if engine not in ENGINES:
        raise ParameterError(f"--engine must be one of {', '.join(ENGINES)}, not {engine!r}.")
    given = [name for name, value in (("--scheduler", scheduler), ("--workers", workers)) if value]
    if given and engine != "dask":
        raise ParameterError(f"{' and '.join(given)} set up a Dask cluster: give them with --engine dask.")
    if thin and engine == "memory":
        raise ParameterError("--thin thins a survey larger than memory: give it with --engine stream, dask or auto.")
    if workers is not None and workers < 1:
        raise ParameterError(f"--workers must be at least 1, not {workers}.")
    if scheduler:
        check_scheduler_address(scheduler)
    if spill_dir is not None:
        check_spill_dir(spill_dir)


def choose_engine(
    engine: str, paths, *, max_memory: int | None = None, rock: bool = False, mesh_samples: int | None = None
) -> str:
    """The engine a run takes: the one asked, or for ``auto`` memory when the files'
    points (read from their headers or sizes) fit in ``max_memory`` (default: half the
    machine's)."""
    if engine != "auto":
        return engine
    limit = max_memory or default_max_memory()
    need = MEMORY_BASE_BYTES + memory_bytes_per_point(rock) * estimate_points(paths, mesh_samples)
    return "memory" if need <= limit else "stream"


def chunk_points(max_memory: int | None) -> int:
    """Points per chunk from a memory bound: half the bound past the baseline for the chunk.

    Examples
    --------
    >>> chunk_points(2**30)
    632640
    """
    if max_memory is None:
        return DEFAULT_CHUNK_POINTS
    budget = (max_memory - BASELINE_BYTES) // 2
    return int(max(50_000, min(DEFAULT_CHUNK_POINTS, budget // CHUNK_BYTES_PER_POINT)))
