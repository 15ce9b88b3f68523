"""Command line: argument parsing only; every command calls the public Python API."""
from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

from . import __version__
from .errors import GeoStructureError, GeoStructureWarning
from .evaluate import PlaneSet, evaluate
from .io.outdir import check_inputs_not_outputs, check_outdir
from .io.readers import DEFAULT_MESH_SAMPLES, read_cloud
from .io.truth import read_truth
from .orientation import Frame
from .params import Params
from .pipeline import measure
from .progress import StageProgress
from .cli_types import finite_float, positive_float, whole
from .runs import add_evaluation, add_report, save_measurement
from .tables import print_evaluation, print_match, print_planes, print_sweep

EXIT_USER_ERROR = 2


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "command", None):
        parser.print_help()
        return EXIT_USER_ERROR
    with warnings.catch_warnings():
        warnings.simplefilter("always")
        warnings.showwarning = _warning_printer()
        try:
            return args.run(args) or 0
        except GeoStructureError as exc:
            print(f"geostructure: error: {exc}", file=sys.stderr)
            return EXIT_USER_ERROR
        except OSError as exc:  # the machine's, not the data's: a disk, a permission, a device
            where = f"{exc.filename}: " if exc.filename else ""
            print(f"geostructure: error: {where}{exc.strerror or exc}.", file=sys.stderr)
            return EXIT_USER_ERROR
        except KeyboardInterrupt:
            print("geostructure: interrupted; the output folder keeps its previous set (no half-written files).",
                  file=sys.stderr)
            return 130


def _warning_printer():
    """``warnings.showwarning`` for one command: each message once, however often a value is
    checked (warnings' own "once" forgets whenever a filter changes)."""
    shown = set()

    def show(message, category, filename, lineno, file=None, line=None):
        if str(message) in shown:
            return
        shown.add(str(message))
        if issubclass(category, GeoStructureWarning):
            print(f"geostructure: warning: {message}", file=sys.stderr)
        else:  # a library's own warning got past us: our defect, said as such, never passed off as advice
            print(f"geostructure: internal warning (please report it): {category.__name__} at "
                  f"{Path(filename).name}:{lineno}: {message}", file=sys.stderr)
    return show


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="geostructure", description=(
        "Measure strike, dip and dip direction of the planar surfaces in a point cloud."))
    parser.add_argument("--version", action="version", version=f"geostructure {__version__}")
    sub = parser.add_subparsers(dest="command")

    m = sub.add_parser("measure", help="measure the planes of a point cloud file")
    m.add_argument("input", type=Path, help="PLY, LAS, LAZ, E57, XYZ, TXT or CSV file")
    m.add_argument("-o", "--outdir", type=Path, required=True, help="folder for planes.csv, regions.ply, run.json")
    m.add_argument("--mesh-samples", type=whole(0), default=DEFAULT_MESH_SAMPLES,
                   help="points sampled on a PLY mesh's faces (0: use the vertices only)")
    m.add_argument("--truth", type=Path, help="ground-truth CSV: also evaluate the planes against it")
    m.add_argument("--report", action="store_true", help="also write report.html, stereonet and rose figures")
    add_measure_options(m)
    m.set_defaults(run=run_measure)

    e = sub.add_parser("evaluate", help="score a measured OUTDIR against a ground-truth CSV")
    e.add_argument("outdir", type=Path, help="a folder written by 'geostructure measure'")
    e.add_argument("--truth", type=Path, required=True, help="CSV: surface, strike, dip, dip_direction[, center_*]")
    e.add_argument("--fit-frame", action="store_true",
                   help="for an unreferenced cloud: fit the frame from the ground-truth planes, then score")
    e.add_argument("-q", "--quiet", action="store_true", help="no table")
    e.set_defaults(run=run_evaluate)

    r = sub.add_parser("report", help="interactive report.html, stereonet and rose figures of a measured OUTDIR")
    r.add_argument("outdir", type=Path, help="a folder written by 'geostructure measure'")
    r.add_argument("--max-points", type=whole(1), default=None,
                   help="points drawn in 3D at most (default 100000; the file grows ~70 bytes a point)")
    r.add_argument("-q", "--quiet", action="store_true")
    r.set_defaults(run=run_report)

    w = sub.add_parser("sweep", help="the paper's experiments: vary one factor, record time and z(R)")
    w.add_argument("input", type=Path, nargs="?", help="cloud file (or --demo for the bundled scene)")
    w.add_argument("--demo", action="store_true", help="sweep the bundled synthetic scene against its exact truth")
    w.add_argument("--truth", type=Path, help="ground-truth CSV (required unless --demo)")
    w.add_argument("-o", "--outdir", type=Path, default=Path("out/sweep"))
    w.add_argument("--factor", choices=("zeta", "theta", "psi", "k", "all"), default="all")
    w.add_argument("--start", type=finite_float)
    w.add_argument("--end", type=finite_float)
    w.add_argument("--step", type=positive_float)
    w.add_argument("--workers", type=whole(1), default=2, help="runs in parallel (default %(default)s)")
    w.add_argument("--points", type=whole(1000), default=300_000, help="points in the --demo scene")
    w.add_argument("--mesh-samples", type=whole(0), default=DEFAULT_MESH_SAMPLES)
    add_measure_options(w, auto_default=False)
    w.set_defaults(run=run_sweep)

    d = sub.add_parser("demo", help="measure the bundled synthetic observatory scene")
    d.add_argument("-o", "--outdir", type=Path, default=Path("out/demo"))
    d.add_argument("--points", type=whole(1000), default=300_000, help="points in the scene")
    d.add_argument("--seed", type=int, default=0)
    d.add_argument("--report", action=argparse.BooleanOptionalAction, default=True,
                   help="also write report.html, stereonet and rose figures (default on)")
    add_measure_options(d)
    d.set_defaults(run=run_demo)

    from .cli_reconstruct import add_reconstruct_commands

    add_reconstruct_commands(sub)
    return parser


