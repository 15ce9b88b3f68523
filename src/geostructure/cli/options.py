"""What the commands share: option types (numbers are checked where they are parsed, so NaN,
infinity and impossible counts get argparse's one-line error, exit 2, before any work), the
measuring options, and the frame and parameters they give."""

from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path

from geostructure.core.orientation import Frame
from geostructure.core.params import MAX_K, Params
from geostructure.detect.registry import DETECTORS, STREAMED_DETECTOR
from geostructure.errors import ParameterError
from geostructure.io.crs import UNITS, check_cloud_crs, check_unit, parse_crs
from geostructure.io.outdir import check_inputs_not_outputs, check_outdir
from geostructure.io.survey_files import check_headers
from geostructure.workflows.outcrop import chosen_params


def finite_float(text: str) -> float:
    """An option's number: NaN and infinity are refused here, before any work."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"'{text}' is not a finite number")
    return value


def positive_float(text: str) -> float:
    value = finite_float(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"{text} is not positive")
    return value


def declination(text: str) -> float:
    """A magnetic declination: degrees east of true north, from -180 to 180 (400 is a slip,
    not 40 degrees)."""
    value = finite_float(text)
    if not -180.0 <= value <= 180.0:
        raise argparse.ArgumentTypeError(f"{text} degrees is not a declination: give one from -180 to 180")
    return value


def whole_number(minimum: int, maximum: int | None = None):
    """An argparse type: a whole number of at least ``minimum`` (and at most ``maximum``)."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"'{text}' is not a whole number") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"{value} is less than {minimum}")
        if maximum is not None and value > maximum:
            raise argparse.ArgumentTypeError(f"{value} is more than {maximum}")
        return value

    parse.__name__ = f"whole number >= {minimum}"
    return parse


#: Processes or workers a command may start per core of the machine: more only queue, and a
#: billion forked 5,702 processes (sweep) or grew a dask cluster to 24 GB before the kernel
#: stopped it.
WORKERS_PER_CORE = 4
#: Points of the synthetic demo scene at most: 10 million take some 3 GB to measure; 10^10
#: ran into the memory cap.
MAX_DEMO_POINTS = 10_000_000


def workers() -> object:
    """An argparse type: a count of parallel workers, from 1 to :data:`WORKERS_PER_CORE` per core."""
    return whole_number(1, WORKERS_PER_CORE * max(1, os.cpu_count() or 1))


def folder(text: str) -> Path:
    """An output folder's name; an empty one is refused (it would mean the current folder)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("the output folder's name is empty")
    return Path(text)


def non_negative_float(text: str) -> float:
    value = finite_float(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"{text} is negative")
    return value


def add_measure_options(p: argparse.ArgumentParser, auto_default: bool = True) -> None:
    defaults = Params()
    g = p.add_argument_group("frame (which way is up and north)")
    g.add_argument(
        "--frame",
        choices=("enu", "paper"),
        default="enu",
        help="enu: x=East y=North z=Up (default); paper: x=North y=West z=Up",
    )
    g.add_argument("--up", type=finite_float, nargs=3, metavar=("X", "Y", "Z"), help="up vector in cloud axes")
    g.add_argument("--north", type=finite_float, nargs=3, metavar=("X", "Y", "Z"), help="north vector in cloud axes")
    g.add_argument(
        "--crs",
        metavar="EPSG:XXXX|WKT_FILE",
        help="the cloud's coordinate reference system, for one that declares none (text, PLY, E57, or a "
        "reconstruction with ground control): planes.geojson and planes.gpkg are written only with one",
    )
    g.add_argument(
        "--unit",
        choices=sorted(UNITS),
        help="the length unit of a cloud without a CRS (default m): the plane table keeps it, and the rock mass "
        "(spacing, traces, intensities) is turned into metres",
    )
    g.add_argument(
        "--declination",
        type=declination,
        default=0.0,
        help="magnetic declination in degrees, east positive: azimuths read against magnetic north",
    )
    g.add_argument(
        "--grid-north",
        action="store_true",
        help="read azimuths against the CRS's grid north (its y axis) instead of true north: a cloud with a "
        "projected CRS is otherwise turned by the grid convergence at its centre",
    )
    a = p.add_argument_group("algorithm (the paper's variable factors)")
    a.add_argument(
        "--auto",
        action=argparse.BooleanOptionalAction,
        default=auto_default,
        help="choose zeta, theta, psi and k from the cloud (explicit values below still win)",
    )
    a.add_argument("--zeta", type=finite_float, help=f"voxel edge / largest extent (fixed default {defaults.zeta})")
    a.add_argument("--theta", type=finite_float, help=f"angle threshold, degrees (fixed default {defaults.theta})")
    a.add_argument("--psi", type=finite_float, help=f"offset threshold, voxel edges (fixed default {defaults.psi})")
    a.add_argument("--k", type=whole_number(1, MAX_K), help=f"neighbours per seed (fixed default {defaults.k})")
    a.add_argument(
        "--min-points",
        type=int,
        default=None,
        help="smallest region reported (default: 30; with --detector voxel 0.1%% of points, >= 30)",
    )
    a.add_argument(
        "--filter",
        choices=("local", "global", "none"),
        default=defaults.filter,
        help="Mahalanobis outlier filter (default %(default)s)",
    )
    a.add_argument(
        "--sigma",
        type=positive_float,
        default=defaults.filter_sigma,
        help="filter threshold, std (default %(default)s)",
    )
    a.add_argument(
        "--reference",
        choices=("region", "seed"),
        default=defaults.reference,
        help="compare normals with the region plane or the seed (default %(default)s)",
    )
    a.add_argument(
        "--rectangle",
        choices=("exact", "golden"),
        default=defaults.rectangle,
        help="minimum-perimeter rectangle by rotating calipers or golden-section search",
    )
    a.add_argument(
        "--merge",
        action=argparse.BooleanOptionalAction,
        default=defaults.merge,
        help="join coplanar regions split by a gap no wider than the smaller one (default on; "
        "--no-merge gives the paper's regions)",
    )
    a.add_argument(
        "--detector",
        choices=tuple(DETECTORS),
        default=None,
        help="; ".join(f"{name}: {spec.help}" for name, spec in DETECTORS.items())
        + f" (default {defaults.detector} in memory; {STREAMED_DETECTOR} when streamed, unless --sets, --kinematics "
        f"or --detector {defaults.detector} thin the survey to what fits)",
    )
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bars and no table")


FACTOR_OPTIONS = ("zeta", "theta", "psi", "k")


def given_factors(args) -> dict:
    """The paper's factors the user set on the command line."""
    return {name: getattr(args, name) for name in FACTOR_OPTIONS if getattr(args, name) is not None}


