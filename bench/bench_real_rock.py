"""Benchmark: GeoStructure against the DSE-style peer on real rock, from the file, end to end.

The cloud is the south-west half of the DICE Lastoni di Formin drone SfM outcrop
(``../shared/data/dice_lastoni_sw``: 38,219 points at 3 cm, 432 hand-mapped fractures and
two published set means). Each method runs in its own process from the text file, with
its default options:

- ``geostructure measure Lastoni_SW_3cm.txt -o OUT --sets``;
- the peer of ``bench_outcrop.py`` (DSE's method as its paper describes it), keeping its
  clusters of 30 points or more (as that benchmark does) and of 10 or more (DSE's own
  minimum).

Each is scored by the data's rule (``geostructure.evaluation.mapcheck``): mapped fractures matched
(a plane's centroid within 0.6 m, its normal within 10 degrees), precision (the share of
the planes that match one), and each published set's angle to the nearest set found; and
GeoStructure's traces by the data's trace rule, the null model's score beside them, with the
seconds the traces' stage takes beside the planes' stages (``run.json``'s, in memory and
streamed) and the memory each of those two stages takes at its peak. It prints seconds,
points per second, peak memory and the ratio of the peer's time to ours.

    python bench/bench_real_rock.py
"""

from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

import numpy as np
from bench_outcrop import run_geostructure, run_peer_process
from common import compile_package, the_commands_memory_settings

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "dice_lastoni_sw"


def scores(found: dict) -> dict:
    """The data's rule on one method's planes and set normals."""
    from geostructure.core.orientation import normal_from_orientation
    from geostructure.evaluation.mapcheck import mapped_set_means, set_errors, validate
    from geostructure.io.fieldmap import read_field_map

    mapped = read_field_map(DATA / "fit_planes.csv")
    means = read_field_map(DATA / "set_means.csv", located=False)
    v = validate(found["centroids"], found["normals"], mapped.centres,
                 normal_from_orientation(mapped.dip_direction, mapped.dip))  # fmt: skip
    errors = set_errors(mapped_set_means(means.dip, means.dip_direction, ["1", "2"]), found["set_normals"])
    return {"matched": f"{v.n_matched}/{len(mapped)}", "precision": round(v.precision, 3), "planes": len(v.useful),
            "set_errors_deg": {k: round(e, 1) for k, e in errors.items()}}  # fmt: skip


#: The measure's stages that find the planes, as ``run.json``'s ``seconds`` names them.
PLANE_STAGES = ("auto", "filter", "voxel", "regions", "planes", "orientation")


def trace_scores(outdir: Path) -> dict:
    """``evaluate --fractures`` on the run's traces (the data's trace rule, its null model beside),
    and what the traces' stage took against the planes' stages, as the run timed them."""
    import json

    from geostructure.evaluation.scoring import add_validation

    summary, _ = add_validation(outdir, DATA / "fit_planes.csv", set_means=DATA / "set_means.csv",
                                fracture_sets=DATA / "set_labels.csv")  # fmt: skip
    t = summary["traces"]
    seconds = json.loads((outdir / "run.json").read_text())["seconds"]
    planes = sum(seconds.get(stage, 0.0) for stage in PLANE_STAGES)
    sets = {k: f"{v['found_chord_sum']:.1f}/{v['mapped_chord_sum']:.1f} m, median {v['found_chord_median']:.2f}/"
               f"{v['mapped_chord_median']:.2f} m" for k, v in t.get("sets", {}).items()}  # fmt: skip
    return {"traces": t["found"], "traced": f"{t['traced']}/432", "trace_precision": round(t["trace_precision"], 3),
            "null": f"{t['null_traced']} at {t['null_precision']:.3f}", "found_by_plane_or_trace":
            t["found_by_plane_or_trace"], "chords_found_over_map": sets,
            "planes_seconds": round(planes, 2), "sets_seconds": round(seconds.get("sets", 0.0), 2),
            "traces_seconds": round(seconds.get("traces", 0.0), 2),
            "traces_over_planes": round(seconds.get("traces", 0.0) / planes, 2) if planes else None}  # fmt: skip


