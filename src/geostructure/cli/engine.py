"""``measure --engine``: in memory, streamed in chunks, or on a Dask cluster, and the memory
bound that chooses between them."""

from __future__ import annotations

import argparse
import os
import re
import time

from geostructure.cli.options import base_params, crs_from, given_factors, say_what_was_left, workers
from geostructure.cli.progress import StageProgress
from geostructure.cli.rockmass import wants_sets
from geostructure.cli.tables import counted, print_evaluation, print_planes
from geostructure.errors import ParameterError
from geostructure.io.crs import recorded_unit
from geostructure.stream.engine import DEFAULT_CHUNK_POINTS
from geostructure.stream.source import estimate_points
from geostructure.workflows.survey import measure_survey

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
_UNITS = {"": 1, "K": 2**10, "M": 2**20, "G": 2**30, "T": 2**40}


def memory_size(text: str) -> int:
    """``--max-memory``: bytes from ``8G``, ``500M``, ``2GiB`` or a plain number of bytes.

    Examples
    --------
    >>> memory_size("2G"), memory_size("700MiB"), memory_size("1000000000")
    (2147483648, 734003200, 1000000000)
    """
    match = re.fullmatch(r"\s*(\d+(?:\.\d+)?)\s*([KMGT]?)(?:I?B)?\s*", str(text).upper())
    if not match:
        raise argparse.ArgumentTypeError(f"expected a size such as 4G or 500M, got '{text}'")
    size = int(float(match.group(1)) * _UNITS[match.group(2)])
    if size < 2 * BASELINE_BYTES:
        raise argparse.ArgumentTypeError(f"{text} is too little to run in: give at least {2 * BASELINE_BYTES >> 20}M")
    return size


def default_max_memory() -> int:
    """Half the machine's memory."""
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE") // 2
    except (ValueError, OSError, AttributeError):
        return 4 * 2**30


def add_engine_options(p) -> None:
    g = p.add_argument_group("scale (surveys larger than memory)")
    g.add_argument(
        "--engine",
        choices=ENGINES,
        default="auto",
        help="memory: the whole cloud at once (all detectors); stream: in chunks, the voxel detector, memory "
        "bounded by --max-memory (with --sets, --kinematics or --detector facets: the facets found on every point "
        "in tiles with halos, the rest on the survey thinned to what fits, every point labelled); dask: the chunks "
        "and tiles as tasks on a dask.distributed cluster; auto (default): memory when the cloud fits in "
        "--max-memory, else stream",
    )
    g.add_argument(
        "--max-memory",
        type=memory_size,
        default=None,
        metavar="SIZE",
        help="the most memory a run may take, e.g. 8G (default: half the machine's)",
    )
    g.add_argument(
        "--scheduler", metavar="ADDRESS", help="--engine dask: a running scheduler (default: a local cluster)"
    )
    g.add_argument("--workers", type=workers(), default=None, help="--engine dask: local workers (default 2)")
    g.add_argument(
        "--thin",
        action="store_true",
        help="with --engine stream or dask and --sets, --kinematics or --detector facets: find the facets on the "
        "thinned survey too, not on every point (faster; joints under about ten thinned cells across are lost)",
    )
    g.add_argument(
        "--spill-dir", metavar="FOLDER", help="where a streamed run spills the points (default: the temporary folder)"
    )


def measures_in_memory(args) -> bool:
    """What a streamed run cannot measure chunk by chunk: the sets' rock mass, the slope's
    kinematics and the facet detector, all on each point's neighbours. A survey too large
    for memory is thinned for them (:mod:`.thinned`)."""
    return bool(wants_sets(args) or args.kinematics or args.detector == "facets")


def memory_bytes_per_point(args) -> int:
    """What a run in memory takes a point, past :data:`MEMORY_BASE_BYTES`."""
    return MEMORY_BYTES_PER_POINT_ROCK if wants_sets(args) or args.kinematics else MEMORY_BYTES_PER_POINT


