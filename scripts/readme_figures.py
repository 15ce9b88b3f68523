"""Draw the README's outcrop figures again from the current code, and print the tables
shown beside them.

    .venv/bin/python scripts/readme_figures.py [WORKDIR]

- ``docs/figures/outcrop_stereonet.png``: ``measure --sets --report`` of
  ``outcrop_scene(seed=0, offset=(662000, 5103000, 800))`` written as text;
- ``docs/figures/outcrop_kinematics.png``: ``measure --sets --kinematics --friction 30`` of
  ``outcrop_scene(seed=0, face_dip=65)``;
- ``docs/figures/dips_columns.png``: the first rows of the first run's ``planes_dips.csv``
  with the Dips column each maps to.
"""

from __future__ import annotations

import csv
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from geostructure.synthetic import outcrop_scene

ROOT = Path(__file__).resolve().parents[1]
FIGURES = ROOT / "docs" / "figures"
COMMAND = [sys.executable, "-m", "geostructure"]


def measure(cloud: Path, out: Path, *options: str) -> None:
    subprocess.run([*COMMAND, "measure", str(cloud), "-o", str(out), *options], check=True)


def dips_columns_figure(dips_csv: Path, path: Path, rows: int = 6) -> None:
    """A picture of the file's header and first rows, each column labelled with what Dips'
    Import CSV maps it to."""
    import matplotlib

    matplotlib.use("Agg")  # a script, not the library: no display here
    import matplotlib.pyplot as plt

    with open(dips_csv, newline="") as fh:
        table = list(csv.reader(fh))
    header, body = table[0], table[1 : rows + 1]
    roles = {
        "Dip Direction": "orientation 2\n(Dip Direction)",
        "Dip": "orientation 1\n(Dip)",
        "Set": "Set",
        "X (East)": "X (East)",
        "Y (North)": "Y (North)",
        "Z (Elev.)": "Z (Elev.)",
        "Region": "extra column",
        "Points": "extra column",
    }
    cells = [[roles.get(h, "extra column") for h in header], header] + [
        [f"{float(v):.2f}" if h.startswith(("X", "Y", "Z")) else v for h, v in zip(header, row)] for row in body
    ]
    fig, ax = plt.subplots(figsize=(11, 0.42 * len(cells) + 0.6))
    ax.axis("off")
    drawn = ax.table(cellText=cells, loc="center", cellLoc="center")
    drawn.auto_set_font_size(False)
    drawn.set_fontsize(9)
    drawn.scale(1, 1.6)
    for (r, _), cell in drawn.get_celld().items():
        if r == 0:
            cell.set_facecolor("#dbe8f5")
            cell.set_height(cell.get_height() * 1.5)
        elif r == 1:
            cell.set_facecolor("#eeeeee")
            cell.get_text().set_fontweight("bold")
    ax.set_title("planes_dips.csv (first rows) and the Dips column each maps to (top row)", fontsize=10)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)


def main(work: Path) -> None:
    work.mkdir(parents=True, exist_ok=True)
    scene = outcrop_scene(seed=0, offset=(662000.0, 5103000.0, 800.0))
    cloud = work / "outcrop.xyz"
    np.savetxt(cloud, scene.cloud.points, fmt="%.4f")
    measure(cloud, work / "outcrop", "--sets", "--report", "--crs", "EPSG:32632")
    shutil.copyfile(work / "outcrop" / "stereonet.png", FIGURES / "outcrop_stereonet.png")
    dips_columns_figure(work / "outcrop" / "planes_dips.csv", FIGURES / "dips_columns.png")

    slope = outcrop_scene(seed=0, face_dip=65)
    cloud = work / "slope.xyz"
    np.savetxt(cloud, slope.cloud.points, fmt="%.4f")
    measure(cloud, work / "slope", "--sets", "--kinematics", "--friction", "30")
    shutil.copyfile(work / "slope" / "kinematics.png", FIGURES / "outcrop_kinematics.png")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp()))