def add_measure_options(p: argparse.ArgumentParser, auto_default: bool = True) -> None:
    defaults = Params()
    g = p.add_argument_group("frame (which way is up and north)")
    g.add_argument("--frame", choices=("enu", "paper"), default="enu",
                   help="enu: x=East y=North z=Up (default); paper: x=North y=West z=Up")
    g.add_argument("--up", type=finite_float, nargs=3, metavar=("X", "Y", "Z"), help="up vector in cloud axes")
    g.add_argument("--north", type=finite_float, nargs=3, metavar=("X", "Y", "Z"), help="north vector in cloud axes")
    g.add_argument("--declination", type=finite_float, default=0.0,
                   help="magnetic declination in degrees, east positive: azimuths read against magnetic north")
    a = p.add_argument_group("algorithm (the paper's variable factors)")
    a.add_argument("--auto", action=argparse.BooleanOptionalAction, default=auto_default,
                   help="choose zeta, theta, psi and k from the cloud (explicit values below still win)")
    a.add_argument("--zeta", type=finite_float, help=f"voxel edge / largest extent (fixed default {defaults.zeta})")
    a.add_argument("--theta", type=finite_float, help=f"angle threshold, degrees (fixed default {defaults.theta})")
    a.add_argument("--psi", type=finite_float, help=f"offset threshold, voxel edges (fixed default {defaults.psi})")
    a.add_argument("--k", type=int, help=f"neighbours per seed (fixed default {defaults.k})")
    a.add_argument("--min-points", type=int, default=None, help="smallest region reported (default: 0.1%% of points, >= 30)")
    a.add_argument("--filter", choices=("local", "global", "none"), default=defaults.filter,
                   help="Mahalanobis outlier filter (default %(default)s)")
    a.add_argument("--sigma", type=positive_float, default=defaults.filter_sigma, help="filter threshold, std (default %(default)s)")
    a.add_argument("--reference", choices=("region", "seed"), default=defaults.reference,
                   help="compare normals with the region plane or the seed (default %(default)s)")
    a.add_argument("--rectangle", choices=("exact", "golden"), default=defaults.rectangle,
                   help="minimum-perimeter rectangle by rotating calipers or golden-section search")
    a.add_argument("--merge", action=argparse.BooleanOptionalAction, default=defaults.merge,
                   help="join coplanar regions split by a gap no wider than the smaller one (default on; "
                        "--no-merge gives the paper's regions)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bars and no table")


