"""Benchmark: ``measure --sets --kinematics`` on a face larger than memory, its facets found
on every point in tiles with halos (issue 46), against the in-memory run on a crop and
against the thinned path (``--thin``).

Writes a synthetic outcrop at 1 cm (panels of ``outcrop_scene``, 20 x 8 m each, three joint
sets with rough, undulating facets, side by side along the strike) as LAZ files of one panel
each, one panel at a time (not timed), then times, each in a process of its own, from the
files to the folder written, with the default options:

- **tiles**: ``geostructure measure PANELS -o OUT -q --sets --kinematics --friction 30
  --engine stream --max-memory 8G``: the facets on every point, the rest on the survey
  thinned to what fits;
- **dask** (with ``--methods``): the same as **tiles** with ``--engine dask --workers 2``, a
  local cluster of two worker processes; its peak memory is that of all its processes
  summed (sampled every 0.25 s), the others' that of the one process;
- **thin**: the same with ``--thin``: everything on the thinned survey (the path before);
- **memory**: ``geostructure measure PANELS... -o OUT -q --sets --kinematics --friction 30
  --engine memory`` on the first eight panels (11M points), the named peer: the same command
  on a crop that fits in memory.

Prints seconds, points per second, the peak resident memory of the process, the planes of
at least 0.3 x 0.3 m (``area_m2`` of 0.09 or more) per square metre of face (its panels'
area), the same on the crop's panels alone (the panels differ, so this is the comparison
with the in-memory crop, like for like), and the joint sets found.

    python bench/bench_large_face.py                       # 10M, 50M and 100M points
    python bench/bench_large_face.py --sizes 10000000      # one size
    python bench/bench_large_face.py --keep-panels /data   # panels kept, used again next time
    python bench/bench_large_face.py --methods tiles dask  # streamed against Dask
    python bench/bench_large_face.py --facet-size 0.3      # finer joints, that thinning loses
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import laspy
import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from common import compile_package, the_commands_memory_settings  # noqa: E402

PANEL_WIDTH, PANEL_HEIGHT, SPACING = 20.0, 8.0, 0.01
#: A plane counted as found: at least this area (m^2), a square 0.3 m on a side.
MIN_FACET_AREA = 0.09
#: The crop measured in memory: the first panels, 11M points (a peak under 3 GiB with
#: --sets --kinematics).
CROP_PANELS = 8


def write_panels(folder: Path, n_points: int, facet_size: float = 0.5) -> list[Path]:
    """Whole panels of the synthetic outcrop side by side along x, one LAZ each, until they
    hold ``n_points`` or more; its facets drawn about ``facet_size`` (m) across."""
    from geostructure.io.laz import write_laz
    from geostructure.synthetic import outcrop_scene

    folder.mkdir(parents=True, exist_ok=True)
    paths, total, index = [], 0, 0
    while total < n_points:
        paths.append(folder / f"panel_{index:03d}.laz")
        if paths[-1].exists():  # kept from a run before (--keep-panels)
            with laspy.open(paths[-1]) as reader:
                total, index = total + reader.header.point_count, index + 1
            continue
        cloud = outcrop_scene(
            width=PANEL_WIDTH, height=PANEL_HEIGHT, point_spacing=SPACING, facet_size=facet_size, seed=index
        ).cloud
        write_laz(paths[-1], cloud.points + [index * (PANEL_WIDTH + 0.5), 0.0, 0.0], {}, offset=cloud.offset)
        total, index = total + len(cloud.points), index + 1
    return paths


def command(method: str, paths: list[str], out: Path, max_memory: str) -> list[str]:
    base = [sys.executable, "-m", "geostructure", "measure"]
    options = ["-o", str(out), "-q", "--sets", "--kinematics", "--friction", "30"]
    if method == "memory":
        return [*base, *paths[:CROP_PANELS], *options, "--engine", "memory"]
    engine = ["dask", "--workers", "2"] if method == "dask" else ["stream"]
    streamed = ["--engine", *engine, "--max-memory", max_memory] + (["--thin"] if method == "thin" else [])
    return [*base, str(Path(paths[0]).parent), *options, *streamed]


def on_panel(x: np.ndarray, index: int) -> np.ndarray:
    """Which of the x coordinates lie on panel ``index`` (with half its gap either side)."""
    shift = index * (PANEL_WIDTH + 0.5)
    return (x >= shift - 0.25) & (x < shift + PANEL_WIDTH + 0.25)


def found(out: Path, crop_panels: int, facet_size: float) -> dict:
    """What a folder holds: points measured, large planes (on the whole face and on the
    crop's panels), the crop's facets of 0.3 m or more found, sets and the tiles' record."""
    with open(out / "planes.csv", newline="") as fh:
        rows = [[float(row[k]) for k in PLANE_COLUMNS] for row in csv.DictReader(fh)]
    table = np.array(rows).reshape(-1, len(PLANE_COLUMNS))
    area, x = table[:, 0], table[:, 1]
    with open(out / "sets.csv", newline="") as fh:
        sets = sum(1 for _ in csv.DictReader(fh))
    record = json.loads((out / "run.json").read_text())
    thinned = record.get("thinned") or {}
    full = (record.get("detection") or {}).get("full_resolution") or {}
    points = thinned.get("survey_points") or record["counts"]["input"]
    large = area >= MIN_FACET_AREA
    in_crop = int((large & np.any([on_panel(x, i) for i in range(crop_panels)], axis=0)).sum())
    return {"points": points, "planes": len(area), "large": int(large.sum()), "in_crop": in_crop, "sets": sets,
            "thinned": thinned.get("points"), "tiles": full.get("tiles"),
            "recall": crop_recall(table, crop_panels, facet_size)}  # fmt: skip


#: planes.csv's columns read: the area, the centroid, the normal and the fit's RMS.
PLANE_COLUMNS = (
    "area_m2",
    "centroid_x",
    "centroid_y",
    "centroid_z",
    "normal_x",
    "normal_y",
    "normal_z",
    "fit_residual",
)


def crop_recall(table: np.ndarray, crop_panels: int, facet_size: float) -> float:
    """The share of the crop's panels' facets of 0.3 m or more that the planes found (their
    centroid on the facet, their normal within 5 degrees:
    :func:`~geostructure.evaluation.groundtruth.match_facets`), each panel's scene drawn
    again from its seed (not timed)."""
    from geostructure.core.planes import Planes
    from geostructure.evaluation.groundtruth import match_facets
    from geostructure.synthetic import outcrop_scene

    found = eligible = 0
    for index in range(crop_panels):
        on = on_panel(table[:, 1], index)
        scene = outcrop_scene(
            width=PANEL_WIDTH, height=PANEL_HEIGHT, point_spacing=SPACING, facet_size=facet_size, seed=index
        )
        centroid = table[on, 1:4] - [index * (PANEL_WIDTH + 0.5), 0.0, 0.0]
        match = match_facets(Planes(normal=table[on, 4:7], local_centroid=centroid, fit_residual=table[on, 7]), scene)
        found, eligible = found + int(match.found[match.eligible].sum()), eligible + int(match.eligible.sum())
    return found / max(eligible, 1)


def timed(arguments: list[str], tree: bool = False) -> dict:
    """Wall seconds and peak resident memory of a command in a process of its own; with
    ``tree``, the peak of its processes' memory summed (a Dask cluster's workers too),
    sampled every quarter second."""
    if tree:
        import psutil

        t = time.perf_counter()
        process = subprocess.Popen(arguments, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        root, peak = psutil.Process(process.pid), 0
        while process.poll() is None:
            try:
                peak = max(peak, sum(p.memory_info().rss for p in [root, *root.children(recursive=True)]))
            except psutil.Error:  # a process ended while sampled
                pass
            time.sleep(0.25)
        seconds, err = time.perf_counter() - t, process.stderr.read()
        if process.returncode != 0:
            return {"error": err.strip()[-300:]}
        return {"seconds": seconds, "peak_mib": peak / 2**20}
    probe = (
        "import resource, subprocess, sys, time; t = time.perf_counter(); "
        "done = subprocess.run(sys.argv[1:], capture_output=True, text=True); "
        "print(done.returncode, time.perf_counter() - t, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss); "
        "print(done.stderr.strip()[-300:])"
    )
    done = subprocess.run([sys.executable, "-c", probe, *arguments], capture_output=True, text=True)
    first, _, last = done.stdout.strip().partition("\n")
    code, seconds, peak_kib = first.split()
    if int(code) != 0:
        return {"error": last}
    return {"seconds": float(seconds), "peak_mib": int(peak_kib) / 1024}


def describe(name: str, row: dict) -> str:
    if "error" in row:
        return f"  {name:<7} {row['error']}"
    per_m2 = row["large"] / (row["panels"] * PANEL_WIDTH * PANEL_HEIGHT)
    crop_m2 = row["in_crop"] / (row["crop_panels"] * PANEL_WIDTH * PANEL_HEIGHT)
    thinned = f"; thinned to {row['thinned']:,}" if row.get("thinned") else ""
    tiles = f", facets in {row['tiles']} tiles" if row.get("tiles") else ""
    return (
        f"  {name:<7} {row['points']:>12,} points {row['seconds']:8.1f} s ({row['points'] / row['seconds']:>9,.0f}"
        f" points/s), peak {row['peak_mib']:>7,.0f} MiB; {row['planes']:,} planes, {row['large']:,} of 0.3 m or "
        f"more ({per_m2:.2f} per m^2; {crop_m2:.2f} on the crop's panels), the crop's facets of 0.3 m or more "
        f"found: {row['recall']:.3f}, {row['sets']} sets{thinned}{tiles}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[10_000_000, 50_000_000, 100_000_000])
    parser.add_argument("--max-memory", default="8G")
    parser.add_argument(
        "--facet-size", type=float, default=0.5,
        help="the facets' median diameter (m); 0.3 makes joints that thinning loses (default 0.5)",
    )  # fmt: skip
    parser.add_argument("--dir", type=Path, help="where the files go (default: a temporary folder)")
    parser.add_argument(
        "--keep-panels", type=Path, metavar="FOLDER",
        help="write the panels under FOLDER and keep them; panels already there are used again",
    )  # fmt: skip
    parser.add_argument(
        "--methods", nargs="+", default=["tiles", "thin", "memory"], choices=["tiles", "dask", "thin", "memory"]
    )
    args = parser.parse_args()
    the_commands_memory_settings()
    compile_package()
    print(f"{os.cpu_count()} cores; a synthetic outcrop at {SPACING * 100:.0f} cm in LAZ panels of "
          f"{PANEL_WIDTH:.0f} x {PANEL_HEIGHT:.0f} m, facets of {args.facet_size:g} m; measure --sets --kinematics, --max-memory {args.max_memory}")  # fmt: skip
    base = Path(tempfile.mkdtemp(dir=args.dir))
    try:
        for n in args.sizes:
            t = time.perf_counter()
            size = "" if args.facet_size == 0.5 else f"_facets_{args.facet_size:g}"  # kept panels of one face
            panels = (args.keep_panels or base) / f"panels_{n}{size}"
            paths = [str(p) for p in write_panels(panels, n, args.facet_size)]
            print(f"{len(paths)} panels for {n:,} points (written in {time.perf_counter() - t:.0f} s, not timed)")
            rows, crop_panels = {}, min(CROP_PANELS, len(paths))
            for method in args.methods:
                out = base / f"out_{method}"
                rows[method] = timed(command(method, paths, out, args.max_memory), tree=method == "dask")
                if "error" not in rows[method]:
                    rows[method].update(
                        found(out, crop_panels, args.facet_size),
                        panels=crop_panels if method == "memory" else len(paths),
                        crop_panels=crop_panels,
                    )
                shutil.rmtree(out, ignore_errors=True)
                print(describe(method, rows[method]), flush=True)
            if "error" not in rows.get("tiles", {"error": 1}) and "error" not in rows.get("memory", {"error": 1}):
                ratio = (rows["tiles"]["points"] / rows["tiles"]["seconds"]) / (
                    rows["memory"]["points"] / rows["memory"]["seconds"])  # fmt: skip
                print(f"  tiles / memory, points per second: {ratio:.2f}")
            if not args.keep_panels:
                shutil.rmtree(panels, ignore_errors=True)
    finally:
        shutil.rmtree(base, ignore_errors=True)


if __name__ == "__main__":
    main()
