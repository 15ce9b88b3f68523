"""Benchmark: GeoStructure from the file, with its default options, against Open3D and a
bare numpy pass over the same file, on the synthetic observatory scene.

For each size, writes the scene as a binary PLY of doubles (not timed), then runs, each in
a process of its own so that the seconds and peak memory are its own:

- ``geostructure measure FILE -o OUT`` as a user runs it: reading, the automatic
  parameters, every stage and every output file;
- Open3D (the peer): ``read_point_cloud``, ``estimate_normals`` (kNN 30) and
  ``detect_planar_patches`` (its defaults), from its import to its planes;
- the floor: a bare numpy pass (memory-mapped read, voxel keys by sort, additive moments
  by ``bincount``, one batched ``eigh``): what any voxel fit must at least spend.

It prints seconds, points per second, peak memory, the observatory's six surfaces found
and their mean normal error, and the ratios Open3D / GeoStructure and GeoStructure / floor.
Every process runs with the memory settings the ``geostructure`` command chooses for itself:
numpy's small pages (``NUMPY_MADVISE_HUGEPAGE=0``) and glibc's malloc reusing freed memory
(``common.the_commands_memory_settings``), so that the floor is measured as it runs.

    python bench/bench_pipeline.py                          # 0.3M and 8M points
    python bench/bench_pipeline.py --sizes 300000           # one size

Open3D is an optional extra (``pip install -e .[open3d]``) and needs Debian's libusb-1.0-0,
libgl1 and libgomp1; without it the peer's row says so.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from common import compile_package, the_commands_memory_settings, write_ply

#: The floor's voxel edge, as a share of the cloud's extent (the paper's zeta).
FLOOR_ZETA = 0.01


def timed(command: list[str], timeout: float) -> dict:
    """Run ``command``; its wall seconds and the peak resident memory of its process."""
    t = time.perf_counter()
    process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        _, stderr = process.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        process.kill()
        process.communicate()
        return {"error": f"did not finish in {timeout:.0f} s"}
    seconds = time.perf_counter() - t
    # The child has been reaped by communicate(); its rusage is folded into ours.
    peak = _children_peak_mib()
    if process.returncode != 0:
        return {"error": (stderr.decode(errors="replace").strip().splitlines() or ["failed"])[-1]}
    return {"seconds": seconds, "peak_mib": peak}


def _children_peak_mib() -> float:
    import resource

    return resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024


def in_own_process(method: str, path: Path, out: Path, timeout: float) -> dict:
    """Each method in a fresh interpreter whose only child is the method, so the
    children's peak memory is the method's own."""
    command = [sys.executable, __file__, "--time", method, str(path), str(out), str(timeout)]
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        return {"error": (done.stderr.strip().splitlines() or ["failed"])[-1]}
    return json.loads(done.stdout.strip().splitlines()[-1])


def method_command(method: str, path: Path, out: Path) -> list[str]:
    if method == "geostructure":
        return [sys.executable, "-m", "geostructure", "measure", str(path), "-o", str(out), "-q"]
    return [sys.executable, __file__, "--run", method, str(path), str(out)]


def open3d_planes(path: Path, out: Path) -> None:
    import open3d as o3d

    pcd = o3d.io.read_point_cloud(str(path))
    pcd.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(30))
    boxes = pcd.detect_planar_patches(search_param=o3d.geometry.KDTreeSearchParamKNN(30))
    centres = [np.asarray(b.center).tolist() for b in boxes]
    normals = [np.asarray(b.R)[:, int(np.argmin(b.extent))].tolist() for b in boxes]
    out.write_text(json.dumps({"centres": centres, "normals": normals}))


def floor_pass(path: Path, out: Path) -> None:
    """The least a voxel fit of this file costs in numpy."""
    with open(path, "rb") as fh:
        head = fh.read(4096)
    start = head.index(b"end_header\n") + len(b"end_header\n")
    n = int(head.split(b"element vertex ")[1].split()[0])
    points = np.memmap(path, dtype="<f8", mode="r", offset=start, shape=(n, 3))
    local = points - points.mean(axis=0)
    lower = local.min(axis=0)
    edge = FLOOR_ZETA * float((local.max(axis=0) - lower).max())
    key = np.floor((local - lower) / edge).astype(np.int64)
    span = key.max(axis=0) + 1
    codes, inverse = np.unique((key[:, 0] * span[1] + key[:, 1]) * span[2] + key[:, 2], return_inverse=True)
    m = len(codes)
    count = np.bincount(inverse, minlength=m).astype(np.float64)
    mean = np.stack([np.bincount(inverse, local[:, a], m) for a in range(3)], axis=1) / count[:, None]
    cov = np.empty((m, 3, 3))
    for a in range(3):
        for b in range(a, 3):
            cov[:, a, b] = cov[:, b, a] = (
                np.bincount(inverse, local[:, a] * local[:, b], m) / count - mean[:, a] * mean[:, b]
            )
    _, vectors = np.linalg.eigh(cov)
    out.write_text(json.dumps({"voxels": m, "normal_0": vectors[0, :, 0].tolist()}))


def planes_found(method: str, out: Path, truth) -> tuple[int, float | None, int]:
    """Surfaces of the truth found (a plane's centre near the surface's), their mean normal
    error (degrees) and the number of planes reported."""
    from geostructure.core.orientation import angle_between_normals
    from geostructure.evaluation.groundtruth import match_by_location

    if method == "geostructure":
        with open(out / "planes.csv", newline="") as fh:
            rows = list(csv.DictReader(fh))
        centres = np.array([[float(r[f"centroid_{a}"]) for a in "xyz"] for r in rows]).reshape(-1, 3)
        normals = np.array([[float(r[f"normal_{a}"]) for a in "xyz"] for r in rows]).reshape(-1, 3)
    elif method == "open3d":
        data = json.loads(out.read_text())
        centres, normals = np.array(data["centres"]).reshape(-1, 3), np.array(data["normals"]).reshape(-1, 3)
    else:
        return 0, None, 0
    surfaces = truth.surfaces
    matched = match_by_location(
        centres, [s.center for s in surfaces], [0.5 * np.hypot(s.width, s.height) for s in surfaces]
    )
    errors = [float(angle_between_normals(normals[j], s.normal)[0]) for s, j in zip(surfaces, matched) if j >= 0]
    return int((matched >= 0).sum()), (float(np.mean(errors)) if errors else None), len(normals)


def open3d_available() -> bool:
    return subprocess.run([sys.executable, "-c", "import open3d"], capture_output=True).returncode == 0


def format_row(method: str, n: int, row: dict) -> str:
    if "error" in row:
        return f"{method:<13} {n:>10,} points: {row['error']}"
    text = f"{method:<13} {n:>10,} points: {row['seconds']:7.2f} s ({n / row['seconds']:,.0f} points/s), peak {row['peak_mib']:,.0f} MiB"
    if "found" in row:
        text += (
            f", {row['found']}/6 surfaces ({row['planes']} planes), mean error {row['error_deg']:.3f} deg"
            if row["error_deg"] is not None
            else f", {row['found']}/6 surfaces"
        )
    return text


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[300_000, 8_000_000])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--timeout", type=float, default=1200, help="seconds allowed per method and size")
    parser.add_argument("--json", type=Path, help="also write the figures here")
    parser.add_argument("--time", nargs=4, help=argparse.SUPPRESS)
    parser.add_argument("--run", nargs=3, help=argparse.SUPPRESS)
    args = parser.parse_args()
    the_commands_memory_settings()  # for every method's process
    if args.time:
        method, path, out, timeout = args.time
        print(json.dumps(timed(method_command(method, Path(path), Path(out)), float(timeout))))
        return
    if args.run:
        method, path, out = args.run
        {"open3d": open3d_planes, "floor": floor_pass}[method](Path(path), Path(out))
        return

    compile_package()
    from geostructure.synthetic import observatory_scene

    methods = ["geostructure", "floor"] + (["open3d"] if open3d_available() else [])
    print(f"{os.cpu_count()} cores; observatory scene, binary PLY of doubles, each method in its own process")
    if "open3d" not in methods:
        print("open3d is not installed: no peer (pip install -e .[open3d])")
    truth = observatory_scene(1000, seed=args.seed)  # the surfaces only: the geometry does not depend on n
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for n in args.sizes:
            path = Path(tmp) / f"observatory_{n}.ply"
            write_ply(observatory_scene(n, seed=args.seed).cloud.points, path)
            by = {}
            for method in methods:
                out = Path(tmp) / f"{method}_{n}" if method == "geostructure" else Path(tmp) / f"{method}_{n}.json"
                row = in_own_process(method, path, out, args.timeout)
                if "error" not in row and method != "floor":
                    row["found"], row["error_deg"], row["planes"] = planes_found(method, out, truth)
                by[method] = row
                rows.append({"method": method, "points": n, **row})
                print(format_row(method, n, row), flush=True)
            ok = {m: r for m, r in by.items() if "error" not in r}
            if "geostructure" in ok and "open3d" in ok:
                print(
                    f"  -> Open3D / GeoStructure: {ok['open3d']['seconds'] / ok['geostructure']['seconds']:.2f}",
                    flush=True,
                )
            if "geostructure" in ok and "floor" in ok:
                print(
                    f"  -> GeoStructure / floor: {ok['geostructure']['seconds'] / ok['floor']['seconds']:.1f}",
                    flush=True,
                )
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2) + "\n")


if __name__ == "__main__":
    main()
