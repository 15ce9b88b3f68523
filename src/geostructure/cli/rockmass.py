"""The commands on a rock mass's measured planes: sets with their spacing, persistence and
intensity, and the kinematic tests of the slope; and their options, which ``measure`` takes
too (``--sets``, ``--kinematics``)."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from geostructure.cli.options import whole_number
from geostructure.cli.progress import StageProgress
from geostructure.errors import ParameterError
from geostructure.kinematics.modes import LATERAL_LIMIT, UNIT_WEIGHT, Slope, check_friction, check_strength
from geostructure.report.terminal import print_kinematics, print_sets
from geostructure.workflows.kinematics import add_kinematics
from geostructure.workflows.saving import add_sets


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
    add_kinematic_options(k, flag=False)
    k.add_argument("-q", "--quiet", action="store_true", help="no table")
    k.set_defaults(run=run_kinematics, kinematics=True)


def run_sets(args) -> int:
    with StageProgress(enabled=not args.quiet) as progress:
        sets, rock, paths = add_sets(args.outdir, n_sets=args.n_sets, progress=progress)
    if not args.quiet:
        print_sets(sets, rock=rock)
        print(f"wrote {', '.join(str(p) for p in paths.values())}")
    return 0


def run_kinematics(args: argparse.Namespace) -> int:
    with StageProgress(enabled=not args.quiet) as progress:
        summary, paths = add_kinematics(args.outdir, **kinematic_settings(args), progress=progress)
    if not args.quiet:
        print_kinematics(summary)
        print(f"wrote {', '.join(str(p) for p in paths.values())}")
    return 0


def add_set_options(parser, choose_flag: str) -> None:
    """``--n-sets N`` or ``choose_flag`` (``--auto`` for ``sets``, ``--sets`` for ``measure``):
    the number of joint sets, given or chosen."""
    group = parser.add_mutually_exclusive_group()
    group.add_argument(
        "--n-sets", type=whole_number(1), default=None, help="cluster the planes' poles into this many joint sets"
    )
    group.add_argument(
        choose_flag,
        dest="choose_sets",
        action="store_true",
        help="joint sets, their number chosen by BIC with the sets at least 20 degrees apart",
    )


def add_kinematic_options(parser, *, flag: bool) -> None:
    """``--friction``, ``--slope`` and ``--lateral-limits``; with ``flag`` (for ``measure``),
    ``--kinematics`` turns the tests on and ``--friction`` is then needed."""
    if flag:
        parser.add_argument("--kinematics", action="store_true", help="also run the kinematic tests (needs --friction)")
    parser.add_argument(
        "--friction",
        type=float,
        required=not flag,
        default=None,
        metavar="PHI",
        help="friction angle of the joints, degrees",
    )
    parser.add_argument(
        "--slope",
        default="auto",
        metavar="DIP/DIPDIR",
        help="the slope face as dip/dip direction (e.g. 75/180), or 'auto': fitted to the cloud (default)",
    )
    parser.add_argument(
        "--lateral-limits",
        type=float,
        default=LATERAL_LIMIT,
        metavar="DEG",
        help=f"degrees either side of the slope's dip direction (default {LATERAL_LIMIT:g})",
    )
    parser.add_argument(
        "--cohesion",
        type=float,
        default=0.0,
        metavar="KPA",
        help="cohesion of the joints, kPa, for the planar and wedge factors of safety (default 0: frictional)",
    )
    parser.add_argument(
        "--unit-weight",
        type=float,
        default=UNIT_WEIGHT,
        metavar="KN/M3",
        help=f"unit weight of the rock, kN/m3 (default {UNIT_WEIGHT:g})",
    )
    parser.add_argument(
        "--height",
        type=float,
        default=None,
        metavar="M",
        help="the slope's height, m, for the planar and wedge blocks with cohesion (default: the cloud's height)",
    )
    parser.add_argument(
        "--upper-slope",
        default=None,
        metavar="DIP/DIPDIR",
        help="the ground above the crest, for the wedges with cohesion (default: level)",
    )


def kinematic_settings(args) -> dict | None:
    """The kinematic tests' settings from the options, checked (before any work): friction,
    slope (None: fit it) and lateral limit; None when they were not asked for."""
    if not getattr(args, "kinematics", False):  # the kinematics command sets it; measure's flag does
        return None
    if args.friction is None:
        raise ParameterError("--kinematics needs the joints' friction angle: add --friction PHI (degrees).")
    check_friction(args.friction)
    if not 0.0 <= args.lateral_limits <= 90.0:
        raise ParameterError(f"--lateral-limits must be 0 to 90 degrees, not {args.lateral_limits}.")
    slope = None
    if args.slope.strip().lower() != "auto":
        slope = Slope(*_dip_and_direction("--slope", args.slope, "75/180", " or 'auto'"))
    upper = None
    if args.upper_slope is not None:
        upper = _dip_and_direction("--upper-slope", args.upper_slope, "12/195")
        if not (math.isfinite(upper[0]) and 0.0 <= upper[0] < (slope.dip if slope is not None else 90.0)):
            raise ParameterError(f"--upper-slope must dip 0 or more and less than the face, not {upper[0]:g} degrees.")
    check_strength(args.cohesion, args.unit_weight, args.height)
    return {
        "friction": args.friction,
        "slope": slope,
        "lateral_limit": args.lateral_limits,
        "cohesion": args.cohesion,
        "unit_weight": args.unit_weight,
        "height": args.height,
        "upper_slope": upper,
    }


def _dip_and_direction(option: str, text: str, example: str, alternative: str = "") -> tuple[float, float]:
    try:
        dip, dip_direction = (float(v) for v in text.split("/"))
    except ValueError:
        raise ParameterError(
            f"{option} takes DIP/DIPDIR in degrees (e.g. {example}){alternative}, not {text!r}."
        ) from None
    if not 0.0 <= dip_direction <= 360.0:  # 75/400 is a slip, not 75/40
        raise ParameterError(f"{option}: the dip direction must be 0 to 360 degrees, not {dip_direction:g}.")
    return dip, dip_direction


def wants_sets(args) -> bool:
    return bool(getattr(args, "choose_sets", False) or getattr(args, "n_sets", None))
