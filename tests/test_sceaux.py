"""Sceaux Castle end to end (../shared/data/sceaux_castle, 11 photos): the main facade is one plane.

The set has no control points or GPS, so the run takes up from the cameras (--assume-level):
dips are approximate and azimuths are relative to the view, but the facade's walls must be
near vertical, share one orientation, and the recessed main wall, split in two by the
projecting entrance bay, must come out as one plane with its fit residual.
"""
import csv
import json

import numpy as np
import pytest
from conftest import shared_file

from geostructure.cli import main


def read_planes(out):
    with open(out / "planes.csv") as fh:
        return [{k: float(v) for k, v in row.items()} for row in csv.DictReader(fh)]


@pytest.fixture(scope="module")
def sceaux_dir(tmp_path_factory):
    images = shared_file("sceaux_castle/images")
    out = tmp_path_factory.mktemp("sceaux")
    assert main(["run", str(images), "-o", str(out), "--assume-level", "-q", "--no-report"]) == 0
    return out


@pytest.fixture(scope="module")
def sceaux(sceaux_dir):
    return read_planes(sceaux_dir)


def length(plane):
    return max(plane["rect_width"], plane["rect_height"])


def test_the_main_facade_is_one_plane_with_its_residual(sceaux):
    facade = sceaux[0]  # the largest plane
    assert facade["dip"] > 85.0                            # measured 88.1: a wall, up from the cameras
    assert facade["fit_residual"] < 0.03                   # measured 0.012 model units
    walls = [p for p in sceaux if p["n_points"] > 1000 and p["dip"] > 80
             and abs((p["dip_direction"] - facade["dip_direction"] + 180) % 360 - 180) < 5]
    assert len(walls) >= 3                                 # the main wall, the two pavilions, the bay
    # the main wall spans the entrance bay: its rectangle is wider than any pavilion's and its
    # centre sits at the bay (x near the middle of the facade's walls)
    assert length(facade) > 1.8 * max(length(p) for p in walls[1:])   # measured 6.1 against 2.8
    xs = [p["rect_center_x"] for p in walls]
    assert min(xs) < facade["rect_center_x"] < max(xs)
    orientation = np.array([[p["dip"], p["dip_direction"]] for p in walls])
    assert np.ptp(orientation, axis=0).max() < 2.5        # one orientation for all the facade's walls


def test_without_the_coplanar_merge_the_main_wall_is_split(sceaux, sceaux_dir, tmp_path):
    """The paper's regions (--no-merge) on the same cloud: the bay cuts the main wall in two."""
    params = [f"--{k}={v}" for k, v in json.loads((sceaux_dir / "run.json").read_text())["params"].items()
              if k in ("zeta", "theta", "psi", "k")]
    assert main(["measure", str(sceaux_dir / "cloud.ply"), "-o", str(tmp_path), "--no-merge", "-q", *params]) == 0
    split = read_planes(tmp_path)
    assert length(split[0]) < 0.6 * length(sceaux[0])     # measured 2.8 against 6.1
