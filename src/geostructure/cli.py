"""Command line: argument parsing only; every command calls the public Python API."""
from __future__ import annotations

import argparse
import sys

import time
import warnings
from pathlib import Path

import numpy as np

from . import __version__
from .errors import GeoStructureError
from .io.readers import DEFAULT_MESH_SAMPLES, read_cloud
from .io.writers import write_outputs
from .orientation import Frame
from .params import Params
from .pipeline import measure
from .progress import StageProgress
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
        warnings.showwarning = _show_warning
        try:
            return args.run(args) or 0
        except GeoStructureError as exc:
            print(f"geostructure: error: {exc}", file=sys.stderr)
            return EXIT_USER_ERROR
        except KeyboardInterrupt:
            print("geostructure: interrupted; no output was written for the unfinished step.", file=sys.stderr)
            return 130


def _show_warning(message, category, filename, lineno, file=None, line=None):
    print(f"geostructure: warning: {message}", file=sys.stderr)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="geostructure", description=(
        "Measure strike, dip and dip direction of the planar surfaces in a point cloud."))
    parser.add_argument("--version", action="version", version=f"geostructure {__version__}")
    sub = parser.add_subparsers(dest="command")

    m = sub.add_parser("measure", help="measure the planes of a point cloud file")
    m.add_argument("input", type=Path, help="PLY, LAS, LAZ, E57, XYZ, TXT or CSV file")
    m.add_argument("-o", "--outdir", type=Path, required=True, help="folder for planes.csv, regions.ply, run.json")
    m.add_argument("--mesh-samples", type=int, default=DEFAULT_MESH_SAMPLES,
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
    r.add_argument("--max-points", type=int, default=None,
                   help="points drawn in 3D at most (default 100000; the file grows ~70 bytes a point)")
    r.add_argument("-q", "--quiet", action="store_true")
    r.set_defaults(run=run_report)

    w = sub.add_parser("sweep", help="the paper's experiments: vary one factor, record time and z(R)")
    w.add_argument("input", type=Path, nargs="?", help="cloud file (or --demo for the bundled scene)")
    w.add_argument("--demo", action="store_true", help="sweep the bundled synthetic scene against its exact truth")
    w.add_argument("--truth", type=Path, help="ground-truth CSV (required unless --demo)")
    w.add_argument("-o", "--outdir", type=Path, default=Path("out/sweep"))
    w.add_argument("--factor", choices=("zeta", "theta", "psi", "k", "all"), default="all")
    w.add_argument("--start", type=float)
    w.add_argument("--end", type=float)
    w.add_argument("--step", type=float)
    w.add_argument("--workers", type=int, default=2, help="runs in parallel (default %(default)s)")
    w.add_argument("--points", type=int, default=300_000, help="points in the --demo scene")
    w.add_argument("--mesh-samples", type=int, default=DEFAULT_MESH_SAMPLES)
    add_measure_options(w, auto_default=False)
    w.set_defaults(run=run_sweep)

    d = sub.add_parser("demo", help="measure the bundled synthetic observatory scene")
    d.add_argument("-o", "--outdir", type=Path, default=Path("out/demo"))
    d.add_argument("--points", type=int, default=300_000, help="points in the scene")
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
    g.add_argument("--up", type=float, nargs=3, metavar=("X", "Y", "Z"), help="up vector in cloud axes")
    g.add_argument("--north", type=float, nargs=3, metavar=("X", "Y", "Z"), help="north vector in cloud axes")
    g.add_argument("--declination", type=float, default=0.0,
                   help="magnetic declination in degrees, east positive: azimuths read against magnetic north")
    a = p.add_argument_group("algorithm (the paper's variable factors)")
    a.add_argument("--auto", action=argparse.BooleanOptionalAction, default=auto_default,
                   help="choose zeta, theta, psi and k from the cloud (explicit values below still win)")
    a.add_argument("--zeta", type=float, help=f"voxel edge / largest extent (fixed default {defaults.zeta})")
    a.add_argument("--theta", type=float, help=f"angle threshold, degrees (fixed default {defaults.theta})")
    a.add_argument("--psi", type=float, help=f"offset threshold, voxel edges (fixed default {defaults.psi})")
    a.add_argument("--k", type=int, help=f"neighbours per seed (fixed default {defaults.k})")
    a.add_argument("--min-points", type=int, default=None, help="smallest region reported (default: 0.1%% of points, >= 30)")
    a.add_argument("--filter", choices=("local", "global", "none"), default=defaults.filter,
                   help="Mahalanobis outlier filter (default %(default)s)")
    a.add_argument("--sigma", type=float, default=defaults.filter_sigma, help="filter threshold, std (default %(default)s)")
    a.add_argument("--reference", choices=("region", "seed"), default=defaults.reference,
                   help="compare normals with the region plane or the seed (default %(default)s)")
    a.add_argument("--rectangle", choices=("exact", "golden"), default=defaults.rectangle,
                   help="minimum-perimeter rectangle by rotating calipers or golden-section search")
    a.add_argument("--merge", action=argparse.BooleanOptionalAction, default=defaults.merge,
                   help="join coplanar regions split by a gap no wider than the smaller one (default on; "
                        "--no-merge gives the paper's regions)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bars and no table")


FACTOR_OPTIONS = ("zeta", "theta", "psi", "k")


def params_from(args, cloud=None) -> tuple[Params, dict | None]:
    """Parameters from the options; with --auto (and a cloud), chosen from the cloud first.

    Returns the parameters and, for --auto, a record of the choice for run.json.
    """
    given = {name: getattr(args, name) for name in FACTOR_OPTIONS if getattr(args, name) is not None}
    base = Params(min_points=args.min_points, filter=args.filter, filter_sigma=args.sigma,
                  reference=args.reference, rectangle=args.rectangle, merge=args.merge, **given)
    if not (args.auto and cloud is not None) or len(given) == len(FACTOR_OPTIONS):
        return base, None
    from .auto import choose_params
    from .pipeline import check_measurable

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
    if args.up is not None:
        return Frame.from_up_north(args.up, args.north, args.declination)
    return Frame.named(args.frame, args.declination)


def run_measure(args) -> int:
    frame = frame_from(args)
    params_from(args)  # refuse bad parameters before any reading
    t = time.perf_counter()
    cloud = read_cloud(args.input, mesh_samples=args.mesh_samples or None)
    return measure_cloud(cloud, args, frame, {"read": time.perf_counter() - t})


def measure_cloud(cloud, args, frame, seconds: dict, extra: dict | None = None) -> int:
    """Measure, write the outputs, print the planes; then evaluate and report if asked."""
    with StageProgress(enabled=not args.quiet) as progress:
        t = time.perf_counter()
        progress("auto", 0, None)
        params, auto = params_from(args, cloud)
        auto_seconds = time.perf_counter() - t
        result = measure(cloud, params, frame, progress)
        result.seconds = {**seconds, "auto": auto_seconds, **result.seconds}
        progress("write", 0, None)
        paths = write_outputs(result, args.outdir, extra={"auto": auto, **(extra or {})})
    if not len(result):
        print("geostructure: warning: no plane found; if the cloud is sparse, try a larger --zeta "
              "(voxels need at least 5 points each to fit a plane).", file=sys.stderr)
    if not args.quiet:
        print_planes(result)
        print(f"{len(result)} planes from {len(cloud):,} points in {sum(result.seconds.values()):.1f} s; "
              f"wrote {', '.join(str(p) for p in paths.values())}")
    status = 0
    if args.truth:
        status = run_evaluate(argparse.Namespace(outdir=args.outdir, truth=args.truth, quiet=args.quiet, fit_frame=False))
    if args.report:
        run_report(argparse.Namespace(outdir=args.outdir, quiet=args.quiet, max_points=None))
    return status


def run_evaluate(args) -> int:
    import json

    from .evaluate import PlaneSet, evaluate
    from .io.truth import read_truth
    from .io.writers import write_evaluation

    run_path = args.outdir / "run.json"
    try:
        frame_record = json.loads(run_path.read_text())["frame"]
        frame = Frame(tuple(map(tuple, frame_record["rotation"])), frame_record["declination"], frame_record["name"])
    except FileNotFoundError:
        raise GeoStructureError(f"{run_path}: no such file; run 'geostructure measure' first.") from None
    except (ValueError, KeyError, TypeError):
        raise GeoStructureError(f"{run_path}: not a GeoStructure run record.") from None
    planes, truth = PlaneSet.from_csv(args.outdir / "planes.csv"), read_truth(args.truth, frame)
    extra, matched = {}, None
    if args.fit_frame:
        planes, truth, extra = _refit_frame(planes, truth, frame, args.truth)
        matched = extra["frame_fit"]["matched_regions"]
    evaluation = evaluate(planes, truth, matched=matched)
    paths = write_evaluation(evaluation, args.outdir, extra)
    if not args.quiet:
        print_evaluation(evaluation)
        if extra:
            f = extra["frame_fit"]
            print(f"frame fitted to the ground truth: turned {f['rotation_deg']:.1f} deg from '{frame.name}'; "
                  f"residuals {', '.join(f'{r:.1f}' for r in f['residuals_deg'])} deg (mean {f['mean_residual_deg']:.2f}); "
                  f"angles between surfaces off by {f['pairwise_mean_deg']:.2f} deg on average (frame-free)")
        print(f"wrote {', '.join(str(p) for p in paths.values())}")
    return 0


def _refit_frame(planes, truth, frame, truth_path):
    """Planes and truth re-expressed in the frame fitted from the truth itself (see framefit)."""
    from dataclasses import replace

    from .framefit import fit_frame_to_truth, fitted_frame, pairwise_angle_error
    from .io.truth import read_truth
    from .orientation import orientation_from_normals

    order = np.argsort(-planes.n_points, kind="stable")
    fit = fit_frame_to_truth(planes.normals[order], truth.normals, candidates=30)
    fit.matched = order[fit.matched]
    new = fitted_frame(frame, fit)
    o = orientation_from_normals(planes.normals, new)
    planes = replace(planes, strike=o.strike, dip=o.dip, dip_direction=o.dip_direction)
    truth = read_truth(truth_path, new)
    pairwise = pairwise_angle_error(planes.normals[fit.matched], truth.normals)
    record = {"rotation_deg": fit.rotation_angle, "residuals_deg": fit.residuals.tolist(),
              "mean_residual_deg": fit.mean_residual, "matched_regions": fit.matched.tolist(),
              "pairwise_mean_deg": float(pairwise.mean()), "pairwise_max_deg": float(pairwise.max()),
              "frame_rotation": [list(r) for r in new.rotation]}
    return planes, truth, {"frame_fit": record}


def run_demo(args) -> int:
    from .evaluate import match_scene
    from .io.writers import write_evaluation
    from .synthetic import observatory_scene

    frame = frame_from(args)
    scene = observatory_scene(args.points, seed=args.seed)
    params, auto = params_from(args, scene.cloud)
    with StageProgress(enabled=not args.quiet) as progress:
        result = measure(scene.cloud, params, frame, progress)
        paths = write_outputs(result, args.outdir, extra={"auto": auto, "demo": {"points": args.points, "seed": args.seed}})
    match = match_scene(result, scene)
    paths.update(write_evaluation(match, args.outdir, {"truth": "the scene's exact surfaces"}))
    if not args.quiet:
        print_planes(result)
        print_match(match)
        print(f"wrote {', '.join(str(p) for p in paths.values())}")
    if args.report:
        run_report(argparse.Namespace(outdir=args.outdir, quiet=args.quiet, max_points=None))
    return 0 if match.all_found else 1


def run_report(args) -> int:
    from .evaluate import PlaneSet
    from .report.html import build_report
    from .report.stereonet import rose_figure, save, stereonet_figure

    if args.max_points is not None and args.max_points < 1:
        raise GeoStructureError(f"--max-points must be at least 1, not {args.max_points}.")
    planes = PlaneSet.from_csv(args.outdir / "planes.csv")
    paths = [build_report(args.outdir, max_points=args.max_points)]
    paths += save(stereonet_figure(planes.strike, planes.dip)[0], args.outdir / "stereonet")
    paths += save(rose_figure(planes.strike)[0], args.outdir / "rose", formats=("png",))
    if not args.quiet:
        print(f"wrote {', '.join(str(p) for p in paths)}")
    return 0


def run_sweep(args) -> int:
    from .evaluate import scene_truth
    from .io.truth import read_truth
    from .io.writers import prepare_outdir, write_json, write_table_csv
    from .sweep import FACTORS, plot_sweep, rows_as_dicts
    from .sweep import run_sweep as sweep

    frame = frame_from(args)
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
    factors = FACTORS if args.factor == "all" else (args.factor,)
    if args.factor == "all" and any(v is not None for v in (args.start, args.end, args.step)):
        raise GeoStructureError("--start, --end and --step need a single --factor.")
    ranges = {args.factor: (args.start, args.end, args.step)} if args.factor != "all" else {}
    outdir = prepare_outdir(args.outdir)
    t = time.perf_counter()
    with StageProgress(enabled=not args.quiet) as progress:
        rows = sweep(cloud, truth, frame, factors, base, ranges=ranges, workers=args.workers, progress=progress)
    write_table_csv(rows_as_dicts(rows), outdir / "sweep.csv")
    figures = plot_sweep(rows, outdir / f"sweep_{args.factor}")
    write_json({"input": "demo" if args.demo else str(args.input), "base_params": base.to_dict(),
                "seconds": round(time.perf_counter() - t, 2), "runs": rows_as_dicts(rows)}, outdir / "sweep.json")
    if not args.quiet:
        print_sweep(rows)
        print(f"{len(rows)} runs in {time.perf_counter() - t:.0f} s; wrote {outdir / 'sweep.csv'}, "
              f"{', '.join(str(p) for p in figures)}")
    return 0
