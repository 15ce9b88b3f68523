"""Benchmark: report.html for a large cloud, against plotting the whole cloud with plotly.

Measures a synthetic observatory scene (5M points by default, fixed parameters), then:

- GeoStructure's ``report.html`` (decimated to 100k points): seconds to build, peak memory,
  file size, and seconds from navigation to the page having drawn every view;
- the peer: ``plotly.io.write_html`` of the whole filtered cloud as one ``scatter3d`` with
  plotly.js embedded (what one would write by hand), timed the same way.

Pages are opened in headless Debian Chromium with software WebGL (no GPU): a worst case;
a desktop browser with a GPU draws faster.

    python bench/bench_report.py                   # 5M points
    python bench/bench_report.py --points 1000000
"""

from __future__ import annotations

import argparse
import json
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def build(kind: str, outdir: str) -> dict:
    """Runs in its own process so that its peak memory is its own."""
    t = time.perf_counter()
    if kind == "geostructure":
        from geostructure.report.html import build_report

        path = build_report(outdir)
    else:
        import numpy as np
        import plotly.graph_objects as go
        from plyfile import PlyData

        v = PlyData.read(str(Path(outdir) / "regions.ply"))["vertex"].data
        p = np.stack([v["x"], v["y"], v["z"]], axis=1)
        p = (p - p.min(axis=0)).astype(np.float32)
        fig = go.Figure(
            go.Scatter3d(
                x=p[:, 0],
                y=p[:, 1],
                z=p[:, 2],
                mode="markers",
                marker=dict(size=1, color=v["region_id"].astype(np.float32)),
            )
        )
        fig.add_trace(go.Scatter3d(x=[], y=[], z=[]))
        path = Path(outdir) / "plotly_full.html"
        fig.write_html(str(path), include_plotlyjs=True, post_script="window.reportReady = true;")
    return {
        "build_s": time.perf_counter() - t,
        "peak_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "path": str(path),
        "mb": Path(path).stat().st_size / 1e6,
    }


OPEN_TIMEOUT = 300


def open_seconds(path: str, timeout: float = OPEN_TIMEOUT) -> float:
    """Seconds from navigation start to window.reportReady, read from the page's own clock."""
    from selenium.common.exceptions import TimeoutException

    from geostructure.testing.browser import start_chromium

    driver, profile = start_chromium()
    driver.set_page_load_timeout(timeout)
    try:
        try:
            driver.get(Path(path).resolve().as_uri())
        except TimeoutException:
            return float("nan")
        end = time.monotonic() + timeout
        while not driver.execute_script("return window.reportReady === true"):
            if time.monotonic() > end:
                return float("nan")
            time.sleep(0.05)
        driver.execute_script("window.readyAt = window.reportTimings ? window.reportTimings.ready : performance.now()")
        return driver.execute_script("return window.readyAt") / 1000
    finally:
        driver.quit()
        shutil.rmtree(profile, ignore_errors=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=5_000_000)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    from geostructure.core.params import Params
    from geostructure.detect.pipeline import measure
    from geostructure.io.writers import write_outputs
    from geostructure.synthetic import observatory_scene

    outdir = tempfile.mkdtemp(prefix="bench-report-")
    t = time.perf_counter()
    result = measure(observatory_scene(args.points, seed=args.seed).cloud, Params())
    write_outputs(result, outdir)
    print(f"{args.points:,} points measured and written in {time.perf_counter() - t:.1f} s: {len(result)} planes")
    rows = {}
    for kind in ("geostructure", "plotly_full"):
        out = subprocess.run(
            [sys.executable, __file__, "--build", kind, outdir], capture_output=True, text=True, check=True
        )
        rows[kind] = json.loads(out.stdout.strip().splitlines()[-1])
        rows[kind]["open_s"] = open_seconds(rows[kind]["path"])
        r = rows[kind]
        drawn = (
            f"drawn {r['open_s']:.1f} s after navigation"
            if r["open_s"] == r["open_s"]
            else f"not drawn within {OPEN_TIMEOUT} s"
        )
        print(
            f"{kind:>13}: {r['mb']:.1f} MB, built in {r['build_s']:.1f} s ({r['peak_mib']:.0f} MiB peak), "
            f"{drawn} (headless Chromium, software WebGL)"
        )
    g, p = rows["geostructure"], rows["plotly_full"]
    opening = (
        f"{p['open_s'] / g['open_s']:.1f}x"
        if p["open_s"] == p["open_s"]
        else f"more than {OPEN_TIMEOUT / g['open_s']:.0f}x"
    )
    print(f"ratio plotly_full / geostructure: size {p['mb'] / g['mb']:.1f}x, opening {opening}")
    shutil.rmtree(outdir, ignore_errors=True)


if __name__ == "__main__":
    if len(sys.argv) == 4 and sys.argv[1] == "--build":
        print(json.dumps(build(sys.argv[2], sys.argv[3])))
    else:
        main()
