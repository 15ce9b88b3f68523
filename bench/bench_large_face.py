"""Benchmark: the facet detector at full resolution on a face larger than memory, in tiles with
halos (issue 46), against the in-memory detector on a crop and against the thinned path.

Writes a synthetic outcrop at 1 cm (panels of ``outcrop_scene``, 20 x 8 m each, three joint
sets with rough, undulating facets, side by side along the strike) as LAZ files of one panel
each, one panel at a time (not timed), then times, each in a process of its own, from the
files to the facets:

- **tiled**: the files spilled and the facet detector run in tiles with halos
  (:func:`geostructure.stream.tiledfacets.detect_facets_spilled`), every point;
- **memory**: the in-memory detector (:func:`geostructure.detect.facets.detect_facets`) on
  one panel, the named peer: the same method on a crop that fits;
- **thinned**: the survey spilled and thinned to ``--thinned-points`` (the path ``measure
  --sets`` takes today on a survey that does not fit), then the in-memory detector.

Prints seconds, points per second, the peak resident memory of the process, and the facets
of at least 0.3 x 0.3 m found per square metre of face (a facet's area: its points times the
cloud's spacing squared). Step 5 of docs/tiles.md (sets and kinematics from the joined
facets) will time ``measure --sets --kinematics`` instead.

    python bench/bench_large_face.py                       # 10M, 50M and 100M points
    python bench/bench_large_face.py --sizes 10000000      # one size
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from common import compile_package, the_commands_memory_settings  # noqa: E402

PANEL_WIDTH, PANEL_HEIGHT, SPACING = 20.0, 8.0, 0.01
#: A facet counted as found: at least this area (m^2), a square 0.3 m on a side.
MIN_FACET_AREA = 0.09


def write_panels(folder: Path, n_points: int) -> list[Path]:
    """Panels of the synthetic outcrop side by side along x until ``n_points``, one LAZ each."""
    from geostructure.io.laz import write_laz
    from geostructure.synthetic import outcrop_scene

    folder.mkdir(parents=True, exist_ok=True)
    paths, total, index = [], 0, 0
    while total < n_points:
        cloud = outcrop_scene(width=PANEL_WIDTH, height=PANEL_HEIGHT, point_spacing=SPACING, seed=index).cloud
        points = cloud.points + [index * (PANEL_WIDTH + 0.5), 0.0, 0.0]
        points = points[: n_points - total]
        paths.append(folder / f"panel_{index:03d}.laz")
        write_laz(paths[-1], points, {}, offset=cloud.offset)
        total, index = total + len(points), index + 1
    return paths


def large_facets(count: np.ndarray, spacing: float) -> int:
    """Facets whose area (points x spacing^2) is at least :data:`MIN_FACET_AREA`."""
    return int((np.asarray(count) * spacing**2 >= MIN_FACET_AREA).sum())


def run_one(method: str, paths: list[str], thinned_points: int, tile_points: int) -> dict:
    """One method, in this process: what it found."""
    from geostructure.detect.facets import detect_facets
    from geostructure.stream import spill_inputs

    spill = spill_inputs(paths, 2_000_000)
    try:
        if method == "tiled":
            from geostructure.stream.tiledfacets import detect_facets_spilled

            found = detect_facets_spilled(spill, 2_000_000, tile_points=tile_points)
            labels = found.labels()
            count = np.bincount(labels[labels >= 0], minlength=found.n_facets)
            spacing, extra = found.thresholds.spacing, {"tiles": found.n_tiles, "tile_cells": found.tile_cells}
        else:
            if method == "thinned":
                from geostructure.stream.thin import thin_spill

                points = thin_spill(spill, thinned_points, 2_000_000).points - spill.offset
            else:
                points = np.fromfile(spill.points_path).reshape(-1, 3) - spill.offset
            found = detect_facets(points)
            count = np.bincount(found.labels[found.labels >= 0])
            spacing, extra = found.thresholds.spacing, {}
        area = spill.n_points * spacing**2 if method != "thinned" else len(points) * spacing**2
        return {"points": spill.n_points, "facets": int(len(count)), "large": large_facets(count, spacing),
                "area": area, "spacing": spacing, **extra}  # fmt: skip
    finally:
        spill.close()


def timed(arguments: list[str]) -> dict:
    """Seconds, peak resident memory and the result of one method in a fresh interpreter."""
    probe = (
        "import resource, subprocess, sys, time; t = time.perf_counter(); "
        "done = subprocess.run(sys.argv[1:], capture_output=True, text=True); "
        "print(done.returncode, time.perf_counter() - t, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss); "
        "print(done.stdout.strip().splitlines()[-1] if done.stdout.strip() else done.stderr.strip()[-300:])"
    )
    done = subprocess.run([sys.executable, "-c", probe, sys.executable, __file__, *arguments], capture_output=True,
                          text=True)  # fmt: skip
    first, last = done.stdout.strip().split("\n", 1)
    code, seconds, peak_kib = first.split()
    if int(code) != 0:
        return {"error": last}
    return {"seconds": float(seconds), "peak_mib": int(peak_kib) / 1024, **json.loads(last)}


def describe(name: str, row: dict) -> str:
    if "error" in row:
        return f"  {name:<8} {row['error']}"
    per_m2 = row["large"] / row["area"]
    return (
        f"  {name:<8} {row['points']:>12,} points {row['seconds']:8.1f} s ({row['points'] / row['seconds']:>10,.0f}"
        f" points/s), peak {row['peak_mib']:>7,.0f} MiB; {row['facets']:,} facets, {row['large']:,} of 0.3 m or more "
        f"({per_m2:.2f} per m^2)" + (f"; {row['tiles']} tiles of {row['tile_cells']} cells" if "tiles" in row else "")
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[10_000_000, 50_000_000, 100_000_000])
    parser.add_argument("--thinned-points", type=int, default=8_000_000, help="what the thinned path keeps")
    parser.add_argument("--tile-points", type=int, default=4_000_000, help="points a tile's core holds, about")
    parser.add_argument("--dir", type=Path, help="where the files go (default: a temporary folder)")
    parser.add_argument("--run", nargs="+", help=argparse.SUPPRESS)  # one method, in the timed process
    args = parser.parse_args()
    if args.run:
        print(json.dumps(run_one(args.run[0], args.run[1:], args.thinned_points, args.tile_points)))
        return
    the_commands_memory_settings()
    compile_package()
    print(f"a synthetic outcrop at {SPACING * 100:.0f} cm in LAZ panels of {PANEL_WIDTH:.0f} x {PANEL_HEIGHT:.0f} m;"
          f" tiles of about {args.tile_points:,} points, the thinned path to {args.thinned_points:,}")  # fmt: skip
    base = Path(tempfile.mkdtemp(dir=args.dir))
    try:
        for n in args.sizes:
            t = time.perf_counter()
            paths = [str(p) for p in write_panels(base / f"panels_{n}", n)]
            print(f"{n:,} points in {len(paths)} panels (written in {time.perf_counter() - t:.0f} s, not timed)")
            options = ["--tile-points", str(args.tile_points), "--thinned-points", str(args.thinned_points)]
            rows = {"tiled": timed([*options, "--run", "tiled", *paths])}
            rows["memory"] = timed([*options, "--run", "memory", paths[0]])
            if n > args.thinned_points:
                rows["thinned"] = timed([*options, "--run", "thinned", *paths])
            for name, row in rows.items():
                print(describe(name, row))
            if "error" not in rows["tiled"] and "error" not in rows["memory"]:
                ratio = rows["tiled"]["points"] / rows["tiled"]["seconds"] / (
                    rows["memory"]["points"] / rows["memory"]["seconds"])  # fmt: skip
                print(f"  tiled / memory, points per second: {ratio:.2f}")
            shutil.rmtree(base / f"panels_{n}", ignore_errors=True)
    finally:
        shutil.rmtree(base, ignore_errors=True)


if __name__ == "__main__":
    main()
