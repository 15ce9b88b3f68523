"""The commands on a rock mass's measured planes: sets with their spacing, persistence and
intensity, and the kinematic tests of the slope."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..progress import StageProgress
from ..runs import add_sets
from ..slope_stability import add_kinematics
from ..tables import print_kinematics, print_sets
from .options import add_kinematic_options, add_set_options, kinematic_settings


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
