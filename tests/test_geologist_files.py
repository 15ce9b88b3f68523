"""What a geologist opens (issue 45): each file's columns say what they hold, in the
client the user has."""

import csv

import numpy as np
import pytest
from helpers import run_cli, scene_points, write_xyz


def dips_rows(out) -> np.ndarray:
    """(dip direction, dip, east, north, elevation, points) of planes_dips.csv's large planes."""
    rows = list(csv.DictReader(open(out / "planes_dips.csv")))
    table = np.array([[float(r[c]) for c in ("Dip Direction", "Dip", "X (East)", "Y (North)", "Z (Elev.)", "Points")]
                      for r in rows])  # fmt: skip
    return table[table[:, 5] >= 1000]


def turned(rotation: np.ndarray, points: np.ndarray) -> np.ndarray:
    """ENU points written in a cloud whose axes are ``rotation``'s rows' duals: cloud = R^T enu."""
    return points @ rotation


@pytest.mark.parametrize("frame", ["paper", "vectors"])
def test_dips_locations_are_east_north_and_elevation_in_every_frame(tmp_path, capsys, frame):
    """planes_dips.csv's X (East) and Y (North) held the cloud's raw x and y whatever the
    frame: in the paper frame (x north) Dips placed every plane a quarter turn away."""
    enu = scene_points(20_000, seed=3)
    assert run_cli(capsys, "measure", write_xyz(tmp_path / "enu.xyz", enu), "-o", tmp_path / "enu", "-q")[0] == 0
    if frame == "paper":
        rotation = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # rows: east, north, up
        options = ["--frame", "paper"]
    else:
        angle = np.radians(35.0)
        rotation = np.array([[np.cos(angle), np.sin(angle), 0.0], [-np.sin(angle), np.cos(angle), 0.0], [0, 0, 1.0]])
        options = ["--up", *map(str, rotation[2]), "--north", *map(str, rotation[1])]
    cloud = write_xyz(tmp_path / "turned.xyz", turned(rotation, enu))
    assert run_cli(capsys, "measure", cloud, "-o", tmp_path / "turned", "-q", *options)[0] == 0
    truth, found = dips_rows(tmp_path / "enu"), dips_rows(tmp_path / "turned")
    assert len(truth) >= 5
    for plane in truth:
        axial = np.abs((found[:, 0] - plane[0] + 180) % 360 - 180) + np.abs(found[:, 1] - plane[1])
        near = np.linalg.norm(found[:, 2:5] - plane[2:5], axis=1)
        best = np.argmin(axial + near)
        assert axial[best] < 2.0 and near[best] < 0.1, (plane, found[best])
