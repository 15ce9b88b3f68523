"""One workflow API (issue 44): ``measure_outcrop`` and ``OutcropRun.save`` do what
``geostructure measure --sets --kinematics`` does, automatic parameters included."""

import csv

import pytest
from conftest import shared_file
from helpers import run_cli, write_xyz

from geostructure import measure_outcrop
from geostructure.synthetic import outcrop_scene

SAME_FILES = ("planes.csv", "planes_dips.csv", "sets.csv", "joints.csv", "kinematics.csv", "regions.ply")


@pytest.mark.real_data
def test_the_api_finds_the_commands_planes_on_a_real_outcrop(tmp_path, capsys):
    """The README's API example, Params() and no automatic choice, found 0 planes on
    jfm_outcrop_test where the command found several, without a word."""
    cloud = shared_file("jfm_outcrop_test/test.txt")
    run = measure_outcrop(cloud)
    assert run.record["auto"] is not None and len(run.planes) >= 3
    run.save(tmp_path / "api")
    assert run_cli(capsys, "measure", cloud, "-o", tmp_path / "cli", "-q")[0] == 0
    assert (tmp_path / "api" / "planes.csv").read_bytes() == (tmp_path / "cli" / "planes.csv").read_bytes()


def test_the_api_writes_what_the_command_writes_with_sets_and_kinematics(tmp_path, capsys):
    cloud = write_xyz(tmp_path / "outcrop.xyz", outcrop_scene(width=8.0, height=5.0, seed=5).cloud.points)
    kinematics = {"friction": 30.0, "cohesion": 10.0}
    run = measure_outcrop(cloud, sets=True, kinematics=kinematics)
    assert len(run.sets) == 3 and run.kinematic_options["slope"] is not None
    paths = run.save(tmp_path / "api", report=True)
    assert run.kinematics and {"planes", "sets", "kinematics", "report"} <= set(paths)
    code, _, _ = run_cli(capsys, "measure", cloud, "-o", tmp_path / "cli", "-q", "--sets", "--kinematics",
                         "--friction", "30", "--cohesion", "10", "--report")  # fmt: skip
    assert code == 0
    for name in SAME_FILES:
        assert (tmp_path / "api" / name).read_bytes() == (tmp_path / "cli" / name).read_bytes(), name


def test_the_tables_are_dataframes(tmp_path):
    pytest.importorskip("pandas")
    run = measure_outcrop(outcrop_scene(width=6.0, height=4.0, seed=1).cloud, sets=True)
    tables = run.tables()
    assert len(tables["planes"]) == len(run.planes) and len(tables["sets"]) == len(run.sets)
    assert {"dip", "dip_direction", "set", "joint"} <= set(tables["planes"].columns)
    assert {"spacing_m", "flags", "persistence"} <= set(tables["sets"].columns)
    run.save(tmp_path / "o")
    written = list(csv.DictReader(open(tmp_path / "o" / "sets.csv")))
    assert [float(r["dip"]) for r in written] == pytest.approx(tables["sets"]["dip"].tolist(), abs=1e-9)


def test_the_streamed_workflow_writes_what_the_streamed_command_writes(tmp_path, capsys):
    from geostructure.workflows.survey import measure_survey

    cloud = write_xyz(tmp_path / "outcrop.xyz", outcrop_scene(width=6.0, height=4.0, seed=1).cloud.points)
    run = measure_survey([cloud], tmp_path / "api", engine="stream")  # chunks as the command sizes them by default
    assert len(run.result) > 5 and run.paths["planes"].name == "planes.csv"
    code, _, _ = run_cli(capsys, "measure", cloud, "-o", tmp_path / "cli", "-q", "--engine", "stream")
    assert code == 0
    for name in ("planes.csv", "regions.ply"):
        assert (tmp_path / "api" / name).read_bytes() == (tmp_path / "cli" / name).read_bytes(), name
