"""``measure --engine``'s options: in memory, streamed in chunks, or on a Dask cluster, and
the memory bound that chooses between them (:mod:`geostructure.workflows.engine_choice`)."""

from __future__ import annotations

import argparse
import re

from geostructure.cli.options import workers
from geostructure.workflows.engine_choice import BASELINE_BYTES, ENGINES

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
