"""Look at the traces on the real outcrop: the mapped traces beside the ones the default
draws, each found trace coloured by whether it traces a mapped fracture, and the null
model's segments scored the same way. Draws docs/figures/real_rock_traces.png and prints
the figures of docs/rockmass.md ("Traces").

    .venv/bin/python scripts/real_rock_traces.py [WORKDIR]

Needs ``../shared/data/dice_lastoni_sw``. Runs ``geostructure measure CLOUD -o DIR --sets``
(the default) and ``geostructure evaluate DIR --fractures ... --fracture-sets ...``.
"""

from __future__ import annotations

import csv
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from geostructure.evaluation.tracescore import score_traces, trace_lines
from geostructure.io.fieldmap import read_field_map, read_set_labels
from geostructure.io.results import read_traces

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data" / "dice_lastoni_sw"
CLOUD = DATA / "Lastoni_SW_3cm.txt"
FIGURE = ROOT / "docs" / "figures" / "real_rock_traces.png"
ZOOM_FIGURE = ROOT / "docs" / "figures" / "real_rock_traces_zoom.png"
#: The window the zoom shows, square-on (metres along and up the face from its centroid):
#: the face's left part, where the map's first set is densest.
ZOOM_WINDOW = (-3.5, -1.5, -2.5, -0.5)
#: Distances (m) at which a mapped trace counts as crowded by another along half its length.
CROWDING_M = (0.03, 0.06, 0.09, 0.15)
COMMAND = [sys.executable, "-m", "geostructure"]
SET_COLOURS = {"1": "#1b9e77", "2": "#d95f02", "": "#7570b3"}


def main() -> None:
    work = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp())
    out = work / "default"
    subprocess.run([*COMMAND, "measure", str(CLOUD), "-o", str(out), "--sets", "-q"], check=True)
    subprocess.run([*COMMAND, "evaluate", str(out), "--fractures", str(DATA / "fit_planes.csv"), "--set-means",
                    str(DATA / "set_means.csv"), "--fracture-sets", str(DATA / "set_labels.csv")], check=True)  # fmt: skip
    scores = json.loads((out / "validation.json").read_text())["traces"]
    points = np.loadtxt(CLOUD)
    xyz, rgb = points[:, :3], points[:, 3:6] / 255.0
    origin = xyz.mean(axis=0)
    xyz = xyz - origin
    tree = cKDTree(xyz)
    mapped = read_field_map(DATA / "fit_planes.csv")
    labels = read_set_labels(DATA / "set_labels.csv", len(mapped))
    centres = mapped.centres - origin
    lines = trace_lines(xyz, tree, centres, mapped.normals)
    found, _ = read_traces(out)
    found = [line - origin for line in found]
    score = score_traces(found, centres, mapped.normals, mapped.radius, lines)
    with open(out / "traces.csv", newline="") as fh:
        source = [row["source"] for row in csv.DictReader(fh)]
    draw(xyz, rgb, centres, mapped.radius, lines, labels, found, score, source, scores)
    draw_zoom(xyz, rgb, centres, mapped.radius, lines, found, score, source)
    print(json.dumps(scores, indent=1))
    print(json.dumps({"mapped_traces_crowded": crowding(centres, mapped.radius, lines)}))


def crowding(centres, radius, lines) -> dict:
    """How many mapped traces run within each distance of :data:`CROWDING_M` of another
    mapped trace along half their length or more (21 samples along each chord): two lines
    that close are one line to a detector whose flanks lie a spacing or two away."""
    samples = [c + np.outer(np.linspace(-1.0, 1.0, 21) * r, t) for c, r, t in zip(centres, radius, lines)]
    owner = np.repeat(np.arange(len(samples)), 21)
    tree = cKDTree(np.vstack(samples))
    out = {}
    for distance in CROWDING_M:
        crowded = 0
        for k, points in enumerate(samples):
            near = tree.query_ball_point(points, distance)
            crowded += np.mean([bool(set(owner[n]) - {k}) for n in near]) >= 0.5
        out[f"{distance:g} m"] = int(crowded)
    return out


