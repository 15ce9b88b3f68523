"""Benchmark: a survey larger than memory, streamed from tiled LAZ files.

For each size, writes a synthetic quarry (benches: faces dipping 70 degrees and level
berms, 1 cm noise, at a UTM offset) as LAZ tiles of at most 5M points, one tile at a time
so the benchmark itself never holds the survey (not timed, not committed), then runs
``geostructure measure TILES/ -o OUT -q --engine stream --max-memory 8G`` in a process of
its own: streamed, with the automatic parameters and every output (regions.ply and
regions.laz of all the points included). Prints seconds, points per
second, the peak resident memory of the process, and the faces and berms found.

    python bench/bench_stream.py                            # 10M, 50M and 200M points
    python bench/bench_stream.py --sizes 10000000           # one size

``--engine stream --max-memory 8G`` are the options given: without them a cloud that fits
in half the machine's memory runs in memory, with the facet detector.
"""

from __future__ import annotations

import argparse
import csv
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

UTM = np.array([500_000.0, 4_600_000.0, 300.0])
TILE_POINTS = 5_000_000
#: The quarry: benches along x, each a face 10 m high dipping 70 degrees towards -y and a
#: berm 6 m deep; tiles follow x.
BENCH_HEIGHT, BERM, FACE_DIP = 10.0, 6.0, 70.0
BENCHES = 4
LENGTH_PER_TILE = 40.0


def quarry_tile(index: int, n: int, seed: int = 0) -> np.ndarray:
    """``n`` points of tile ``index`` (x from 40 index to 40 (index + 1) metres)."""
    rng = np.random.default_rng([seed, index])
    run = BENCH_HEIGHT / np.tan(np.radians(FACE_DIP))
    step = run + BERM
    which = rng.integers(0, BENCHES, n)
    on_face = rng.random(n) < (np.hypot(run, BENCH_HEIGHT) / (np.hypot(run, BENCH_HEIGHT) + BERM))
    x = LENGTH_PER_TILE * (index + rng.random(n))
    t = rng.random(n)
    y = which * step + np.where(on_face, t * run, run + t * BERM)
    z = which * BENCH_HEIGHT + np.where(on_face, t * BENCH_HEIGHT, BENCH_HEIGHT)
    points = np.column_stack([x, y, z])
    normal = np.where(on_face[:, None], [0.0, -np.sin(np.radians(FACE_DIP)), np.cos(np.radians(FACE_DIP))], [0, 0, 1.0])
    return points + 0.01 * rng.standard_normal(n)[:, None] * normal + UTM


def write_tiles(folder: Path, n_points: int, seed: int = 0) -> list[Path]:
    import laspy

    folder.mkdir(parents=True, exist_ok=True)
    counts = [TILE_POINTS] * (n_points // TILE_POINTS) + ([n_points % TILE_POINTS] if n_points % TILE_POINTS else [])
    paths = []
    for i, count in enumerate(counts):
        header = laspy.LasHeader(point_format=6, version="1.4")
        header.scales, header.offsets = [0.001] * 3, UTM.tolist()
        las = laspy.LasData(header)
        points = quarry_tile(i, count, seed)
        las.x, las.y, las.z = points.T
        paths.append(folder / f"quarry_{i:03d}.laz")
        las.write(str(paths[-1]))
    return paths


def surfaces_found(out: Path) -> tuple[int, int]:
    """Planes whose normal is within 2 degrees of the faces' and of the berms'."""
    with open(out / "planes.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    normals = np.array([[float(r[f"normal_{a}"]) for a in "xyz"] for r in rows]).reshape(-1, 3)
    face = np.array([0.0, -np.sin(np.radians(FACE_DIP)), np.cos(np.radians(FACE_DIP))])
    near = lambda n: int((np.degrees(np.arccos(np.clip(np.abs(normals @ n), 0, 1))) < 2).sum())  # noqa: E731
    return near(face), near(np.array([0, 0, 1.0]))


def timed(command: list[str]) -> dict:
    """Wall seconds and peak resident memory of ``command``, run in a fresh interpreter
    whose only child it is."""
    probe = (
        "import resource, subprocess, sys, time; t = time.perf_counter(); "
        "code = subprocess.call(sys.argv[1:], stdout=subprocess.DEVNULL); "
        "print(code, time.perf_counter() - t, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)"
    )
    done = subprocess.run([sys.executable, "-c", probe, *command], capture_output=True, text=True)
    code, seconds, peak_kib = done.stdout.split()
    if int(code) != 0:
        return {"error": (done.stderr.strip().splitlines() or ["failed"])[-1]}
    return {"seconds": float(seconds), "peak_mib": int(peak_kib) / 1024}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[10_000_000, 50_000_000, 200_000_000])
    parser.add_argument("--max-memory", default="8G")
    parser.add_argument("--dir", type=Path, help="where the tiles go (default: a temporary folder)")
    args = parser.parse_args()
    print(
        f"{os.cpu_count()} cores; a synthetic quarry in LAZ tiles of {TILE_POINTS:,} points; "
        f"geostructure measure TILES -o OUT -q --engine stream --max-memory {args.max_memory}, in its own process"
    )
    base = Path(tempfile.mkdtemp(dir=args.dir))
    try:
        for n in args.sizes:
            t = time.perf_counter()
            tiles = write_tiles(base / f"tiles_{n}", n)
            made = time.perf_counter() - t
            out = base / f"out_{n}"
            row = timed(
                [
                    sys.executable,
                    "-m",
                    "geostructure",
                    "measure",
                    str(tiles[0].parent),
                    "-o",
                    str(out),
                    "-q",
                    "--engine",
                    "stream",
                    "--max-memory",
                    args.max_memory,
                ]
            )
            if "error" in row:
                print(f"{n:>12,} points: {row['error']}")
            else:
                faces, berms = surfaces_found(out)
                print(
                    f"{n:>12,} points in {len(tiles)} tiles: {row['seconds']:8.1f} s "
                    f"({n / row['seconds']:,.0f} points/s), peak {row['peak_mib']:,.0f} MiB; "
                    f"{faces} face and {berms} berm planes (tiles written in {made:.0f} s, not timed)"
                )
            shutil.rmtree(base / f"tiles_{n}", ignore_errors=True)
            shutil.rmtree(out, ignore_errors=True)
    finally:
        shutil.rmtree(base, ignore_errors=True)


if __name__ == "__main__":
    main()