def streamed_stage_seconds(cloud: Path, outdir: Path) -> dict:
    """``measure --sets --engine stream`` in a process of its own: the traces' stage and the
    planes' stages, as its ``run.json`` times them."""
    import subprocess

    subprocess.run([sys.executable, "-m", "geostructure", "measure", str(cloud), "-o", str(outdir), "--sets",
                    "--engine", "stream", "-q"], check=True, stderr=subprocess.DEVNULL)  # fmt: skip
    seconds = json.loads((outdir / "run.json").read_text())["seconds"]
    planes = sum(seconds.get(stage, 0.0) for stage in PLANE_STAGES)
    return {"streamed_planes_seconds": round(planes, 2), "streamed_traces_seconds": round(seconds["traces"], 2),
            "streamed_traces_over_planes": round(seconds["traces"] / planes, 2)}  # fmt: skip


def stage_memory(cloud: Path) -> dict:
    """The most memory (MB, numpy's and Python's, as ``tracemalloc`` counts them) the planes'
    stage and the traces' stage each take above what stood when it began, in memory
    (``measure_outcrop(..., sets=True)``, in this process, after the timed runs)."""
    import tracemalloc
    import warnings

    import geostructure.workflows.outcrop as outcrop
    from geostructure.io.readers import read_cloud

    points = read_cloud(cloud)
    peaks: dict = {}

    def traced(name, stage):
        def run(measuring):
            start = tracemalloc.get_traced_memory()[0]
            tracemalloc.reset_peak()
            stage(measuring)
            peaks[name] = (tracemalloc.get_traced_memory()[1] - start) / 1e6

        return run

    kept = outcrop.STAGES
    # each stage wrapped for the one run: the workflow reads its stages from that list
    outcrop.STAGES = tuple((name, traced(name, stage)) for name, stage in kept)
    tracemalloc.start()
    try:
        with warnings.catch_warnings():  # the notes the timed run printed already
            warnings.simplefilter("ignore")
            outcrop.measure_outcrop(points, sets=True)
    finally:
        tracemalloc.stop()
        outcrop.STAGES = kept
    return {"planes_stage_mb": round(peaks["planes"], 1), "traces_stage_mb": round(peaks["traces"], 1)}


def main() -> None:
    cloud = DATA / "Lastoni_SW_3cm.txt"
    if not cloud.is_file():
        sys.exit(f"{cloud}: not here (../shared/data is beside the checkout)")
    the_commands_memory_settings()
    compile_package()
    n = sum(1 for _ in open(cloud))
    print(f"{cloud.name}: {n:,} points, default options, each method in its own process from the file")
    with tempfile.TemporaryDirectory() as tmp:
        runs = {"geostructure": run_geostructure(cloud, Path(tmp) / "out")}
        traced = trace_scores(Path(tmp) / "out")
        traced.update(streamed_stage_seconds(cloud, Path(tmp) / "streamed"))
        for minimum in (30, 10):
            runs[f"DSE-style peer, clusters of {minimum}+"] = run_peer_process(
                cloud, Path(tmp) / f"peer{minimum}.npz", minimum
            )
    traced.update(stage_memory(cloud))
    ours = runs["geostructure"]["seconds"]
    for name, run in runs.items():
        row = {"method": name, "seconds": round(run["seconds"], 2), "points_per_s": round(n / run["seconds"]),
               "peak_mb": round(run["peak_mb"]), "peer_seconds_over_ours": round(run["seconds"] / ours, 2),
               **scores(run), **(traced if name == "geostructure" else {"traces": "none drawn"})}  # fmt: skip
        print(json.dumps(row))


if __name__ == "__main__":
    np.seterr(all="ignore")
    main()