FACTOR_OPTIONS = ("zeta", "theta", "psi", "k")


def base_params(args) -> Params:
    """The parameters the options give, checked (and warned about) once, before any reading."""
    given = {name: getattr(args, name) for name in FACTOR_OPTIONS if getattr(args, name) is not None}
    return Params(min_points=args.min_points, filter=args.filter, filter_sigma=args.sigma,
                  reference=args.reference, rectangle=args.rectangle, merge=args.merge, **given)


def params_from(args, cloud=None) -> tuple[Params, dict | None]:
    """Parameters from the options; with --auto (and a cloud), chosen from the cloud first.

    Returns the parameters and, for --auto, a record of the choice for run.json.
    """
    from .auto import choose_params
    from .pipeline import check_measurable

    given = {name: getattr(args, name) for name in FACTOR_OPTIONS if getattr(args, name) is not None}
    base = base_params(args)
    if not (args.auto and cloud is not None) or len(given) == len(FACTOR_OPTIONS):
        return base, None
    check_measurable(cloud)
    choice = choose_params(cloud.local, base)
    params = choice.params.with_(**given) if given else choice.params
    if not args.quiet:
        print(f"geostructure: {choice.describe()}" + (f"; given: {given}" if given else ""), file=sys.stderr)
    record = {"zeta": choice.params.zeta, "theta": choice.params.theta, "psi": choice.params.psi,
              "k": choice.params.k, "points_per_voxel": choice.points_per_voxel,
              "normal_noise_deg": choice.normal_noise_deg, "offset_noise_voxel_edges": choice.offset_noise,
              "overridden_by_user": sorted(given)}
    return params, record


def frame_from(args) -> Frame:
    if (args.up is None) != (args.north is None):
        raise GeoStructureError("give both --up and --north, or neither.")
    try:
        if args.up is not None:
            return Frame.from_up_north(args.up, args.north, args.declination)
        return Frame.named(args.frame, args.declination)
    except GeoStructureError as exc:  # the library names its parameters; here they are options
        raise GeoStructureError(str(exc).replace("up ", "--up ").replace("north ", "--north ")) from None


def check_before_work(args, inputs) -> None:
    """Everything cheap, before reading a cloud: the output folder, and inputs it would overwrite."""
    check_outdir(args.outdir)
    check_inputs_not_outputs(args.outdir, [p for p in inputs if p is not None])


def run_measure(args) -> int:
    frame = frame_from(args)
    base_params(args)
    check_before_work(args, [args.input, args.truth])
    truth = read_truth(args.truth, frame) if args.truth else None
    t = time.perf_counter()
    cloud = read_cloud(args.input, mesh_samples=args.mesh_samples or None)
    return measure_cloud(cloud, args, frame, {"read": time.perf_counter() - t}, truth=truth,
                         inputs=[args.input, args.truth])


def measure_cloud(cloud, args, frame, seconds: dict, extra: dict | None = None, *, truth=None, inputs=()) -> int:
    """Measure; write the outputs, the evaluation and the report as one set; print the planes."""
    with StageProgress(enabled=not args.quiet) as progress:
        t = time.perf_counter()
        progress("auto", 0, None)
        params, auto = params_from(args, cloud)
        auto_seconds = time.perf_counter() - t
        result = measure(cloud, params, frame, progress)
        result.seconds = {**seconds, "auto": auto_seconds, **result.seconds}
        evaluation = evaluate(PlaneSet.from_result(result), truth) if truth is not None else None
        progress("write", 0, None)
        paths = save_measurement(result, args.outdir, extra={"auto": auto, **(extra or {})}, evaluation=evaluation,
                                 report=args.report, inputs=inputs)
    if not len(result):
        print("geostructure: warning: no plane found; if the cloud is sparse, try a larger --zeta "
              "(voxels need at least 5 points each to fit a plane).", file=sys.stderr)
    if not args.quiet:
        print_planes(result)
        if evaluation is not None:
            print_evaluation(evaluation)
        print(f"{len(result)} planes from {len(cloud):,} points in {sum(result.seconds.values()):.1f} s; "
              f"wrote {', '.join(str(p) for p in paths.values())}")
    return 0


