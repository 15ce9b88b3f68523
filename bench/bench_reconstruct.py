"""Benchmark: `geostructure run` stage by stage, the two CPU dense paths side by side.

On the rendered outcrop video (exact truth; `testing/render.py`), and on a folder of
photos if given, runs the whole reconstruction once with each CPU dense path:

- ``sgbm``: OpenCV's semi-global block matching on rectified pairs (the peer: the usual
  CPU stereo), and
- ``sweep``: GeoStructure's plane sweep, for cameras that move along their view,

and prints per stage seconds, dense points per second, peak memory and, on the outcrop,
the largest dip / dip-direction error against the truth. Each run is its own process, so
its peak memory is its own; the SfM is redone each time, so its figures repeat.

    python bench/bench_reconstruct.py
    python bench/bench_reconstruct.py --images ../shared/data/sceaux_castle/images
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

METHODS = ("sgbm", "sweep")


def run_once(source: str, outdir: str, method: str, georef: list[str], truth: str | None) -> dict:
    """One `geostructure run` in this process; its record as a dict."""
    from geostructure.cli import main

    argv = ["run", source, "-o", outdir, "--dense", method, "--no-report", "-q", *georef]
    if truth:
        argv += ["--truth", truth]
    t = time.perf_counter()
    status = main(argv)
    record = json.loads((Path(outdir) / "reconstruct.json").read_text())
    row = {
        "status": status,
        "total_s": time.perf_counter() - t,
        "peak_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "frames_s": record.get("frames", {}).get("seconds"),
        "sfm_s": sum(record["sfm"]["seconds"].values()),
        "dense_s": record["dense"]["seconds"],
        "points": record["dense"]["points"],
        "surface_s": record["surface"]["seconds"],
    }
    evaluation = Path(outdir) / "evaluation.csv"
    if evaluation.exists():
        import csv

        rows = list(csv.DictReader(evaluation.open()))
        row["max_error_deg"] = max(float(r["normal_error_deg"]) for r in rows if r["normal_error_deg"])
    return row


def report(name: str, rows: dict) -> None:
    for method, r in rows.items():
        frames = f"frames {r['frames_s']:.1f} s, " if r["frames_s"] else ""
        error = f", largest normal error {r['max_error_deg']:.2f} deg" if "max_error_deg" in r else ""
        print(
            f"{name} [{method:>5}]: {frames}SfM {r['sfm_s']:.1f} s, dense {r['dense_s']:.1f} s "
            f"({r['points']:,} points, {r['points'] / r['dense_s']:,.0f} points/s), surface {r['surface_s']:.1f} s, "
            f"total {r['total_s']:.1f} s, peak {r['peak_mib']:.0f} MiB{error}"
        )
    g, s = rows["sgbm"], rows["sweep"]
    print(
        f"{name}: ratio sweep / sgbm (OpenCV StereoSGBM pairs): dense time {s['dense_s'] / g['dense_s']:.2f}x, "
        f"points {s['points'] / max(g['points'], 1):.2f}x"
    )


def compare(name: str, source: str, georef: list[str], truth: str | None) -> None:
    rows = {}
    for method in METHODS:
        with tempfile.TemporaryDirectory(prefix=f"bench-run-{method}-") as out:
            args = [sys.executable, __file__, "--one", method, source, out, json.dumps(georef), truth or ""]
            done = subprocess.run(args, capture_output=True, text=True)
            if done.returncode:
                print(f"{name} [{method}]: failed: {done.stderr.strip().splitlines()[-1:]}")
                return
            rows[method] = json.loads(done.stdout.strip().splitlines()[-1])
    report(name, rows)


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "--one":
        method, source, out, georef, truth = sys.argv[2:7]
        print(json.dumps(run_once(source, out, method, json.loads(georef), truth or None)))
        return
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--images", help="also a folder of photos (measured with --assume-level)")
    args = parser.parse_args()
    from geostructure.testing.render import write_scene_video

    with tempfile.TemporaryDirectory(prefix="bench-outcrop-") as folder:
        video, gcp, truth = write_scene_video(folder)
        compare("rendered outcrop (36 frames 640x480)", str(video), ["--gcp", str(gcp)], str(truth))
    if args.images:
        compare(Path(args.images).parent.name or args.images, args.images, ["--assume-level"], None)


if __name__ == "__main__":
    main()