def check_spill_dir(folder) -> None:
    """Refuse, before any work, a --spill-dir that is no writable folder (it was reported
    after the read as the output folder's failure)."""
    import tempfile
    from pathlib import Path

    folder = Path(folder)
    if not folder.is_dir():
        raise ParameterError(f"--spill-dir {folder}: no such folder; give an existing folder with room for the points.")
    try:
        os.rmdir(tempfile.mkdtemp(prefix=".geostructure-probe-", dir=folder))
    except OSError as exc:
        raise ParameterError(f"--spill-dir {folder}: the folder is not writable ({exc.strerror}).") from None


def check_scheduler_address(address: str) -> None:
    """Refuse, before any work, a --scheduler that is no Dask address (``tcp://HOST:PORT``)."""
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


def chosen_engine(args, paths) -> str:
    """The engine a run takes: the one asked, or for ``auto`` memory when the cloud fits."""
    engine = getattr(args, "engine", "memory")
    given = [name for name, value in (("--scheduler", args.scheduler), ("--workers", args.workers)) if value]
    if given and engine != "dask":
        raise ParameterError(f"{' and '.join(given)} set up a Dask cluster: give them with --engine dask.")
    if getattr(args, "thin", False) and engine == "memory":
        raise ParameterError("--thin thins a survey larger than memory: give it with --engine stream, dask or auto.")
    if args.workers is not None and args.workers < 1:
        raise ParameterError(f"--workers must be at least 1, not {args.workers}.")
    if args.scheduler:
        check_scheduler_address(args.scheduler)
    if getattr(args, "spill_dir", None) is not None:
        check_spill_dir(args.spill_dir)
    if engine != "auto":
        return engine
    limit = args.max_memory or default_max_memory()
    need = MEMORY_BASE_BYTES + memory_bytes_per_point(args) * estimate_points(paths, args.mesh_samples or None)
    return "memory" if need <= limit else "stream"


def chunk_points(args) -> int:
    """Points per chunk from ``--max-memory``: half the bound past the baseline for the chunk."""
    if args.max_memory is None:
        return DEFAULT_CHUNK_POINTS
    budget = (args.max_memory - BASELINE_BYTES) // 2
    return int(max(50_000, min(DEFAULT_CHUNK_POINTS, budget // CHUNK_BYTES_PER_POINT)))


def run_streamed(args, paths, frame, engine: str, extra: dict | None, *, truth=None, inputs=()) -> int:
    """Measure ``paths`` streamed (or on Dask) and write the folder's files as one set
    (:func:`~geostructure.workflows.survey.measure_survey`); print the planes."""
    t = time.perf_counter()
    with StageProgress(enabled=not args.quiet) as progress:
        run = measure_survey(paths, args.outdir, frame=frame, params=base_params(args), auto=args.auto,
                             given=given_factors(args), engine=engine, chunk_points=chunk_points(args),
                             scheduler=args.scheduler, workers=args.workers, spill_dir=args.spill_dir,
                             mesh_samples=args.mesh_samples or None, crs=crs_from(args),
                             unit=getattr(args, "unit", None), grid_north=args.grid_north, truth=truth,
                             truth_path=args.truth, report=args.report, extra=extra, inputs=inputs,
                             progress=progress)  # fmt: skip
    result, evaluation = run.result, run.evaluation
    say_what_was_left(len(result), "voxel", result.cloud.crs is not None, args.min_points, result.counts)
    if not args.quiet:
        print_planes(result, metres_per_unit=recorded_unit({"crs": result.cloud.crs, **run.record})["metres"])
        if evaluation is not None:
            print_evaluation(evaluation)
        print(
            f"{counted(len(result), 'plane')} from {result.counts['input']:,} points ({engine} engine) in "
            f"{time.perf_counter() - t:.1f} s; wrote {', '.join(str(p) for p in run.paths.values())}"
        )
    return 0
