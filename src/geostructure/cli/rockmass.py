"""The commands on a rock mass's measured planes: sets with their spacing, persistence and
intensity, and the kinematic tests of the slope."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..errors import ParameterError
from ..kinematics import LATERAL_LIMIT, Slope
from ..runs import add_sets
from ..slope_stability import add_kinematics
from ..tables import print_kinematics, print_sets
from .options import add_set_options


def add_rockmass_commands(sub) -> None:
    s = sub.add_parser("sets", help="joint sets of a measured OUTDIR: sets.csv and a set column in planes.csv")
    s.add_argument("outdir", type=Path, help="a folder written by 'geostructure measure'")
    add_set_options(s, "--auto")
    s.add_argument("-q", "--quiet", action="store_true", help="no table")
    s.set_defaults(run=run_sets)

    k = sub.add_parser(
        "kinematics",
        help="which planes and wedges can slide or topple out of the slope: kinematics.csv, wedges.csv, .json, .png",
    )
    k.add_argument("outdir", type=Path, help="a folder written by 'geostructure measure' (with --sets for set results)")
    k.add_argument("--friction", type=float, required=True, metavar="PHI", help="friction angle of the joints, degrees")
    k.add_argument(
        "--slope",
        default="auto",
        metavar="DIP/DIPDIR",
        help="the slope face as dip/dip direction (e.g. 75/180), or 'auto': fitted to the cloud (default)",
    )
    k.add_argument(
        "--lateral-limits",
        type=float,
        default=LATERAL_LIMIT,
        metavar="DEG",
        help=f"degrees either side of the slope's dip direction (default {LATERAL_LIMIT:g})",
    )
    k.add_argument("-q", "--quiet", action="store_true", help="no table")
    k.set_defaults(run=run_kinematics)


def run_sets(args) -> int:
    sets, rock, paths = add_sets(args.outdir, n_sets=args.n_sets)
    if not args.quiet:
        print_sets(sets, rock=rock)
        print(f"wrote {', '.join(str(p) for p in paths.values())}")
    return 0


def parse_slope(text: str) -> Slope | None:
    """``auto`` -> None (fit it), ``DIP/DIPDIR`` -> a given :class:`~geostructure.kinematics.Slope`."""
    if text.strip().lower() == "auto":
        return None
    try:
        dip, dip_direction = (float(v) for v in text.split("/"))
    except ValueError:
        raise ParameterError(f"--slope takes DIP/DIPDIR in degrees (e.g. 75/180) or 'auto', not {text!r}.") from None
    return Slope(dip, dip_direction)


def run_kinematics(args: argparse.Namespace) -> int:
    if not 0.0 <= args.lateral_limits <= 90.0:
        raise ParameterError(f"--lateral-limits must be 0 to 90 degrees, not {args.lateral_limits}.")
    summary, paths = add_kinematics(
        args.outdir, args.friction, slope=parse_slope(args.slope), lateral_limit=args.lateral_limits
    )
    if not args.quiet:
        print_kinematics(summary)
        print(f"wrote {', '.join(str(p) for p in paths.values())}")
    return 0