def run_evaluate(args) -> int:
    evaluation, extra, paths = add_evaluation(args.outdir, args.truth, fit_frame=args.fit_frame)
    if not args.quiet:
        print_evaluation(evaluation)
        if extra:
            f = extra["frame_fit"]
            print(f"frame fitted to the ground truth: turned {f['rotation_deg']:.1f} deg; "
                  f"residuals {', '.join(f'{r:.1f}' for r in f['residuals_deg'])} deg (mean {f['mean_residual_deg']:.2f}); "
                  f"angles between surfaces off by {f['pairwise_mean_deg']:.2f} deg on average (frame-free)")
        print(f"wrote {', '.join(str(p) for p in paths.values())}")
    return 0


def run_demo(args) -> int:
    from .evaluate import match_scene
    from .synthetic import observatory_scene

    frame = frame_from(args)
    base_params(args)
    check_outdir(args.outdir)
    scene = observatory_scene(args.points, seed=args.seed)
    params, auto = params_from(args, scene.cloud)
    with StageProgress(enabled=not args.quiet) as progress:
        result = measure(scene.cloud, params, frame, progress)
        match = match_scene(result, scene)
        progress("write", 0, None)
        paths = save_measurement(result, args.outdir, extra={"auto": auto, "demo": {"points": args.points, "seed": args.seed}},
                                 evaluation=match, evaluation_extra={"truth": "the scene's exact surfaces"},
                                 report=args.report)
    if not args.quiet:
        print_planes(result)
        print_match(match)
        print(f"wrote {', '.join(str(p) for p in paths.values())}")
    return 0 if match.all_found else 1


def run_report(args) -> int:
    paths = add_report(args.outdir, max_points=args.max_points)
    if not args.quiet:
        print(f"wrote {', '.join(str(p) for p in paths.values())}")
    return 0


def run_sweep(args) -> int:
    from .evaluate import scene_truth
    from .io.outdir import output_set
    from .io.writers import write_table_csv
    from .sweep import FACTORS, factor_values, plot_sweep, rows_as_dicts
    from .sweep import run_sweep as sweep

    frame = frame_from(args)
    base_params(args)
    if args.factor == "all" and any(v is not None for v in (args.start, args.end, args.step)):
        raise GeoStructureError("--start, --end and --step need a single --factor.")
    factors = FACTORS if args.factor == "all" else (args.factor,)
    ranges = {args.factor: (args.start, args.end, args.step)} if args.factor != "all" else {}
    for factor in factors:  # a bad range is refused before the cloud is read
        factor_values(factor, *ranges.get(factor, (None,) * 3))
    check_before_work(args, [args.input, args.truth])
    if args.demo:
        from .synthetic import observatory_scene

        scene = observatory_scene(args.points)
        cloud, truth = scene.cloud, scene_truth(scene, frame)
    else:
        if args.input is None or args.truth is None:
            raise GeoStructureError("sweep needs INPUT and --truth TRUTH.csv, or --demo.")
        truth = read_truth(args.truth, frame)
        cloud = read_cloud(args.input, mesh_samples=args.mesh_samples or None)
    base, _ = params_from(args, cloud)
    t = time.perf_counter()
    with StageProgress(enabled=not args.quiet) as progress:
        rows = sweep(cloud, truth, frame, factors, base, ranges=ranges, workers=args.workers, progress=progress)
    with output_set(args.outdir, record_name="sweep.json", inputs=[args.input, args.truth]) as outputs:
        write_table_csv(rows_as_dicts(rows), outputs.path("sweep.csv"))
        figures = plot_sweep(rows, outputs.staging / f"sweep_{args.factor}")
        outputs.record = {"input": "demo" if args.demo else str(args.input), "base_params": base.to_dict(),
                          "seconds": round(time.perf_counter() - t, 2), "runs": rows_as_dicts(rows)}
    if not args.quiet:
        print_sweep(rows)
        print(f"{len(rows)} runs in {time.perf_counter() - t:.0f} s; wrote {outputs.final('sweep.csv')}, "
              f"{', '.join(str(outputs.final(p.name)) for p in figures)}")
    return 0
