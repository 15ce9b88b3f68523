"""An output folder is a user's file (issue 53, items 4 and 6): a run.json or planes.csv
edited and resealed, or with its seal deleted, is refused in one sentence by every command
that reads the folder, and nothing in the folder changes."""

import json
import shutil

import pytest
from helpers import assert_one_sentence, folder_digests, run_cli, scene_points, write_xyz

from geostructure.io.outdir import SEAL, file_entry, sealed

ARGS = ["--no-auto", "--zeta", "0.015", "-q"]


@pytest.fixture(scope="module")
def measured(tmp_path_factory):
    from geostructure.cli import main

    tmp = tmp_path_factory.mktemp("edited")
    cloud = write_xyz(tmp / "scene.xyz", scene_points(20_000))
    assert main(["measure", str(cloud), "-o", str(tmp / "out"), *ARGS]) == 0
    return tmp / "out"


def resealed(folder, edit) -> None:
    """Edit run.json's values with ``edit(record)`` and seal it again, as a careful forger would."""
    path = folder / "run.json"
    record = json.loads(path.read_text())
    edit(record)
    path.write_text(json.dumps(sealed(record)))


def edited_planes(folder, column: str, value: str) -> None:
    """Set ``column`` of planes.csv's first row to ``value``, and make the manifest and the seal agree."""
    path = folder / "planes.csv"
    lines = path.read_text().splitlines()
    header = lines[0].split(",")
    row = lines[1].split(",")
    row[header.index(column)] = value
    lines[1] = ",".join(row)
    path.write_text("\n".join(lines) + "\n")
    resealed(folder, lambda r: r["outputs"].update({"planes.csv": file_entry(path)}))


def many_planes(folder) -> None:
    """planes.csv grown to more rows than the folder's 20,000 points can make (a plane holds 3)."""
    path = folder / "planes.csv"
    lines = path.read_text().splitlines()
    path.write_text("\n".join([lines[0]] + [lines[1]] * 6_700) + "\n")
    resealed(folder, lambda r: r["outputs"].update({"planes.csv": file_entry(path)}))


CASES = {
    "offset of text": lambda f: resealed(f, lambda r: r.update(offset=["a", 0, 0])),
    "huge offset": lambda f: resealed(f, lambda r: r.update(offset=[1e300, 0, 0])),
    "params as a list": lambda f: resealed(f, lambda r: r.update(params=[1, 2, 3])),
    "unit with a payload": lambda f: resealed(f, lambda r: r.update(unit=[["symbol", "<script>"]])),
    "frame unreadable": lambda f: resealed(f, lambda r: r.update(frame={"rotation": "north"})),
    "seal deleted": lambda f: resealed(f, lambda r: None) or _unsealed(f),
    "dip of 200": lambda f: edited_planes(f, "dip", "200"),
    "more planes than points": many_planes,
}


def _unsealed(folder) -> None:
    path = folder / "run.json"
    record = json.loads(path.read_text())
    record.pop(SEAL)
    path.write_text(json.dumps(record))


@pytest.mark.parametrize("case", sorted(CASES))
@pytest.mark.parametrize("command", ["sets", "kinematics", "report"])
def test_an_edited_folder_is_refused_in_one_sentence(measured, tmp_path, capsys, case, command):
    folder = tmp_path / "out"
    shutil.copytree(measured, folder)
    CASES[case](folder)
    before = folder_digests(folder)
    extra = ["--friction", "30"] if command == "kinematics" else []
    code, _, err = run_cli(capsys, command, folder, *extra, "-q")
    assert code == 2, (case, err)
    assert_one_sentence(err, folder)
    assert folder_digests(folder) == before
