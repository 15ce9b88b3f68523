"""Benchmark: GeoStructure against Open3D on the synthetic observatory scene.

For each size, builds the scene once, then runs each method in its own process (so peak
memory is its own) and prints seconds per stage, points per second, peak memory and mean
normal error on the six surfaces, with the ratio of the two methods.

    python bench/bench_pipeline.py                 # 0.3M and 5M points
    python bench/bench_pipeline.py --sizes 300000  # one size

The peer is Open3D's ``estimate_normals`` (kNN 30) + ``detect_planar_patches`` (its
defaults, kNN 30), the nearest thing in a widely used library to what GeoStructure does.
It needs the ``open3d`` extra (``pip install -e .[open3d]``) and Debian's libusb-1.0-0,
libgl1 and libgomp1; without it only GeoStructure is measured.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np


def worker(method: str, scene_path: str, n_points: int, seed: int) -> dict:
    from geostructure.cloud import Cloud
    from geostructure.evaluate import match_by_location
    from geostructure.orientation import angle_between_normals
    from geostructure.synthetic import observatory_scene

    truth = observatory_scene(1000, seed=seed)  # the surfaces only; geometry does not depend on n
    points = np.load(scene_path)
    rss_before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    t0 = time.perf_counter()
    if method == "geostructure":
        from geostructure.pipeline import measure

        result = measure(Cloud.from_points(points))
        seconds = dict(result.seconds)
        centres, normals = result.centroids, result.normals
    else:
        import open3d as o3d

        cloud = Cloud.from_points(points)
        pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(cloud.local))
        t = time.perf_counter()
        pcd.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(30))
        seconds = {"normals": time.perf_counter() - t}
        t = time.perf_counter()
        boxes = pcd.detect_planar_patches(search_param=o3d.geometry.KDTreeSearchParamKNN(30))
        seconds["patches"] = time.perf_counter() - t
        centres = np.array([np.asarray(b.center) for b in boxes]).reshape(-1, 3) + cloud.offset
        normals = np.array([np.asarray(b.R)[:, int(np.argmin(b.extent))] for b in boxes]).reshape(-1, 3)
    total = time.perf_counter() - t0
    surfaces = truth.surfaces
    matched = match_by_location(
        centres, [s.center for s in surfaces], [0.5 * np.hypot(s.width, s.height) for s in surfaces]
    )
    found = matched >= 0
    errors = [float(angle_between_normals(normals[j], s.normal)[0]) for s, j in zip(surfaces, matched) if j >= 0]
    return {
        "method": method,
        "points": n_points,
        "seconds": {k: round(v, 3) for k, v in seconds.items()},
        "total_s": round(total, 3),
        "points_per_s": round(n_points / total),
        "peak_rss_mib": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1),
        "rss_before_mib": round(rss_before / 1024, 1),
        "planes": int(len(normals)),
        "found": int(found.sum()),
        "mean_error_deg": round(float(np.mean(errors)), 4) if errors else None,
    }


def run_worker(method, scene_path, n, seed, timeout):
    cmd = [sys.executable, __file__, "--worker", method, "--scene", scene_path, "--sizes", str(n), "--seed", str(seed)]
    try:
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"method": method, "points": n, "error": f"did not finish in {timeout} s"}
    if out.returncode != 0:
        last = (out.stderr.strip().splitlines() or ["failed"])[-1]
        return {"method": method, "points": n, "error": last}
    return json.loads(out.stdout.strip().splitlines()[-1])


def open3d_available() -> bool:
    probe = subprocess.run([sys.executable, "-c", "import open3d"], capture_output=True)
    return probe.returncode == 0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[300_000, 5_000_000])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--timeout", type=int, default=900, help="seconds allowed per method and size")
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    parser.add_argument("--scene", help=argparse.SUPPRESS)
    parser.add_argument("--json", type=Path, help="also write the figures here")
    args = parser.parse_args()
    if args.worker:
        print(json.dumps(worker(args.worker, args.scene, args.sizes[0], args.seed)))
        return

    from geostructure.synthetic import observatory_scene

    methods = ["geostructure"] + (["open3d"] if open3d_available() else [])
    if len(methods) == 1:
        print("open3d is not installed: measuring GeoStructure alone (pip install -e .[open3d])")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for n in args.sizes:
            scene_path = str(Path(tmp) / f"scene_{n}.npy")
            np.save(scene_path, observatory_scene(n, seed=args.seed).cloud.points)
            for method in methods:
                row = run_worker(method, scene_path, n, args.seed, args.timeout)
                rows.append(row)
                print(format_row(row), flush=True)
            by = {r["method"]: r for r in rows if r["points"] == n and "error" not in r}
            if len(by) == 2:
                print(
                    f"  -> GeoStructure is {by['open3d']['total_s'] / by['geostructure']['total_s']:.1f}x faster than "
                    f"Open3D at {n:,} points; mean normal error {by['geostructure']['mean_error_deg']} vs "
                    f"{by['open3d']['mean_error_deg']} deg",
                    flush=True,
                )
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2) + "\n")


def format_row(row: dict) -> str:
    if "error" in row:
        return f"{row['method']:<13} {row['points']:>10,} points: {row['error']}"
    stages = ", ".join(f"{k} {v:.2f}" for k, v in row["seconds"].items())
    return (
        f"{row['method']:<13} {row['points']:>10,} points: {row['total_s']:7.2f} s "
        f"({row['points_per_s']:,} points/s), peak {row['peak_rss_mib']:,.0f} MiB, "
        f"{row['found']}/6 surfaces, mean error {row['mean_error_deg']} deg [{stages}]"
    )


if __name__ == "__main__":
    main()
