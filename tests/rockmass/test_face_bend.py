"""A face that turns along its strike (a road cut's bend, a quarry's corner): one mean face
stands for none of its parts, and the sets and the kinematic tests say so."""

import json

import numpy as np
import pytest
from helpers import run_cli, turned_faces, write_xyz

from geostructure.rockmass.exposure import BENT_FACE, face_bend
from geostructure.synthetic import outcrop_scene


@pytest.mark.parametrize("turn", [20.0, 40.0, 90.0])
def test_the_bend_of_two_faces_is_their_turn(turn):
    bend = face_bend(turned_faces(turn))
    assert bend == pytest.approx(turn, abs=0.25 * turn)  # 90 reads 76: its thirds reach round the corner


def test_flat_faces_and_terrains_do_not_bend():
    # Flat but stepped by their joints: at most 15.4 degrees on 29 faces of 12 x 6 to 40 x 16 m.
    for seed in (5, 11):  # the two that read most (14.0 and 15.4)
        assert face_bend(outcrop_scene(width=12.0, height=6.0, seed=seed).cloud.points) < BENT_FACE
    rng = np.random.default_rng(0)
    ground = np.column_stack([rng.random((5000, 2)) * [400.0, 150.0], rng.normal(0.0, 2.0, 5000)])
    assert face_bend(ground) == 0.0  # an airborne survey has no trace on the map to turn


def test_a_corner_records_its_bend(tmp_path, capsys):
    """Two faces dipping 75 degrees and turned 40 degrees: the mean face dips 65, which no
    part has; at 90 degrees it dips 8. The bend is recorded, and the sets and the kinematic
    tests take the face in sections (tests/test_sections.py)."""
    path = write_xyz(tmp_path / "corner.xyz", turned_faces(40.0))
    out = tmp_path / "out"
    code, _, err = run_cli(
        capsys, "measure", str(path), "-o", str(out), "-q", "--sets", "--kinematics", "--friction", "30"
    )
    assert code == 0
    err = " ".join(err.split())
    assert "warning" not in err, err  # measured and tested in sections (tests/test_sections.py)
    run = json.loads((out / "run.json").read_text())
    assert run["sets"]["rock_mass"]["face_bend_deg"] > BENT_FACE and run["sets"]["rock_mass"]["face_sections"] == 2
    slope = json.loads((out / "kinematics.json").read_text())["slope"]
    assert slope["face_bend_deg"] > BENT_FACE and slope["source"] == "fitted" and slope["sections"] == 2
    # a flat face of the same size says nothing of it
    path = write_xyz(tmp_path / "flat.xyz", turned_faces(0.0))
    code, _, err = run_cli(capsys, "measure", str(path), "-o", str(tmp_path / "flat"), "-q", "--sets", "--kinematics",
                           "--friction", "30")  # fmt: skip
    assert code == 0 and "turns by" not in err
