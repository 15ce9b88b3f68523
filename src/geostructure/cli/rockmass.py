"""The commands on a rock mass's measured planes: sets with their spacing, persistence and
intensity (and, as it comes, kinematics)."""

from __future__ import annotations

from pathlib import Path

from ..runs import add_sets
from ..tables import print_sets
from .options import add_set_options


def add_rockmass_commands(sub) -> None:
    s = sub.add_parser("sets", help="joint sets of a measured OUTDIR: sets.csv and a set column in planes.csv")
    s.add_argument("outdir", type=Path, help="a folder written by 'geostructure measure'")
    add_set_options(s, "--auto")
    s.add_argument("-q", "--quiet", action="store_true", help="no table")
    s.set_defaults(run=run_sets)


def run_sets(args) -> int:
    sets, rock, paths = add_sets(args.outdir, n_sets=args.n_sets)
    if not args.quiet:
        print_sets(sets, rock=rock)
        print(f"wrote {', '.join(str(p) for p in paths.values())}")
    return 0
