"""Benchmark: GeoStructure against a DSE-style peer on rough synthetic outcrops, from files.

For each seed, writes a synthetic outcrop (``geostructure.synthetic.outcrop_scene``, 40 x 16 m
at 2.5 cm by default, about 0.9M points after occlusion) as a binary PLY. Then it runs, each
in its own process and from that file, with their default options:

- ``geostructure measure FILE -o OUT --sets``;
- the peer.

It prints, for each: the facets found (of 0.3 m and more), each set's mean error against
the exposed facets, the seconds end to end, the points per second, the peak memory, and the
ratio of the two.

    python bench/bench_outcrop.py                   # seeds 0 and 1
    python bench/bench_outcrop.py --seeds 3 --width 20 --height 8 --spacing 0.03
    python bench/bench_outcrop.py --road 4 --crest 3 --bushes 12   # a rock cut as surveyed
    python bench/bench_outcrop.py --persistence 3                   # joints 3 m across

With ``--road``, ``--crest`` and ``--bushes`` the file also holds level ground before the
face and behind its crest (metres deep, 1 cm of noise) and bushes on it, the rock behind
them hidden (``geostructure.synthetic.road_before``, ``crest_above``, ``bushes_on``); the
facets are still counted against the whole face, so those the bushes hide count as missed.

With ``--persistence`` the joints are discs of that mean diameter (Baecher et al. 1977)
rather than planes through the rock mass. For GeoStructure the benchmark also prints each
generated set's spacing as measured over the truth, and its joints' mean trace over the
true traces of the discs the face shows, with ISRM's class of both (the peer gives neither).

The peer is written here from the method of Discontinuity Set Extractor (Riquelme et al.
2014), as its paper describes it:

1. per-point normals from the 30 nearest neighbours;
2. a coplanarity test: the neighbourhood's surface variation below the 75th percentile;
3. the sets from the peaks of the poles' density (exponential Kamb), each peak at least a
   fifth of the highest; points within 30 degrees of a set's pole belong to it;
4. DBSCAN of each set's points in space (eps 2.5 point spacings, 10 points), one cluster
   a discontinuity;
5. a least-squares plane per cluster of at least 30 points.

It is a peer written for this benchmark, not DSE itself (MATLAB), and not part of the package.
Both run with the memory settings the ``geostructure`` command chooses for itself: numpy's
small pages (``NUMPY_MADVISE_HUGEPAGE=0``; on a VM that returns freed memory to its host it
takes a third off each one's time) and glibc's malloc reusing freed memory; the peer is given
them too.
"""

from __future__ import annotations

import argparse
import csv
import json
import resource
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from common import compile_package, the_commands_memory_settings, write_ply


