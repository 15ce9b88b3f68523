import csv
import hashlib
import subprocess
import sys

import numpy as np
import pytest
from helpers import write_ply

from geostructure.cli import main
from geostructure.core.planes import PLANE_COLUMNS


def digest(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


def assert_user_error(capsys, tmp_path, path, *expected):
    outdir = tmp_path / "out"
    before = digest(path) if path.exists() and path.is_file() else None
    code = main(["measure", str(path), "-o", str(outdir), "-q"])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert "Traceback" not in err and len(err.splitlines()) == 1, err
    assert str(path.name) in err
    for word in expected:
        assert word in err, err
    assert not (outdir / "planes.csv").exists()
    if before is not None:
        assert digest(path) == before  # the input is never modified


@pytest.fixture
def good_ply(tmp_path):
    from geostructure.synthetic import observatory_scene

    scene = observatory_scene(40_000, seed=2)
    path = tmp_path / "scene.ply"
    write_ply(path, scene.cloud.points, text=False)
    return path


def test_measure_writes_the_contract(tmp_path, good_ply, capsys):
    from plyfile import PlyData

    before = digest(good_ply)
    assert main(["measure", str(good_ply), "-o", str(tmp_path / "out"), "--zeta", "0.02"]) == 0
    out = capsys.readouterr().out
    assert "strike" in out and "planes from" in out
    rows = list(csv.reader(open(tmp_path / "out" / "planes.csv")))
    assert tuple(rows[0][: len(PLANE_COLUMNS)]) == PLANE_COLUMNS
    sizes = [int(r[1]) for r in rows[1:]]
    assert len(sizes) >= 6 and sizes == sorted(sizes, reverse=True)
    ply = PlyData.read(str(tmp_path / "out" / "regions.ply"))
    region_id = ply["vertex"]["scalar_region_id"]  # the name CloudCompare's batch reader loads
    assert region_id.dtype.kind == "i" and region_id.min() == -1 and region_id.max() == len(sizes) - 1
    assert ply["vertex"]["x"].dtype == np.float64
    import json

    run = json.loads((tmp_path / "out" / "run.json").read_text())
    assert run["params"]["zeta"] == 0.02 and run["counts"]["planes"] == len(sizes)
    assert set(run["seconds"]) >= {"read", "filter", "voxel", "regions", "planes"}
    assert digest(good_ply) == before
    assert not list((tmp_path / "out").glob(".*tmp"))


def test_missing_file(capsys, tmp_path):
    assert_user_error(capsys, tmp_path, tmp_path / "nope.ply", "no such file")


def test_unknown_extension(capsys, tmp_path):
    path = tmp_path / "cloud.obj"
    path.write_text("v 0 0 0\n")
    assert_user_error(capsys, tmp_path, path, "unknown extension")


@pytest.mark.parametrize("name", ["empty.ply", "empty.las", "empty.xyz", "empty.e57"])
def test_empty_file(capsys, tmp_path, name):
    path = tmp_path / name
    path.write_bytes(b"")
    assert_user_error(capsys, tmp_path, path, "empty")


def test_truncated_binary_ply(capsys, tmp_path, good_ply):
    data = good_ply.read_bytes()
    path = tmp_path / "cut.ply"
    path.write_bytes(data[: len(data) // 2])
    assert_user_error(capsys, tmp_path, path, "truncated")


def test_ascii_ply_promising_more_points_than_it_holds(capsys, tmp_path):
    path = tmp_path / "short.ply"
    path.write_text(
        "ply\nformat ascii 1.0\nelement vertex 10\nproperty float x\nproperty float y\n"
        "property float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n"
    )
    assert_user_error(capsys, tmp_path, path)


def make_las(path, n=1000):
    import laspy

    las = laspy.LasData(laspy.LasHeader(point_format=3, version="1.2"))
    rng = np.random.default_rng(0)
    las.x, las.y, las.z = (rng.random((n, 3)) * 10).T
    las.write(str(path))


@pytest.mark.parametrize("suffix", [".las", ".laz"])
def test_truncated_las(capsys, tmp_path, suffix):
    full = tmp_path / f"full{suffix}"
    make_las(full)
    data = full.read_bytes()
    path = tmp_path / f"cut{suffix}"
    path.write_bytes(data[: int(len(data) * 0.6)])
    assert_user_error(capsys, tmp_path, path)


def test_las_header_promising_more_points(capsys, tmp_path):
    path = tmp_path / "liar.las"
    make_las(path)
    data = bytearray(path.read_bytes())
    data[107:111] = (5000).to_bytes(4, "little")  # legacy point count in a LAS 1.2 header
    path.write_bytes(bytes(data))
    assert_user_error(capsys, tmp_path, path)


@pytest.mark.parametrize("scale", [0.0, float("nan")])
def test_las_header_with_a_scale_of_zero(capsys, tmp_path, scale):
    """A damaged x scale of 0 put every point at x = offset: measured, exit 0, with an
    internal divide-by-zero warning from the LAZ writer."""
    import struct

    path = tmp_path / "flat.las"
    make_las(path)
    data = bytearray(path.read_bytes())
    data[131:139] = struct.pack("<d", scale)  # the x scale
    path.write_bytes(bytes(data))
    assert_user_error(capsys, tmp_path, path, "the x scale is")


def test_nan_coordinates(capsys, tmp_path):
    path = tmp_path / "nan.xyz"
    path.write_text("0 0 0\n1 0 0\nnan 1 0\n0 1 1\n")
    assert_user_error(capsys, tmp_path, path, "NaN")


def test_infinite_coordinates_in_ply(capsys, tmp_path):
    path = tmp_path / "inf.ply"
    write_ply(path, np.array([[0, 0, 0], [1, 0, 0], [np.inf, 1, 0], [0, 1, 1.0]]), text=False)
    assert_user_error(capsys, tmp_path, path, "infinite")


def test_non_numeric_field_names_the_line(capsys, tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text("x,y,z\n0,0,0\n1,0,0\n0,one,0\n")
    assert_user_error(capsys, tmp_path, path, "line 4", "'one'")


def test_too_few_points(capsys, tmp_path):
    path = tmp_path / "two.xyz"
    path.write_text("0 0 0\n1 1 1\n")
    assert_user_error(capsys, tmp_path, path, "at least 3")


def test_points_on_one_line(capsys, tmp_path):
    path = tmp_path / "line.xyz"
    path.write_text("".join(f"{t} {2 * t} {3 * t}\n" for t in range(100)))
    assert_user_error(capsys, tmp_path, path, "one line")


def test_points_at_one_spot(capsys, tmp_path):
    path = tmp_path / "spot.xyz"
    path.write_text("5 5 5\n" * 20)
    assert_user_error(capsys, tmp_path, path, "one spot")


def test_not_a_ply(capsys, tmp_path):
    path = tmp_path / "fake.ply"
    path.write_text("hello\n")
    assert_user_error(capsys, tmp_path, path, "not a PLY")


def test_binary_garbage_as_text(capsys, tmp_path):
    path = tmp_path / "garbage.xyz"
    path.write_bytes(bytes(range(256)) * 4)
    assert_user_error(capsys, tmp_path, path)


def test_bad_parameter_is_one_sentence(capsys, tmp_path, good_ply):
    code = main(["measure", str(good_ply), "-o", str(tmp_path / "o"), "--zeta", "-1", "-q"])
    err = capsys.readouterr().err
    assert code == 2 and "zeta" in err and "Traceback" not in err
    assert not (tmp_path / "o" / "planes.csv").exists()


@pytest.mark.parametrize(
    "argv, said",
    [
        (["measure", "cloud.ply"], "the following arguments are required: -o/--outdir"),
        (["measure", "cloud.ply", "-o", "o", "--n-sets", "0"], "argument --n-sets: 0 is less than 1"),
        (["measur", "cloud.ply"], "invalid choice: 'measur'"),
        (["measure", "cloud.ply", "-o", "o", "--no-report"], "unrecognized arguments: --no-report"),
        (["--nothing"], "unrecognized arguments: --nothing"),
    ],
)
def test_an_option_slip_is_one_line_that_says_where_to_read_more(capsys, argv, said):
    """argparse printed the whole usage (25 lines for measure) above the line that says what
    is wrong: now that line alone, and the command's --help."""
    with pytest.raises(SystemExit) as stop:
        main(argv)
    err = capsys.readouterr().err
    assert stop.value.code == 2 and err.count("\n") == 1 and said in err
    command = "geostructure measure" if argv[0] == "measure" else "geostructure"
    assert err.startswith(f"{command}: error: ") and err.endswith(f"see '{command} --help'.\n")


@pytest.mark.parametrize("value", ["400", "-181"])
def test_a_declination_beyond_half_a_turn_is_refused(capsys, tmp_path, good_ply, value):
    """400 degrees was read as 40 without a word: a slip, not a declination."""
    with pytest.raises(SystemExit) as stop:
        main(["measure", str(good_ply), "-o", str(tmp_path / "o"), "--declination", value, "-q"])
    err = capsys.readouterr().err
    assert stop.value.code == 2 and "is not a declination" in err and not (tmp_path / "o").exists()


def test_python_dash_m_runs_the_demo(tmp_path):
    run = subprocess.run(
        [sys.executable, "-m", "geostructure", "demo", "-o", str(tmp_path / "demo"), "--points", "60000"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert run.returncode == 0, run.stderr
    assert "6 of 6 surfaces found" in run.stdout
    assert (tmp_path / "demo" / "planes.csv").exists()


def test_python_dash_m_bad_input_exit_status(tmp_path):
    run = subprocess.run(
        [sys.executable, "-m", "geostructure", "measure", str(tmp_path / "missing.laz"), "-o", str(tmp_path / "o")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert run.returncode == 2 and "Traceback" not in run.stderr and "missing.laz" in run.stderr


def test_a_control_character_quoted_from_a_file_stays_on_the_error_s_line(tmp_path, capsys):
    """A vertical tab inside a number (the fuzz tests at a larger scale): the message quoted
    it raw, and the terminal (and splitlines) broke the one-line error in two."""
    from helpers import assert_one_sentence, run_cli

    path = tmp_path / "scan.csv"
    path.write_text("x,y,z\n5\x0b0006.3,4600002.6,100.0\n" + "500001.0,4600003.0,100.1\n" * 5)
    code, _, err = run_cli(capsys, "measure", path, "-o", tmp_path / "out", "-q")
    assert code == 2
    assert_one_sentence(err, "scan.csv", "line 2 holds a control character (\\x0b)")