def draw_zoom(xyz, rgb, centres, radius, lines, found, score, source) -> None:
    """The face's colour with the map's traces (traced ones bright), and its grey with ours
    (those that trace a mapped fracture blue), in :data:`ZOOM_WINDOW`, a point a dot."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    axes = np.linalg.eigh(np.cov(xyz.T))[1]
    u, v = axes[:, 2], axes[:, 1] if axes[2, 1] >= 0 else -axes[:, 1]
    flat = lambda p: np.column_stack([p @ u, p @ v])  # noqa: E731
    face = flat(xyz)
    x0, x1, y0, y1 = ZOOM_WINDOW
    inside = (face[:, 0] > x0) & (face[:, 0] < x1) & (face[:, 1] > y0) & (face[:, 1] < y1)
    fig, panels = plt.subplots(1, 2, figsize=(16, 8.4), constrained_layout=True)
    panels[0].scatter(face[inside, 0], face[inside, 1], c=rgb[inside], s=16, lw=0)
    panels[1].scatter(face[inside, 0], face[inside, 1], c=rgb[inside].mean(axis=1), cmap="gray", s=16, lw=0)
    for c, r, t, traced in zip(centres, radius, lines, score.traced):
        ends = flat(np.stack([c - r * t, c + r * t]))
        panels[0].plot(ends[:, 0], ends[:, 1], color="#00c000" if traced else "#ffd000", lw=2)
    for line, useful, kind in zip(found, score.useful, source):
        xy = flat(line)
        panels[1].plot(xy[:, 0], xy[:, 1], color="#1f78b4" if useful else "#e31a1c", lw=2, ls=LINE_STYLES.get(kind, "--"))
    for ax in panels:
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
        ax.set_aspect("equal")
        ax.set_xlabel("along the face (m)")
        ax.set_ylabel("up the face (m)")
    panels[0].set_title("The map over the colour: traced (green), missed (yellow)")
    panels[1].set_title("The default's traces over the grey: tracing a mapped fracture (blue) or none (red)")
    fig.savefig(ZOOM_FIGURE, dpi=60)
    print(f"wrote {ZOOM_FIGURE}")


#: How each kind of trace is drawn: a dark line solid, a valley dotted, a plane's trace dashed.
LINE_STYLES = {"dark line": "-", "valley": ":", "plane": "--"}


def draw(xyz, rgb, centres, radius, lines, labels, found, score, source, scores) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    # square-on: the face's own plane (its two largest axes)
    axes = np.linalg.eigh(np.cov(xyz.T))[1]
    u, v = axes[:, 2], axes[:, 1] if axes[2, 1] >= 0 else -axes[:, 1]
    flat = lambda p: np.column_stack([p @ u, p @ v])  # noqa: E731
    face = flat(xyz)
    fig, panels = plt.subplots(1, 2, figsize=(18, 8.2), constrained_layout=True)
    for ax in panels:
        ax.scatter(face[:, 0], face[:, 1], c=rgb, s=1.2, lw=0)
        ax.set_aspect("equal")
        ax.set_xlabel("along the face (m)")
        ax.set_ylabel("up the face (m)")
    for c, r, t, label in zip(centres, radius, lines, labels):
        ends = flat(np.stack([c - r * t, c + r * t]))
        panels[0].plot(ends[:, 0], ends[:, 1], color=SET_COLOURS.get(label, SET_COLOURS[""]), lw=1.4)
    panels[0].set_title(f"The map: {len(centres)} traces drawn by hand (DICE)")
    panels[0].legend(handles=[Line2D([], [], color=SET_COLOURS[k], lw=2, label=f"set {k}" if k else "no set")
                              for k in ("1", "2", "")], loc="lower right")  # fmt: skip
    for line, useful, kind in zip(found, score.useful, source):
        xy = flat(line)
        panels[1].plot(xy[:, 0], xy[:, 1], color="#1f78b4" if useful else "#e31a1c", lw=1.6,
                       ls=LINE_STYLES.get(kind, "--"))  # fmt: skip
    panels[1].set_title(
        f"The default: {scores['found']} traces, {scores['traced']} mapped fractures traced, precision "
        f"{scores['trace_precision']:.2f} (null model: {scores['null_traced']} at {scores['null_precision']:.2f})"
    )
    panels[1].legend(handles=[Line2D([], [], color="#1f78b4", lw=2, label="traces a mapped fracture"),
                              Line2D([], [], color="#e31a1c", lw=2, label="traces none"),
                              Line2D([], [], color="k", lw=2, label="dark line"),
                              Line2D([], [], color="k", lw=2, ls=":", label="valley"),
                              Line2D([], [], color="k", lw=2, ls="--", label="a plane's trace")],
                     loc="lower right")  # fmt: skip
    FIGURE.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(FIGURE, dpi=80)
    print(f"wrote {FIGURE}")


if __name__ == "__main__":
    main()
