"""Benchmark: the synthetic outcrop photographed by a drone and rebuilt by ``geostructure run``
(SfM and dense matching), against the same outcrop sampled directly and against the real
Lastoni SW half: how close the synthetic face comes to real SfM rock, and what the default
command finds on each.

1. ``geostructure.testing.outcrop_photos.write_outcrop_photos``: a 6 x 4 m face (seed 0),
   24 photos of 1024 x 768 from two rows 7 m out, ground control at 8 facet centres;
2. ``geostructure run photos -o rebuilt --gcp gcp.csv --no-report`` (the cloud in the
   scene's own coordinates);
3. the rebuilt cloud thinned to one point a 3 cm cell, as the real half was delivered,
   and ``geostructure measure --sets`` on it, on the scene sampled directly at 3 cm (the
   synthetic outcrop as the tests use it), and on the real half.

Prints, for each cloud: points, the grid's scatter (what decides the detector), the
median angle between neighbouring points' planes (30 neighbours), the share of points the
default run puts in a plane, the points per facet or mapped fracture, and the facets
found (synthetic) or fractures matched (real).

    python bench/bench_sfm_outcrop.py [WORKDIR]
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "dice_lastoni_sw"
COMMAND = [sys.executable, "-m", "geostructure"]
THIN = 0.03


def thinned(points: np.ndarray, cell: float) -> np.ndarray:
    """One point a ``cell`` grid cell (the first in file order), as a cloud is subsampled."""
    key = np.floor((points - points.min(axis=0)) / cell).astype(np.int64)
    _, first = np.unique(key, axis=0, return_index=True)
    return points[np.sort(first)]


def neighbour_plane_angle(points: np.ndarray, k: int = 30) -> float:
    """Median angle (degrees) between each point's plane (``k`` neighbours) and its nearest
    neighbour's: how rough the cloud reads at DSE's scale."""
    from geostructure.detect.roughfacets import point_normals

    normal, _, _, neighbours, _ = point_normals(points, k, k)
    cos = np.abs(np.einsum("ij,ij->i", normal, normal[neighbours[:, 1]]))
    return float(np.degrees(np.arccos(np.clip(np.median(cos), 0.0, 1.0))))


def measure(cloud: Path, out: Path) -> dict:
    t = time.perf_counter()
    subprocess.run([*COMMAND, "measure", str(cloud), "-o", str(out), "--sets", "-q"], check=True)
    record = json.loads((out / "run.json").read_text())
    return {"seconds": time.perf_counter() - t, "record": record}


def describe(name: str, points: np.ndarray, run: dict, extra: dict) -> None:
    record = run["record"]
    counts = record["counts"]
    print(json.dumps({
        "cloud": name, "points": len(points),
        "grid_scatter_deg": round(record["detection"]["far_scatter_deg"], 2),
        "rough_detector": "rough_facets" in record["detection"],
        "plane_angle_30nn_deg": round(neighbour_plane_angle(points - points.mean(axis=0)), 2),
        "share_in_planes": round(counts["labelled_points"] / counts["filtered"], 3),
        "planes": counts["planes"], "seconds": round(run["seconds"], 2), **extra,
    }))  # fmt: skip


def facet_scores(scene, out: Path, points: np.ndarray) -> dict:
    from scipy.spatial import cKDTree

    from geostructure.evaluation.groundtruth import match_facets
    from geostructure.io.results import read_planes

    planes = read_planes(out, offset=np.zeros(3))
    match = match_facets(planes, scene)
    eligible = match.eligible
    radius = np.sqrt(scene.facet_area / np.pi)
    per_facet = cKDTree(points).query_ball_point(scene.facet_center[eligible], radius[eligible], return_length=True)
    return {"facets_found": f"{int(match.found[eligible].sum())}/{int(eligible.sum())} ({match.recall:.0%})",
            "points_per_facet_median": int(np.median(per_facet))}  # fmt: skip


def main() -> None:
    from geostructure.io.readers import read_cloud
    from geostructure.synthetic import outcrop_scene
    from geostructure.testing.outcrop_photos import write_outcrop_photos

    work = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp())
    t = time.perf_counter()
    scene, photos, gcp = write_outcrop_photos(work)
    print(f"24 photos rendered in {time.perf_counter() - t:.0f} s")
    t = time.perf_counter()
    subprocess.run([*COMMAND, "run", str(photos), "-o", str(work / "rebuilt"), "--gcp", str(gcp),
                    "--no-report", "-q"], check=True)  # fmt: skip
    print(f"rebuilt by geostructure run in {time.perf_counter() - t:.0f} s")
    rebuilt = thinned(read_cloud(work / "rebuilt" / "cloud.ply").points, THIN)
    np.savetxt(work / "rebuilt_3cm.xyz", rebuilt, fmt="%.6f")
    run = measure(work / "rebuilt_3cm.xyz", work / "rebuilt_measured")
    describe(
        "synthetic, photographed and rebuilt, 3 cm",
        rebuilt,
        run,
        facet_scores(scene, work / "rebuilt_measured", rebuilt),
    )
    direct = outcrop_scene(width=6.0, height=4.0, seed=0)
    np.savetxt(work / "direct.xyz", direct.cloud.points, fmt="%.6f")
    run = measure(work / "direct.xyz", work / "direct_measured")
    describe("synthetic, sampled directly, 3 cm", direct.cloud.points, run,
             facet_scores(direct, work / "direct_measured", direct.cloud.points))  # fmt: skip
    cloud = DATA / "Lastoni_SW_3cm.txt"
    if cloud.is_file():
        from scipy.spatial import cKDTree

        from geostructure.io.fieldmap import read_field_map

        real = np.loadtxt(cloud, usecols=(0, 1, 2))
        run = measure(cloud, work / "real_measured")
        subprocess.run([*COMMAND, "evaluate", str(work / "real_measured"), "--fractures", str(DATA / "fit_planes.csv"),
                        "-q"], check=True)  # fmt: skip
        scores = json.loads((work / "real_measured" / "validation.json").read_text())
        fmap = read_field_map(DATA / "fit_planes.csv")
        radius = np.genfromtxt(DATA / "fit_planes.csv", delimiter=",", names=True)["Radius"]
        per = cKDTree(real).query_ball_point(fmap.centres, radius, return_length=True)
        describe("real Lastoni SW half, 3 cm", real, run,
                 {"fractures_matched": f"{scores['matched']}/{scores['mapped']}",
                  "points_per_fracture_median": int(np.median(per))})  # fmt: skip


if __name__ == "__main__":
    main()
