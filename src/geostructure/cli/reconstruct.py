"""The commands from video or photos: ``frames`` and ``run`` (the whole paper)."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from geostructure.cli.options import (
    add_measure_options,
    base_params,
    check_before_work,
    choice_teller,
    crs_from,
    folder,
    frame_from,
    given_factors,
    non_negative_float,
    positive_float,
    whole_number,
)
from geostructure.cli.progress import StageProgress
from geostructure.reconstruct.dense import DenseOptions
from geostructure.reconstruct.frames import FrameOptions, extract_frames
from geostructure.reconstruct.sfm import SfmOptions
from geostructure.reconstruct.stages import ReconstructOptions
from geostructure.reconstruct.surface import SurfaceOptions
from geostructure.report.terminal import print_run
from geostructure.workflows.video import reconstruct_and_measure, require_reconstruction_extra


def add_reconstruct_commands(sub) -> None:
    defaults = FrameOptions()
    f = sub.add_parser("frames", help="pick the sharp, moving frames of a video for SfM")
    f.add_argument("video", type=Path, help="mp4, avi, mov, mkv ... file")
    f.add_argument("-o", "--outdir", type=folder, required=True, help="folder for frame_NNNNNN.jpg")
    add_frame_options(f, defaults)
    f.add_argument("-q", "--quiet", action="store_true")
    f.set_defaults(run=run_frames)

    r = sub.add_parser("run", help="video or photos -> frames -> SfM -> dense -> surface -> georeference -> planes")
    r.add_argument("source", type=Path, help="a video file or a folder of photos")
    r.add_argument("-o", "--outdir", type=folder, required=True, help="folder for the cloud, planes and report")
    g = r.add_argument_group("reconstruction")
    add_frame_options(g, defaults)
    g.add_argument(
        "--matching",
        choices=("auto", "sequential", "exhaustive"),
        default="auto",
        help="SfM matching: sequential for video, exhaustive for photo sets (auto: by count)",
    )
    g.add_argument(
        "--max-image-size",
        type=whole_number(64, MAX_IMAGE_SIZE),
        default=1600,
        help="SfM features on images this large (px)",
    )
    g.add_argument(
        "--dense",
        choices=("auto", "colmap", "sgbm", "sweep", "none"),
        default="auto",
        help="dense stage: colmap (CUDA PatchMatch), sgbm (CPU, rectified pairs), sweep (CPU plane "
        "sweep, for walks along the view), none (measure sparse points); auto: colmap with CUDA, "
        "else sgbm, or sweep when most images have no sideways partner",
    )
    g.add_argument(
        "--dense-neighbours", type=whole_number(1), default=2, help="stereo partners per image (sgbm, sweep)"
    )
    g.add_argument("--no-mesh", action="store_true", help="skip the Poisson surface: measure the dense cloud directly")
    g.add_argument(
        "--poisson-depth",
        type=whole_number(4, MAX_POISSON_DEPTH),
        default=9,
        help="Poisson octree depth (default %(default)s)",
    )
    e = r.add_argument_group("georeference (one is needed before strike and dip mean anything)")
    e.add_argument(
        "--gcp",
        type=Path,
        help="control points: a CSV of name,E,N,Up with image,u,v (pixels) or x,y,z "
        "(model), or OpenSfM's ground_control_points.json (WGS84)",
    )
    e.add_argument(
        "--scale",
        type=positive_float,
        default=1.0,
        help="manual georeference: metres per model unit, with --up and --north given in model axes",
    )
    e.add_argument(
        "--assume-level",
        action="store_true",
        help="no control, no GPS: take up from the cameras (held without roll) and 'north' along their mean "
        "view; dips approximate, azimuths relative to the view",
    )
    r.add_argument("--truth", type=Path, help="ground-truth CSV: also evaluate the planes against it")
    r.add_argument(
        "--report", action=argparse.BooleanOptionalAction, default=True, help="write report.html (default on)"
    )
    add_measure_options(r)
    r.set_defaults(run=run_run)


def add_frame_options(parser, defaults) -> None:
    parser.add_argument("--fps", type=positive_float, default=None, help="decode rate (default: the video's own)")
    parser.add_argument("--all-frames", action="store_true", help="keep every decoded frame (no sharpness/motion test)")
    parser.add_argument(
        "--min-motion",
        type=non_negative_float,
        default=defaults.min_motion,
        help="keep a frame once the view moved this fraction of the width (default %(default)s)",
    )
    parser.add_argument("--max-frames", type=whole_number(1), default=None, help="stop after this many kept frames")


def frame_options(args):
    return FrameOptions(
        fps=args.fps, select=not args.all_frames, min_motion=args.min_motion, max_frames=args.max_frames
    )


def run_frames(args) -> int:
    require_reconstruction_extra(needs_video=True, needs_mesh=False)
    with StageProgress(enabled=not args.quiet) as progress:
        report = extract_frames(args.video, args.outdir, frame_options(args), progress)
    if not args.quiet:
        print(f"{report.summary()}; wrote {args.outdir}")
    return 0


def run_run(args) -> int:
    frame_from(args)  # refuse a half-given --up/--north before hours of reconstruction
    crs_from(args)
    base_params(args)
    options = ReconstructOptions(
        frames=frame_options(args),
        sfm=SfmOptions(matching=args.matching, max_image_size=args.max_image_size),
        dense=DenseOptions(method="auto" if args.dense == "none" else args.dense, neighbours=args.dense_neighbours),
        surface=SurfaceOptions(depth=args.poisson_depth),
        use_dense=args.dense != "none",
        mesh=not args.no_mesh,
        gcp=str(args.gcp) if args.gcp else None,
        up=args.up,
        north=args.north,
        scale=args.scale,
        assume_level=args.assume_level,
    )
    check_before_work(args, [args.truth, args.gcp])
    t = time.perf_counter()
    log = (lambda line: None) if args.quiet else (lambda line: print(line, flush=True))
    with StageProgress(enabled=not args.quiet) as progress:
        run = reconstruct_and_measure(args.source, args.outdir, options, declination=args.declination,
                                      params=base_params(args), auto=args.auto, given=given_factors(args),
                                      crs=crs_from(args), unit=args.unit, grid_north=args.grid_north,
                                      truth_path=args.truth, report=args.report, inputs=[args.truth, args.gcp],
                                      progress=progress, log=log, on_choice=choice_teller(args))  # fmt: skip
    if not args.quiet:
        print_run(run, time.perf_counter() - t, unit=args.unit)
    return 0


#: The largest image side SfM is asked to read: a 100-megapixel frame is 12,000 px across.
MAX_IMAGE_SIZE = 16_384
#: The deepest Poisson octree: each level multiplies the cells by eight; at 14 a surface
#: already takes tens of GB.
MAX_POISSON_DEPTH = 14
