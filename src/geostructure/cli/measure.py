"""The commands on clouds and output folders: measure, evaluate, report, sweep, demo."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from geostructure.cli.options import (
    MAX_DEMO_POINTS,
    add_measure_options,
    base_params,
    check_before_work,
    check_outdir,
    check_unit_given,
    choice_teller,
    crs_from,
    finite_float,
    folder,
    frame_from,
    given_factors,
    params_from,
    positive_float,
    whole_number,
    workers,
)
from geostructure.cli.progress import StageProgress
from geostructure.cli.rockmass import add_kinematic_options, add_set_options, kinematic_settings, wants_sets
from geostructure.cli.scale_options import add_engine_options
from geostructure.errors import ParameterError
from geostructure.evaluation.groundtruth import scene_truth
from geostructure.evaluation.mapcheck import MAX_ANGLE, MAX_DISTANCE
from geostructure.evaluation.scoring import add_evaluation, add_validation
from geostructure.evaluation.sweep import FACTORS, factor_values
from geostructure.io.readers import DEFAULT_MESH_SAMPLES, MAX_MESH_SAMPLES, read_cloud
from geostructure.io.survey_files import expand_inputs
from geostructure.io.truth import read_truth
from geostructure.report.terminal import (
    frame_fit_line,
    print_evaluation,
    print_match,
    print_planes,
    print_run,
    print_sweep,
    validation_lines,
)
from geostructure.synthetic import observatory_scene
from geostructure.workflows.experiments import run_demo as run_demo_scene
from geostructure.workflows.experiments import sweep_and_save
from geostructure.workflows.saving import add_report
from geostructure.workflows.survey import measure_survey


def add_measure_commands(sub) -> None:
    """The parsers of measure, evaluate, report, sweep and demo."""
    m = sub.add_parser("measure", help="measure the planes of a point cloud file")
    m.add_argument(
        "input",
        type=Path,
        nargs="+",
        help="PLY, LAS, LAZ, E57, XYZ, TXT or CSV file; or several (tiles), a folder of them, or a quoted glob",
    )
    m.add_argument("-o", "--outdir", type=folder, required=True, help="folder for planes.csv, regions.ply, run.json")
    m.add_argument(
        "--mesh-samples",
        type=whole_number(0, MAX_MESH_SAMPLES),
        default=DEFAULT_MESH_SAMPLES,
        help="points sampled on a PLY mesh's faces (0: use the vertices only)",
    )
    m.add_argument("--truth", type=Path, help="ground-truth CSV: also evaluate the planes against it")
    m.add_argument("--report", action="store_true", help="also write report.html, stereonet and rose figures")
    add_set_options(m, "--sets")
    add_kinematic_options(m, flag=True)
    add_measure_options(m)
    add_engine_options(m)
    m.set_defaults(run=run_measure)

    e = sub.add_parser("evaluate", help="score a measured OUTDIR against a ground-truth CSV or a field map")
    e.add_argument("outdir", type=Path, help="a folder written by 'geostructure measure'")
    e.add_argument("--truth", type=Path, help="CSV: surface, strike, dip, dip_direction[, center_*]")
    e.add_argument(
        "--fractures",
        type=Path,
        help="field map CSV: x, y, z, dip, dip_direction[, set] per mapped fracture or compass station "
        "(or DICE's Xcenter, Ycenter, Zcenter, Dip, DipDirection); writes validation.csv",
    )
    e.add_argument("--set-means", type=Path, help="with --fractures: published set means (dip, dip_direction[, set])")
    e.add_argument(
        "--fracture-sets",
        type=Path,
        help="with --fractures: each mapped fracture's set, row for row (a CSV with a set column)",
    )
    e.add_argument(
        "--max-distance",
        type=float,
        default=MAX_DISTANCE,
        help=f"with --fractures: a plane's centroid within this of a mapped centre (default {MAX_DISTANCE})",
    )
    e.add_argument("--max-angle", type=float, default=MAX_ANGLE,
                   help=f"with --fractures: its normal within this many degrees (default {MAX_ANGLE:g})")  # fmt: skip
    e.add_argument(
        "--fit-frame",
        action="store_true",
        help="for an unreferenced cloud: fit the frame from the ground-truth planes, then score",
    )
    e.add_argument("-q", "--quiet", action="store_true", help="no table")
    e.set_defaults(run=run_evaluate)

    r = sub.add_parser("report", help="interactive report.html, stereonet and rose figures of a measured OUTDIR")
    r.add_argument("outdir", type=Path, help="a folder written by 'geostructure measure'")
    r.add_argument(
        "--max-points",
        type=whole_number(1),
        default=None,
        help="points drawn in 3D at most (default 100000; the file grows ~70 bytes a point)",
    )
    r.add_argument("-q", "--quiet", action="store_true")
    r.set_defaults(run=run_report)

    w = sub.add_parser("sweep", help="the paper's experiments: vary one factor, record time and z(R)")
    w.add_argument("input", type=Path, nargs="?", help="cloud file (or --demo for the bundled scene)")
    w.add_argument("--demo", action="store_true", help="sweep the bundled synthetic scene against its exact truth")
    w.add_argument("--truth", type=Path, help="ground-truth CSV (required unless --demo)")
    w.add_argument("-o", "--outdir", type=folder, default=Path("out/sweep"))
    w.add_argument("--factor", choices=("zeta", "theta", "psi", "k", "all"), default="all")
    w.add_argument("--start", type=finite_float)
    w.add_argument("--end", type=finite_float)
    w.add_argument("--step", type=positive_float)
    w.add_argument("--workers", type=workers(), default=2, help="runs in parallel (default %(default)s)")
    w.add_argument(
        "--points", type=whole_number(1000, MAX_DEMO_POINTS), default=300_000, help="points in the --demo scene"
    )
    w.add_argument("--mesh-samples", type=whole_number(0, MAX_MESH_SAMPLES), default=DEFAULT_MESH_SAMPLES)
    add_measure_options(w, auto_default=False)
    w.set_defaults(run=run_sweep)

    d = sub.add_parser("demo", help="measure the bundled synthetic observatory scene")
    d.add_argument("-o", "--outdir", type=folder, default=Path("out/demo"))
    d.add_argument("--points", type=whole_number(1000, MAX_DEMO_POINTS), default=300_000, help="points in the scene")
    d.add_argument("--seed", type=whole_number(0), default=0, help="the scene's random seed, 0 or more")
    d.add_argument(
        "--report",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="also write report.html, stereonet and rose figures (default on)",
    )
    add_measure_options(d)
    d.set_defaults(run=run_demo)


def run_measure(args) -> int:
    frame = frame_from(args)
    crs_from(args)  # refused before any work
    params = base_params(args)
    kinematics = kinematic_settings(args)  # refused before any work
    check_outdir(args.outdir)  # the folder first: it says nothing of the inputs
    paths = expand_inputs(args.input)
    check_before_work(args, [*paths, args.truth])
    check_unit_given(args, paths)
    t = time.perf_counter()
    with StageProgress(enabled=not args.quiet) as progress:
        run = measure_survey(paths, args.outdir, engine=args.engine, max_memory=args.max_memory, thin=args.thin,
                             detector=args.detector,
                             frame=frame, params=params, auto=args.auto, given=given_factors(args),
                             crs=crs_from(args), unit=args.unit, grid_north=args.grid_north, sets=wants_sets(args),
                             n_sets=args.n_sets, kinematics=kinematics, scheduler=args.scheduler,
                             workers=args.workers, spill_dir=args.spill_dir, mesh_samples=args.mesh_samples or None,
                             truth_path=args.truth, report=args.report, inputs=[*paths, args.truth],
                             progress=progress, on_choice=choice_teller(args))  # fmt: skip
    if not args.quiet:
        print_run(run, time.perf_counter() - t, unit=args.unit)
    return 0


def run_evaluate(args) -> int:
    if (args.truth is None) == (args.fractures is None):
        raise ParameterError("evaluate needs --truth TRUTH.csv or --fractures MAP.csv (one of the two).")
    if args.fractures is not None:
        summary, paths = add_validation(args.outdir, args.fractures, set_means=args.set_means,
                                        max_distance=args.max_distance, max_angle=args.max_angle,
                                        fracture_sets=args.fracture_sets)  # fmt: skip
        if not args.quiet:
            print(validation_lines(summary))
            print(f"wrote {', '.join(str(p) for p in paths.values())}")
        return 0
    if args.set_means is not None or args.fracture_sets is not None:
        raise ParameterError("--set-means and --fracture-sets go with --fractures.")
    evaluation, extra, paths = add_evaluation(args.outdir, args.truth, fit_frame=args.fit_frame)
    if not args.quiet:
        print_evaluation(evaluation)
        if extra:
            print(frame_fit_line(extra["frame_fit"]))
        print(f"wrote {', '.join(str(p) for p in paths.values())}")
    return 0


def run_demo(args) -> int:
    frame = frame_from(args)
    params = base_params(args)
    check_outdir(args.outdir)
    crs = crs_from(args)
    check_unit_given(args, [])  # --unit beside a --crs that says another unit means nothing
    if getattr(args, "unit", None) not in (None, "m"):
        raise ParameterError(f"--unit {args.unit}: the demo's scene is built in metres; leave --unit out.")
    with StageProgress(enabled=not args.quiet) as progress:
        run = run_demo_scene(args.outdir, points=args.points, seed=args.seed, frame=frame, params=params,
                             auto=args.auto, given=given_factors(args), crs=crs, report=args.report,
                             progress=progress, on_choice=choice_teller(args))  # fmt: skip
    if not args.quiet:
        print_planes(run.result)
        print_match(run.match)
        print(f"wrote {', '.join(str(p) for p in run.paths.values())}")
    return 0 if run.match.all_found else 1


def run_report(args) -> int:
    paths = add_report(args.outdir, max_points=args.max_points)
    if not args.quiet:
        print(f"wrote {', '.join(str(p) for p in paths.values())}")
    return 0


def run_sweep(args) -> int:
    frame = frame_from(args)
    base_params(args)
    if args.factor == "all" and any(v is not None for v in (args.start, args.end, args.step)):
        raise ParameterError("--start, --end and --step need a single --factor.")
    factors = FACTORS if args.factor == "all" else (args.factor,)
    ranges = {args.factor: (args.start, args.end, args.step)} if args.factor != "all" else {}
    for factor in factors:  # a bad range is refused before the cloud is read
        factor_values(factor, *ranges.get(factor, (None,) * 3))
    check_before_work(args, [args.input, args.truth])
    if args.demo and (args.input is not None or args.truth is not None):  # it swept the demo, the file unread
        raise ParameterError("sweep --demo sweeps the synthetic scene: give INPUT and --truth, or --demo, not both.")
    if args.demo:
        scene = observatory_scene(args.points)
        cloud, truth = scene.cloud, scene_truth(scene, frame)
    else:
        if args.input is None or args.truth is None:
            raise ParameterError("sweep needs INPUT and --truth TRUTH.csv, or --demo.")
        truth = read_truth(args.truth, frame)
        cloud = read_cloud(args.input, mesh_samples=args.mesh_samples or None)
    t = time.perf_counter()
    with StageProgress(enabled=not args.quiet) as progress:
        rows, written = sweep_and_save(cloud, truth, frame, factors, params_from(args, cloud)[0], args.outdir,
                                       ranges=ranges, workers=args.workers, progress=progress, stem=args.factor,
                                       input_name="demo" if args.demo else str(args.input),
                                       inputs=[args.input, args.truth])  # fmt: skip
    if not args.quiet:
        print_sweep(rows)
        print(f"{len(rows)} runs in {time.perf_counter() - t:.0f} s; wrote {', '.join(str(p) for p in written)}")
    return 0
