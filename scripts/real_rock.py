"""Look at the real outcrop: where the mapped fractures are, what each detector found, and
why the missed ones were missed. Prints the tables of docs/rockmass.md ("Real rock") and
draws docs/figures/real_rock_sw.png.

    .venv/bin/python scripts/real_rock.py [WORKDIR]

Needs ``../shared/data/dice_lastoni_sw``. Runs ``geostructure measure CLOUD -o DIR --sets``
(the default) and the same with ``--detector voxel`` (the paper's voxel growing, which the
default fell back to on this cloud until 2026-12-06), scores both with ``geostructure
evaluate --fractures``, then sorts the default's missed fractures by cause.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from geostructure.core.density import point_spacing
from geostructure.core.orientation import normal_from_orientation
from geostructure.detect.roughfacets import FACE_CONE, MIN_FACET_POINTS, envelope_normals, point_normals
from geostructure.evaluation.mapcheck import MAX_ANGLE, MAX_DISTANCE, axial_angle
from geostructure.io.fieldmap import read_field_map

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data" / "dice_lastoni_sw"
CLOUD = DATA / "Lastoni_SW_3cm.txt"
FIGURE = ROOT / "docs" / "figures" / "real_rock_sw.png"
COMMAND = [sys.executable, "-m", "geostructure"]


def run(work: Path, name: str, *options: str) -> dict:
    """Measure with ``options``, score against the field map; the scores and plane table."""
    out = work / name
    subprocess.run([*COMMAND, "measure", str(CLOUD), "-o", str(out), "--sets", "-q", *options], check=True)
    subprocess.run([*COMMAND, "evaluate", str(out), "--fractures", str(DATA / "fit_planes.csv"),
                    "--set-means", str(DATA / "set_means.csv"), "-q"], check=True)  # fmt: skip
    planes = np.genfromtxt(out / "planes.csv", delimiter=",", names=True)
    return {"summary": json.loads((out / "validation.json").read_text()), "planes": planes, "folder": out,
            "matched": np.genfromtxt(out / "validation.csv", delimiter=",", names=True)["matched"] > 0}  # fmt: skip


def causes(points: np.ndarray, planes, fmap) -> dict[str, int]:
    """Why each mapped fracture the default missed was missed (see docs/rockmass.md)."""
    from scipy.spatial import cKDTree

    normal, _, _, _, _ = point_normals(points)
    on_face = np.abs(np.einsum("ij,ij->i", normal, envelope_normals(points, point_spacing(points)))) >= np.cos(
        np.radians(FACE_CONE)
    )
    map_normals = normal_from_orientation(fmap.dip_direction, fmap.dip)
    centroids = np.column_stack([planes["centroid_x"], planes["centroid_y"], planes["centroid_z"]])
    plane_normals = normal_from_orientation(planes["dip_direction"], planes["dip"])
    near_planes = cKDTree(centroids).query_ball_point(fmap.centres, MAX_DISTANCE)
    near_points = cKDTree(points).query_ball_point(fmap.centres, MAX_DISTANCE)
    count = {"matched": 0, "no face of its own (a trace only)": 0, "its points lie along the face": 0,
             "a facet near, its normal off": 0, "its points joined no facet": 0}  # fmt: skip
    for i in range(len(fmap)):
        angles = axial_angle(plane_normals[near_planes[i]], map_normals[i]) if near_planes[i] else np.zeros(0)
        if (angles <= MAX_ANGLE).any():
            count["matched"] += 1
            continue
        index = np.asarray(near_points[i], dtype=np.int64)
        agree = index[axial_angle(normal[index], map_normals[i]) <= MAX_ANGLE]
        if len(agree) < MIN_FACET_POINTS:
            count["no face of its own (a trace only)"] += 1
        elif on_face[agree].mean() > 0.5:
            count["its points lie along the face"] += 1
        elif len(angles):
            count["a facet near, its normal off"] += 1
        else:
            count["its points joined no facet"] += 1
    return count


def figure(points: np.ndarray, fmap, runs: dict, path: Path) -> None:
    """The face seen square-on, three panels: the mapped fractures (filled where the
    default matched them), the default's planes by set, the voxel growing's planes."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    centre = points.mean(axis=0)
    axes = np.linalg.svd(points - centre, full_matrices=False)[2]  # along strike, up the face, normal
    u = (points - centre) @ axes[:2].T
    fig, panels = plt.subplots(1, 3, figsize=(18, 6.4), sharex=True, sharey=True)
    colours = ["tab:red", "tab:blue", "tab:green", "tab:purple", "tab:orange", "tab:brown"]
    labels = np.genfromtxt(DATA / "set_labels.csv", delimiter=",", names=True)["Set"]
    for ax in panels:
        ax.scatter(u[:, 0], u[:, 1], s=0.4, c="0.82", linewidths=0)
        ax.set_aspect("equal")
        ax.set_xlabel("along the face (m)")
    mapped = (fmap.centres - centre) @ axes[:2].T
    matched = runs["default"]["matched"]
    for s, colour in ((1, "tab:red"), (2, "tab:blue")):
        for hit in (True, False):
            m = (labels == s) & (matched == hit)
            panels[0].scatter(mapped[m, 0], mapped[m, 1], s=18, marker="o", linewidths=0.8,
                              facecolors=colour if hit else "none", edgecolors=colour,
                              label=f"set {s}, {'matched' if hit else 'missed'} ({m.sum()})")  # fmt: skip
    m = np.isnan(labels)
    panels[0].scatter(
        mapped[m, 0], mapped[m, 1], s=12, marker="x", c="0.3", linewidths=0.6, label=f"no set ({m.sum()})"
    )
    panels[0].legend(loc="lower left", fontsize=8)
    panels[0].set_ylabel("up the face (m)")
    panels[0].set_title("Mapped fractures (disc centres)\nfilled: the default matched them")
    for ax, name, title in ((panels[1], "default", "Default: facets on rough rock"),
                            (panels[2], "voxel", "Paper's voxel growing (the old fallback)")):  # fmt: skip
        planes, summary, folder = runs[name]["planes"], runs[name]["summary"], runs[name]["folder"]
        from plyfile import PlyData

        vertex = PlyData.read(folder / "regions.ply")["vertex"].data
        region = vertex["scalar_region_id"]
        xy = (np.column_stack([vertex["x"], vertex["y"], vertex["z"]]) - centre) @ axes[:2].T
        sets = np.r_[planes["set"].astype(int), -1]
        face = planes["face_surface"] > 0 if "face_surface" in planes.dtype.names else np.zeros(len(planes), bool)
        point_set, point_face = sets[region], np.r_[face, False][region]
        m = point_face
        ax.scatter(
            xy[m, 0], xy[m, 1], s=0.8, c="tan", linewidths=0, label=f"the face's own surface ({face.sum()} planes)"
        )
        m = (region >= 0) & (point_set < 0) & ~point_face
        ax.scatter(xy[m, 0], xy[m, 1], s=0.8, c="0.3", linewidths=0,
                   label=f"in no set ({((sets[:-1] < 0) & ~face).sum()} planes)")  # fmt: skip
        table = np.genfromtxt(folder / "sets.csv", delimiter=",", names=True, ndmin=1)
        for s, row in enumerate(table):
            m = point_set == s
            ax.scatter(xy[m, 0], xy[m, 1], s=1.2, c=colours[s % len(colours)], linewidths=0,
                       label=f"set {s}: {row['n_planes']:.0f} planes, {row['dip']:.0f}/{row['dip_direction']:03.0f}")  # fmt: skip
        ax.legend(loc="lower left", fontsize=8, markerscale=8)
        ax.set_title(f"{title}\n{summary['matched']} of 432 matched, precision {summary['precision']:.0%}")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main() -> None:
    if not CLOUD.is_file():
        sys.exit(f"{CLOUD}: not here (../shared/data is beside the checkout in CI)")
    work = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp())
    runs = {"default": run(work, "default"), "voxel": run(work, "voxel", "--detector", "voxel")}
    for name, r in runs.items():
        s = r["summary"]
        errors = ", ".join(f"{v:.1f}" for v in (s["set_errors_deg"] or {}).values())
        print(f"{name}: {s['matched']} of {s['mapped']} matched, precision {s['precision']:.3f} "
              f"({s['planes']} planes), set errors {errors} deg")  # fmt: skip
    points = np.loadtxt(CLOUD, usecols=(0, 1, 2))
    offset = points.mean(axis=0)
    fmap = read_field_map(DATA / "fit_planes.csv")
    fmap = type(fmap)(fmap.centres - offset, fmap.dip, fmap.dip_direction, fmap.sets)
    planes = runs["default"]["planes"].copy()
    for axis in "xyz":
        planes[f"centroid_{axis}"] -= offset["xyz".index(axis)]
    print(f"point spacing {point_spacing(points - offset):.4f}")
    for cause, n in causes(points - offset, planes, fmap).items():
        print(f"  {cause}: {n}")
    figure(points, read_field_map(DATA / "fit_planes.csv"), runs, FIGURE)
    print(f"wrote {FIGURE}")


if __name__ == "__main__":
    main()