def base_params(args) -> Params:
    """The parameters the options give, checked (and warned about) once, before any reading."""
    given = given_factors(args)
    return Params(
        min_points=args.min_points,
        filter=args.filter,
        filter_sigma=args.sigma,
        reference=args.reference,
        rectangle=args.rectangle,
        merge=args.merge,
        detector=args.detector or Params().detector,
        **given,
    )


def params_from(args, cloud=None) -> tuple[Params, dict | None, object]:
    """Parameters from the options; with --auto (and a cloud), chosen from the cloud first.

    Returns the parameters, for --auto a record of the choice for run.json, and the cloud's
    voxel moments the choice summed (:class:`~geostructure.detect.voxel.CloudMoments`, for
    ``measure(..., moments=)``; None without --auto).
    """
    base = base_params(args)
    if cloud is None:
        return base, None, None
    return chosen_params(cloud, base, args.auto, given_factors(args), choice_teller(args))


def choice_teller(args):
    """What tells the user the automatic choice: a line on stderr, none under ``-q``."""

    def say(text: str) -> None:
        if not args.quiet:
            print(f"geostructure: {text}", file=sys.stderr)

    return say


def frame_from(args) -> Frame:
    if (args.up is None) != (args.north is None):
        raise ParameterError("give both --up and --north, or neither.")
    if args.up is not None:
        return Frame.from_up_north(args.up, args.north, args.declination)
    return Frame.named(args.frame, args.declination)


def crs_from(args) -> str | None:
    """``--crs`` as the text a cloud carries (``EPSG:XXXX``, or the WKT of a file), checked
    before any work; None when not given."""
    text = getattr(args, "crs", None)
    if text is not None and not text.strip():
        raise ParameterError("--crs is empty: give EPSG:XXXX or a file holding the CRS's WKT, or leave it out.")
    if not text:
        return None
    crs = parse_crs(text)
    check_cloud_crs(text, f"--crs {text}")
    authority = crs.to_authority()
    return (
        f"{authority[0]}:{authority[1]}" if authority and text.upper().startswith(("EPSG:", "ESRI:")) else crs.to_wkt()
    )


def check_before_work(args, inputs) -> None:
    """Everything cheap, before reading a cloud: the output folder, and inputs it would overwrite."""
    check_outdir(args.outdir)
    check_inputs_not_outputs(args.outdir, [p for p in inputs if p is not None])


def check_unit_given(args, paths) -> None:
    """``--unit`` refused before any work where a CRS says otherwise: ``--crs``, or the one
    the LAS/LAZ headers declare."""
    unit = getattr(args, "unit", None)
    if unit is None:
        return
    if getattr(args, "crs", None):
        check_unit(unit, crs_from(args), f"--crs {args.crs}")
        return
    declared = check_headers(paths)
    if declared is not None:
        check_unit(unit, *declared)