def dbscan(points: np.ndarray, eps: float, min_samples: int) -> np.ndarray:
    """DBSCAN with scipy: core points (min_samples within eps) joined by eps, borders to a core."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    tree = cKDTree(points)
    core = tree.query_ball_point(points, eps, return_length=True) >= min_samples
    labels = np.full(len(points), -1)
    if not core.any():
        return labels
    core_index = np.flatnonzero(core)
    pairs = cKDTree(points[core]).query_pairs(eps, output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(core_index),) * 2)
    _, component = connected_components(graph, directed=False)
    labels[core_index] = component
    border = np.flatnonzero(~core)
    dist, nearest = cKDTree(points[core]).query(points[border], distance_upper_bound=eps)
    ok = np.isfinite(dist)
    labels[border[ok]] = component[nearest[ok]]
    return labels


#: Points per batch of the peer's covariance matrices (bounds memory at ~50 MB a batch).
BATCH = 100_000


def knn_planes(points: np.ndarray, k: int = 30) -> tuple[np.ndarray, np.ndarray, float]:
    """DSE's per-point planes: each point's unit normal (N, 3) and surface variation (N,)
    from the least-squares plane through its ``k`` nearest neighbours, and the cloud's
    spacing (the median distance to the nearest neighbour)."""
    from scipy.spatial import cKDTree

    k = min(k, len(points))
    distances, neighbours = cKDTree(points).query(points, k=k, workers=-1)
    normal = np.empty((len(points), 3))
    variation = np.empty(len(points))
    for start in range(0, len(points), BATCH):
        # About the point itself (well conditioned), the six distinct moments one by one:
        # much faster than an einsum over (n, k, 3, 3).
        rel = points[neighbours[start : start + BATCH]] - points[start : start + BATCH, None, :]
        mean = rel.mean(axis=1)
        cov = np.empty((len(rel), 3, 3))
        for i, j in ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)):
            cov[:, i, j] = cov[:, j, i] = (rel[:, :, i] * rel[:, :, j]).mean(axis=1) - mean[:, i] * mean[:, j]
        values, vectors = np.linalg.eigh(cov)
        values = np.maximum(values, 0.0)
        normal[start : start + BATCH] = vectors[:, :, 0]
        variation[start : start + BATCH] = values[:, 0] / np.maximum(values.sum(axis=1), 1e-300)
    return normal, variation, float(np.median(distances[:, 1]))


def peer(path: str, min_points: int = 30) -> dict:
    """The DSE-style pipeline on a PLY file (or an ``x y z ...`` text file); returns planes
    (centroid, normal) of its clusters of ``min_points`` or more, and set poles."""
    from plyfile import PlyData

    from geostructure.core.orientation import normal_from_orientation, orientation_from_normals
    from geostructure.core.projection import pole_density
    from geostructure.detect.rectangle import fit_plane

    if str(path).endswith(".txt"):
        points = np.loadtxt(path, usecols=(0, 1, 2))
    else:
        vertex = PlyData.read(path)["vertex"].data
        points = np.column_stack([vertex["x"], vertex["y"], vertex["z"]]).astype(np.float64)
    offset = points.mean(axis=0)
    local = points - offset
    normal, variation, spacing = knn_planes(local, k=30)
    flat = variation <= np.percentile(variation, 75)
    o = orientation_from_normals(normal[flat])
    sample = np.random.default_rng(0).choice(int(flat.sum()), min(20_000, int(flat.sum())), replace=False)
    x, y, density = pole_density(o.dip_direction[sample], o.dip[sample], gridsize=61)
    d = np.nan_to_num(density, nan=-np.inf)
    padded = np.pad(d, 1, constant_values=-np.inf)
    neighbours = np.stack([padded[1 + a : 1 + a + d.shape[0], 1 + b : 1 + b + d.shape[1]]
                           for a in (-1, 0, 1) for b in (-1, 0, 1) if a or b])  # fmt: skip
    peak = (d >= neighbours.max(axis=0)) & (d >= 0.2 * np.nanmax(density))
    rows, cols = np.nonzero(peak)
    # A pole at (x, y) of the lower-hemisphere net: back to a plane's dip direction and dip.
    r = np.hypot(x[cols], y[rows])
    plunge = 90.0 - 2.0 * np.degrees(np.arcsin(np.clip(r / np.sqrt(2.0), 0, 1)))
    trend = np.degrees(np.arctan2(x[cols], y[rows])) % 360.0
    set_normals = normal_from_orientation((trend + 180.0) % 360.0, 90.0 - plunge)
    cos = np.abs(normal[flat] @ set_normals.T)
    member = np.where(cos.max(axis=1) >= np.cos(np.radians(30.0)), cos.argmax(axis=1), -1)
    centroids, normals = [], []
    flat_points = local[flat]
    for s in range(len(set_normals)):
        mine = flat_points[member == s]
        labels = dbscan(mine, 2.5 * spacing, 10)
        for c in range(int(labels.max(initial=-1)) + 1):
            cluster = mine[labels == c]
            if len(cluster) >= min_points:
                centroid, plane_normal, _, _ = fit_plane(cluster)
                centroids.append(centroid + offset)
                normals.append(plane_normal)
    return {"centroids": np.array(centroids).reshape(-1, 3), "normals": np.array(normals).reshape(-1, 3),
            "set_normals": set_normals}  # fmt: skip


def run_peer_process(path: Path, out: Path, min_points: int = 30) -> dict:
    """The peer in a process of its own: seconds and peak memory are its own."""
    t = time.perf_counter()
    subprocess.run([sys.executable, __file__, "--peer", str(path), str(out), str(min_points)], check=True)
    seconds = time.perf_counter() - t
    data = np.load(out)
    return {"seconds": seconds, "peak_mb": float(data["peak_mb"]), "centroids": data["centroids"],
            "normals": data["normals"], "set_normals": data["set_normals"]}  # fmt: skip


def run_geostructure(path: Path, outdir: Path) -> dict:
    """``geostructure measure --sets`` in a process of its own, as a user runs it."""
    t = time.perf_counter()
    subprocess.run([sys.executable, __file__, "--measure", str(path), str(outdir)], check=True)
    seconds = time.perf_counter() - t
    peak_mb = json.loads((outdir / "peak.json").read_text())["peak_mb"]
    with open(outdir / "planes.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    with open(outdir / "sets.csv", newline="") as fh:
        sets = list(csv.DictReader(fh))

    def vectors(table, name):
        return np.array([[float(r[f"{name}_{a}"]) for a in "xyz"] for r in table]).reshape(-1, 3)

    return {"seconds": seconds, "peak_mb": peak_mb, "centroids": vectors(rows, "centroid"),
            "normals": vectors(rows, "normal"), "set_normals": vectors(sets, "normal"),
            "set_spacing": np.array([float(r["spacing_m"]) for r in sets]),
            "set_trace": np.array([float(r["joint_trace_mean_m"]) for r in sets]),
            "set_persistence": [r["persistence"] for r in sets]}  # fmt: skip


def score(scene, found: dict) -> dict:
    from geostructure.core.orientation import angle_between_normals
    from geostructure.core.planes import Planes
    from geostructure.evaluation.groundtruth import match_facets
    from geostructure.rockmass.tracelengths import persistence_class
    from geostructure.synthetic.scanlines import exposed_trace_chords

    planes = Planes(normal=found["normals"], local_centroid=found["centroids"], fit_residual=0.0)
    match = match_facets(planes, scene)
    truth = scene.exposed_set_statistics(min_diameter=0.3)
    errors = []
    for t in truth:
        if len(found["set_normals"]):
            tiled = np.tile(t["mean_normal"], (len(found["set_normals"]), 1))
            errors.append(float(angle_between_normals(tiled, found["set_normals"]).min()))
    # Each generated set's spacing as measured (the set nearest it), over the truth: ours only,
    # the peer gives none.
    # So is its joints' mean trace, over the true traces of the discs the face shows, with
    # its ISRM class and the truth's.
    spacing, trace, persistence = [], [], []
    if "set_spacing" in found and len(found["set_normals"]):
        for s, joint in enumerate(scene.sets):
            nearest = int(np.abs(found["set_normals"] @ joint.normal).argmax())
            spacing.append(float(found["set_spacing"][nearest] / scene.set_spacing[s]))
            chords = exposed_trace_chords(scene, s)
            if joint.persistence is not None and len(chords):
                trace.append(float(found["set_trace"][nearest] / chords.mean()))
                persistence.append(f"{found['set_persistence'][nearest] or '-'} ({persistence_class(chords.mean())})")
    return {"recall": match.recall, "found": int(match.found[match.eligible].sum()), "eligible": int(match.eligible.sum()),
            "planes": len(planes), "sets": len(found["set_normals"]), "set_errors": errors,
            "spacing_over_truth": spacing, "trace_over_truth": trace, "persistence": persistence}  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    parser.add_argument("--width", type=float, default=40.0)
    parser.add_argument("--height", type=float, default=16.0)
    parser.add_argument("--spacing", type=float, default=0.025)
    parser.add_argument("--road", type=float, default=0.0, help="metres of road before the face")
    parser.add_argument("--crest", type=float, default=0.0, help="metres of level ground behind its crest")
    parser.add_argument("--bushes", type=int, default=0, help="bushes on the face")
    parser.add_argument("--persistence", type=float, default=0.0,
                        help="the joints' mean diameter (m), as discs; 0: planes through the rock mass")  # fmt: skip
    parser.add_argument("--peer", nargs=3, metavar=("PLY", "OUT", "MIN_POINTS"), help=argparse.SUPPRESS)
    parser.add_argument("--measure", nargs=2, metavar=("PLY", "OUTDIR"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    the_commands_memory_settings()  # for every method's process
    if args.measure:
        from geostructure.__main__ import run as geostructure  # the command, as its script runs it

        code = geostructure(["measure", args.measure[0], "-o", args.measure[1], "--sets", "-q"])
        peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
        (Path(args.measure[1]) / "peak.json").write_text(json.dumps({"peak_mb": peak_mb}))
        sys.exit(code)
    if args.peer:
        result = peer(args.peer[0], int(args.peer[2]))
        peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
        np.savez(args.peer[1], peak_mb=peak_mb, **result)
        return

    compile_package()
    from geostructure.synthetic import bushes_on, crest_above, outcrop_scene, road_before
    from geostructure.synthetic.rock_outcrop import DEFAULT_SETS

    print("end to end from a binary PLY, default options; the peer: DSE's method as written here")
    if args.road or args.crest or args.bushes:
        print(f"with {args.road:g} m of road, {args.crest:g} m of ground behind the crest, {args.bushes} bushes")
    if args.persistence:
        print(f"joints {args.persistence:g} m across on average (discs), not planes through the rock mass")
    sets = tuple(replace(s, persistence=args.persistence or None) for s in DEFAULT_SETS)
    for seed in args.seeds:
        scene = outcrop_scene(width=args.width, height=args.height, point_spacing=args.spacing, seed=seed, sets=sets)
        bushes, hidden = bushes_on(scene, args.bushes, seed=seed) if args.bushes else (np.zeros((0, 3)), None)
        points = [scene.cloud.points if hidden is None else scene.cloud.points[~hidden], bushes]
        points += [road_before(scene, args.road, seed=seed)] if args.road else []
        points += [crest_above(scene, args.crest, seed=seed + 1)] if args.crest else []
        points = np.vstack(points)
        n = len(points)
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "outcrop.ply"
            write_ply(points, path)
            ours = run_geostructure(path, Path(tmp) / "out")
            theirs = run_peer_process(path, Path(tmp) / "peer.npz")
        scores = {"geostructure": score(scene, ours), "DSE-style peer": score(scene, theirs)}
        for name, run in (("geostructure", ours), ("DSE-style peer", theirs)):
            s = scores[name]
            print(
                json.dumps(
                    {
                        "seed": seed,
                        "method": name,
                        "points": n,
                        "seconds": round(run["seconds"], 2),
                        "points_per_s": round(n / run["seconds"]),
                        "peak_mb": round(run["peak_mb"]),
                        "facets_found": f"{s['found']}/{s['eligible']} ({100 * s['recall']:.0f}%)",
                        "planes": s["planes"],
                        "sets": s["sets"],
                        "set_mean_errors_deg": [round(e, 2) for e in s["set_errors"]],
                        **(
                            {"spacing_over_truth": [round(r, 2) for r in s["spacing_over_truth"]]}
                            if s["spacing_over_truth"]
                            else {}
                        ),
                        **(
                            {
                                "trace_over_truth": [round(r, 2) for r in s["trace_over_truth"]],
                                "persistence (truth)": s["persistence"],
                            }
                            if s["trace_over_truth"]
                            else {}
                        ),  # fmt: skip
                    }
                )
            )
        print(
            f"seed {seed}: GeoStructure {theirs['seconds'] / ours['seconds']:.2f}x the peer's speed, "
            f"{scores['geostructure']['found']} against {scores['DSE-style peer']['found']} facets found"
        )


if __name__ == "__main__":
    main()
