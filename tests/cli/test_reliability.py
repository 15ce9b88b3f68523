"""The reliability issue's defects, one test each (numbered as in the issue): nothing lost,
nothing silently wrong, and every bad input one sentence with exit status 2."""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from helpers import assert_one_sentence, digest, folder_digests, run_cli, scene_points, write_xyz

from geostructure import Cloud, Frame, GeoStructureError, measure
from geostructure.errors import InputError, OutputError, ParameterError
from geostructure.io.atomic import json_text
from geostructure.io.outdir import output_set, verified_record
from geostructure.io.planetable import read_planes_csv

FIXED = ["--no-auto", "--zeta", "0.02", "-q"]


@pytest.fixture(scope="module")
def cloud_file(tmp_path_factory):
    return write_xyz(tmp_path_factory.mktemp("cloud") / "scene.xyz", scene_points())


@pytest.fixture
def measured(tmp_path, cloud_file, capsys):
    out = tmp_path / "out"
    code, _, err = run_cli(capsys, "measure", cloud_file, "-o", out, *FIXED)
    assert code == 0, err
    return out


# 1. The input is never overwritten, even when it lies in OUTDIR under an output's name.
@pytest.mark.parametrize("name", ["regions.ply", "voxel_planes.ply", "planes.csv"])
def test_an_input_that_is_an_output_is_refused_before_any_work(measured, capsys, name):
    source = measured / name
    if name == "planes.csv":  # a text cloud that happens to carry the name
        write_xyz(source, scene_points(3000, seed=1), delimiter=",")
    before = folder_digests(measured)
    code, _, err = run_cli(capsys, "measure", source, "-o", measured, "-q")
    assert code == 2
    assert_one_sentence(err, name)
    assert folder_digests(measured) == before


def test_a_truth_file_that_is_an_output_is_refused(measured, capsys, cloud_file):
    truth = measured / "evaluation.csv"
    truth.write_text("surface,dip,dip_direction\na,40,90\n")
    code, _, err = run_cli(capsys, "measure", cloud_file, "-o", measured, "--truth", truth, "-q")
    assert code == 2 and "evaluation.csv" in err and truth.read_text().startswith("surface")


# 2. Non-finite frame values never reach the numbers; JSON is strict.
@pytest.mark.parametrize(
    "option",
    [
        ["--up", "nan", "0", "1", "--north", "0", "1", "0"],
        ["--up", "inf", "0", "1", "--north", "0", "1", "0"],
        ["--up", "0", "0", "1", "--north", "nan", "1", "0"],
        ["--declination", "nan"],
        ["--declination", "inf"],
        ["--zeta", "nan"],
        ["--theta", "inf"],
        ["--psi", "inf"],
        ["--sigma", "nan"],
    ],
)
def test_non_finite_options_exit_2_before_reading(tmp_path, capsys, option):
    with pytest.raises(SystemExit) as stop:
        run_cli(capsys, "measure", tmp_path / "missing.xyz", "-o", tmp_path / "out", *option)
    assert stop.value.code == 2
    assert "finite" in capsys.readouterr().err and not (tmp_path / "out").exists()


def test_the_api_refuses_non_finite_frames_and_parameters():
    with pytest.raises(ParameterError, match="declination"):
        Frame.named("enu", float("nan"))
    with pytest.raises(ParameterError, match="finite"):
        Frame.from_up_north([np.inf, 0, 1], [0, 1, 0])
    with pytest.raises(ParameterError, match="psi"):
        from geostructure import Params

        Params(psi=float("inf"))


def test_json_never_holds_nan():
    text = json_text({"a": float("nan"), "b": [np.float64("inf"), 1.5]})
    assert json.loads(text, parse_constant=lambda c: pytest.fail(f"{c} in JSON")) == {"a": None, "b": [None, 1.5]}


# 3. Coordinates round-trip float64: a cloud at a 1e7 offset gives the origin's centroids plus the offset.
def test_planes_csv_keeps_utm_precision(tmp_path, capsys):
    points = scene_points(20_000, seed=4)
    offset = np.array([1e7, 1e7, 1e3])
    rows = {}
    for name, shift in (("origin", np.zeros(3)), ("utm", offset)):
        path = write_xyz(tmp_path / f"{name}.xyz", points + shift)
        code, _, err = run_cli(capsys, "measure", path, "-o", tmp_path / name, *FIXED)
        assert code == 0, err
        rows[name] = list(csv.DictReader(open(tmp_path / name / "planes.csv")))
    assert len(rows["origin"]) == len(rows["utm"]) >= 6
    for a, b in zip(rows["origin"], rows["utm"]):
        for i, axis in enumerate("xyz"):
            assert float(b[f"centroid_{axis}"]) - offset[i] == pytest.approx(float(a[f"centroid_{axis}"]), abs=1e-6)


def test_the_automatic_choice_does_not_depend_on_where_the_cloud_sits(tmp_path, capsys):
    """With the default (automatic) parameters, groups of two points on the grid had a
    normal the rounding chose: at UTM and at (1.2e7, 1.3e7) a small plane came out with
    other points and its centroid moved tenths of a metre."""
    points = scene_points(20_000, seed=4)
    rows = {}
    for name, shift in (("origin", np.zeros(3)), ("utm", np.array([5e5 + 0.37, 5e6 + 0.81, 100.3])),
                        ("far", np.array([1.2e7, 1.3e7, 1e3]))):  # fmt: skip
        path = write_xyz(tmp_path / f"{name}.xyz", points + shift)
        code, _, err = run_cli(capsys, "measure", path, "-o", tmp_path / name, "-q")
        assert code == 0, err
        table = list(csv.DictReader(open(tmp_path / name / "planes.csv")))
        rows[name] = np.array([[float(r["n_points"])] + [float(r[f"centroid_{a}"]) for a in "xyz"] for r in table])
        rows[name][:, 1:] -= shift
    assert len(rows["origin"]) >= 7
    for name in ("utm", "far"):
        assert rows[name].shape == rows["origin"].shape
        assert np.array_equal(rows[name][:, 0], rows["origin"][:, 0])
        assert np.abs(rows[name][:, 1:] - rows["origin"][:, 1:]).max() < 1e-6


def test_regions_ply_gives_back_the_input_coordinates_bit_for_bit(tmp_path, capsys):
    from plyfile import PlyData

    points = scene_points(20_000, seed=5) + np.array([500_123.456789, 4_650_987.654321, 312.5])
    path = write_xyz(tmp_path / "utm.xyz", points)
    assert run_cli(capsys, "measure", path, "-o", tmp_path / "out", *FIXED)[0] == 0
    vertex = PlyData.read(str(tmp_path / "out" / "regions.ply"))["vertex"]
    written = np.column_stack([vertex["x"], vertex["y"], vertex["z"]])
    given = {tuple(p) for p in points.tolist()}
    assert all(tuple(p) in given for p in written.tolist())


# 5. A run owns its folder's outputs: it removes those of the previous set it did not make,
# and never a file it did not write.
def test_a_rerun_removes_the_previous_sets_stale_files_and_nothing_else(measured, capsys, cloud_file):
    assert run_cli(capsys, "report", measured, "-q")[0] == 0
    assert run_cli(capsys, "evaluate", measured, "--truth", _truth(measured.parent), "-q")[0] == 0
    (measured / "notes.txt").write_text("field notes")
    (measured / "rose.png").write_bytes(b"a figure the user redrew")  # no longer the file we wrote
    assert run_cli(capsys, "measure", cloud_file, "-o", measured, *FIXED)[0] == 0
    names = {p.name for p in measured.iterdir() if not p.name.startswith(".")}
    assert names == {  # no GIS files: the cloud has no CRS
        "planes.csv",
        "planes_dips.csv",
        "regions.ply",
        "regions.laz",
        "voxel_planes.ply",
        "voxel_planes.laz",
        "run.json",
        "notes.txt",
        "rose.png",
    }
    assert sorted(verified_record(measured)["outputs"]) == sorted(names - {"run.json", "notes.txt", "rose.png"})


def _truth(folder: Path) -> Path:
    path = folder / "truth.csv"
    path.write_text("surface,dip,dip_direction\nslope,40,89\n")
    return path


# 4 (the folder half). report and evaluate refuse a folder whose files are not one run's.
def test_report_and_evaluate_refuse_a_mixed_folder(measured, tmp_path, capsys, cloud_file):
    other = tmp_path / "other"
    points = scene_points(15_000, seed=9)
    assert run_cli(capsys, "measure", write_xyz(tmp_path / "b.xyz", points), "-o", other, *FIXED)[0] == 0
    (measured / "planes.csv").write_bytes((other / "planes.csv").read_bytes())
    before = folder_digests(measured)
    for argv in (["report", measured], ["evaluate", measured, "--truth", _truth(tmp_path)]):
        code, _, err = run_cli(capsys, *argv)
        assert code == 2
        assert_one_sentence(err, "planes.csv")
        assert folder_digests(measured) == before


def test_a_folder_without_a_manifest_is_not_trusted(measured, capsys):
    record = json.loads((measured / "run.json").read_text())
    del record["outputs"]
    sealed = dict(record)
    del record["record_sha256"]  # as an older GeoStructure wrote it, without its seal
    (measured / "run.json").write_text(json.dumps(record))
    code, _, err = run_cli(capsys, "report", measured)
    assert code == 2 and "has no seal" in err  # an unsealed record could be edited at will
    (measured / "run.json").write_text(json.dumps(sealed))  # the seal kept, the record edited
    code, _, err = run_cli(capsys, "report", measured)
    assert code == 2 and "was changed since GeoStructure wrote it" in err


# 6. Wrong shapes are refused at the API, never reshaped.
@pytest.mark.parametrize("shape", [(100, 4), (100, 2), (300,), (10, 3, 1)])
def test_cloud_refuses_wrong_shapes(shape):
    with pytest.raises(ParameterError, match=r"\(N, 3\)"):
        Cloud.from_points(np.zeros(shape))
    with pytest.raises(ParameterError, match=r"\(N, 3\)"):
        Cloud(np.zeros(shape))


def test_measure_on_an_array_says_what_to_pass_and_nan_is_the_files_error():
    with pytest.raises(ParameterError, match="Cloud.from_points"):
        measure(np.zeros((100, 3)))
    points = scene_points(5000)
    points[7, 1] = np.nan
    with pytest.raises(InputError, match="NaN or infinite coordinates"):
        measure(Cloud.from_points(points))
    with pytest.raises(ParameterError, match="real numbers"):
        Cloud.from_points(np.array([["a", "b", "c"]]))


# 7. Silently wrong values.
def test_a_byte_order_mark_does_not_cost_the_first_point(tmp_path):
    from geostructure import read_cloud

    points = scene_points(2000, seed=2)
    for delimiter in (" ", ","):
        cloud = read_cloud(write_xyz(tmp_path / f"bom{delimiter.strip()}.csv", points, delimiter=delimiter, bom=True))
        assert len(cloud) == 2000 and np.array_equal(cloud.points[0], points[0])


@pytest.mark.parametrize(
    "text, words",
    [
        ("surface,dip,dip,dip_direction\na,40,50,90\n", ["'dip'", "more than once"]),
        ("surface,dip,dip_direction\na,40,inf\n", ["dip_direction", "finite"]),
        ("surface,dip,strike\na,40,nan\n", ["strike", "finite"]),
        ("surface,dip,dip_direction,center_x,center_y,center_z\na,40,90,1,inf,2\n", ["center_y", "finite"]),
    ],
)
def test_truth_values_are_used_as_written_or_refused(tmp_path, text, words):
    from geostructure.io.truth import read_truth

    path = tmp_path / "truth.csv"
    path.write_text(text)
    with pytest.raises(InputError) as error:
        read_truth(path)
    assert all(w in str(error.value) for w in words), error.value


# 8. A non-ASCII file name.
def test_a_non_ascii_file_name_measures(tmp_path, capsys):
    from plyfile import PlyData

    path = write_xyz(tmp_path / "café.xyz", scene_points(8000))
    code, _, err = run_cli(capsys, "measure", path, "-o", tmp_path / "out", *FIXED)
    assert code == 0, err
    assert len(verified_record(tmp_path / "out")["outputs"]) == 6  # without a CRS, no GIS files
    assert "caf" in " ".join(PlyData.read(str(tmp_path / "out" / "regions.ply")).comments)


# 9. A full disk: one sentence naming the folder, and the previous set untouched.
def test_a_full_disk_leaves_the_previous_set(measured, cloud_file):
    before = folder_digests(measured)

    def small_files():  # the kernel refuses writes past 300 kB, as a full disk would
        import resource

        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (300_000, 300_000))

    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "geostructure",
            "measure",
            str(cloud_file),
            "-o",
            str(measured),
            "--no-auto",
            "--zeta",
            "0.03",
            "-q",
        ],
        capture_output=True,
        text=True,
        preexec_fn=small_files,
        timeout=300,
    )
    assert done.returncode == 2, done.stderr
    assert_one_sentence(done.stderr, str(measured), "holds what it held before")
    assert folder_digests(measured) == before


def test_a_full_disk_while_sets_rewrite_regions_laz_leaves_the_folder(tmp_path, capsys):
    """`sets OUTDIR` writes regions.laz again chunk by chunk through lazrs, which turned the
    write's own error (here a file size limit, as a full disk would) into its "IoError:
    Failed to call write", a traceback with exit 1. The write's error is now given back."""
    from geostructure.synthetic import outcrop_scene

    out = tmp_path / "out"
    cloud = write_xyz(tmp_path / "face.xyz", outcrop_scene(width=6.0, height=4.0, seed=1).cloud.points)
    assert run_cli(capsys, "measure", cloud, "-o", out, "-q")[0] == 0
    before, limit = folder_digests(out), (out / "regions.laz").stat().st_size // 2
    assert limit > max((out / name).stat().st_size for name in ("planes.csv", "planes_dips.csv"))

    def small_files():
        import resource

        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    done = subprocess.run([sys.executable, "-m", "geostructure", "sets", str(out), "-q"], capture_output=True,
                          text=True, preexec_fn=small_files, timeout=300)  # fmt: skip
    assert done.returncode == 2, done.stderr
    assert_one_sentence(done.stderr, str(out), "holds what it held before")
    assert folder_digests(out) == before


def test_no_space_left_during_staging_is_an_output_error(tmp_path):
    with pytest.raises(OutputError, match="No space left on device"):
        with output_set(tmp_path / "out") as outputs:
            outputs.path("planes.csv").write_text("partial")
            raise OSError(28, "No space left on device")
    assert not (tmp_path / "out").exists()  # the folder this run made goes with it
    (tmp_path / "kept").mkdir()  # one the user made stays, holding only the lock
    with pytest.raises(OutputError, match="No space left on device"):
        with output_set(tmp_path / "kept") as outputs:
            raise OSError(28, "No space left on device")
    assert sorted(p.name for p in (tmp_path / "kept").iterdir()) == [".geostructure-lock"]


def test_a_file_hashed_early_then_written_again_is_listed_as_written(tmp_path):
    # The point files are hashed as soon as written (OutputSet.hash_staged): a file written
    # again after that, even to the same size at once, must not keep the first hash.
    with output_set(tmp_path / "out") as outputs:
        for name in ("regions.ply", "regions.laz"):
            outputs.path(name).write_bytes(b"first")
            outputs.hash_staged(outputs.staging / name)
        tick = (outputs.staging / "regions.laz").stat().st_mtime_ns
        outputs.path("regions.laz").write_bytes(b"again")  # the same size,
        os.utime(outputs.staging / "regions.laz", ns=(tick, tick))  # within a coarse clock's same tick
    listed = verified_record(tmp_path / "out")["outputs"]
    assert listed["regions.laz"]["sha256"] == digest(tmp_path / "out" / "regions.laz")
    assert listed["regions.ply"]["sha256"] == digest(tmp_path / "out" / "regions.ply")


# 10. A truth CSV that is not UTF-8, for evaluate and measure --truth.
def test_truth_that_is_not_utf8(measured, tmp_path, capsys, cloud_file):
    truth = tmp_path / "latin1.csv"
    truth.write_bytes("surface,dip,dip_direction\nfalaise é,40,90\n".encode("latin-1"))
    for argv in (
        ["evaluate", measured, "--truth", truth],
        ["measure", cloud_file, "-o", tmp_path / "new", "--truth", truth, "-q"],
    ):
        code, _, err = run_cli(capsys, *argv)
        assert code == 2
        assert_one_sentence(err, "latin1.csv", "UTF-8")
    assert not (tmp_path / "new").exists()  # 16: checked before any measuring


# 11. A hand-edited planes.csv.
@pytest.mark.parametrize("content", [b"region_id,n_points\n0\n", b"\x00\xff\xfe binary \x89PNG\r\n"])
def test_a_damaged_planes_csv(measured, capsys, content):
    (measured / "planes.csv").write_bytes(content)
    for command in ("report", "evaluate"):
        extra = ["--truth", _truth(measured.parent)] if command == "evaluate" else []
        code, _, err = run_cli(capsys, command, measured, *extra)
        assert code == 2
        assert_one_sentence(err, "planes.csv")
    with pytest.raises(GeoStructureError, match="not a GeoStructure planes.csv"):
        read_planes_csv(measured / "planes.csv")


@pytest.mark.parametrize("name", ["planes.csv", "regions.laz"])
def test_sets_refuses_a_planes_csv_or_regions_laz_not_the_runs(measured, capsys, name):
    """`sets` writes planes.csv and regions.laz again, so it skipped their check, yet it reads
    both: a plane deleted by hand (or another run's file) went into the sets without a word,
    and came out as this run's."""
    path = measured / name
    if name == "planes.csv":
        path.write_text("".join(path.read_text().splitlines(keepends=True)[:-1]))  # one plane fewer
    else:
        data = path.read_bytes()
        path.write_bytes(data[:-1] + bytes([data[-1] ^ 0xFF]))  # its last byte flipped
    before = folder_digests(measured)
    code, _, err = run_cli(capsys, "sets", measured, "-q")
    assert code == 2
    assert_one_sentence(err, f"{name} is not the file run.json lists")
    assert folder_digests(measured) == before


# 12 and 16. run: bad control points found before any reconstruction.
@pytest.mark.parametrize("row", ["A,nan,2,3,1,1,1", "A,1,2,inf,1,1,1", "A,1,2"])
def test_run_checks_control_points_first(tmp_path, capsys, row):
    photos = tmp_path / "photos"
    photos.mkdir()
    gcp = tmp_path / "gcp.csv"
    gcp.write_text(f"name,E,N,Up,x,y,z\n{row}\nB,1,2,3,4,5,6\n")
    code, _, err = run_cli(capsys, "run", photos, "-o", tmp_path / "out", "--gcp", gcp, "-q")
    assert code == 2
    assert_one_sentence(err, "gcp.csv")
    assert not (tmp_path / "out").exists()


# 13. sweep ranges.
@pytest.mark.parametrize(
    "option, code", [(["--step", "nan"], "exit"), (["--end", "inf"], "exit"), (["--step", "1e-12"], 2)]
)
def test_sweep_refuses_impossible_ranges(tmp_path, capsys, option, code):
    argv = ["sweep", "--demo", "--factor", "zeta", "-o", tmp_path / "s", *option]
    if code == "exit":
        with pytest.raises(SystemExit) as stop:
            run_cli(capsys, *argv)
        assert stop.value.code == 2 and "finite" in capsys.readouterr().err
    else:
        status, _, err = run_cli(capsys, *argv)
        assert status == 2
        assert_one_sentence(err, "runs")
    assert not (tmp_path / "s").exists()


# 14. run without the reconstruction extra.
def test_run_without_pycolmap_names_the_extra(tmp_path, capsys, monkeypatch):
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "pycolmap" else real(name, *a))
    code, _, err = run_cli(capsys, "run", tmp_path, "-o", tmp_path / "out", "-q")
    assert code == 2
    assert_one_sentence(err, "pycolmap", "pip install 'geostructure[reconstruct]'")


# 15. No library warning reaches the user on tiny clouds.
@pytest.mark.parametrize(
    "points",
    [
        np.random.default_rng(0).random((10, 3)) * [1, 1, 0],
        np.random.default_rng(1).random((6, 3)) * [1, 1, 1e-3],
        np.random.default_rng(2).random((50, 3)),
        np.outer(np.arange(100.0), [1, 2, 3]),
    ],
)
def test_tiny_clouds_give_no_raw_warning(tmp_path, capsys, points):
    code, _, err = run_cli(capsys, "measure", write_xyz(tmp_path / "tiny.xyz", points), "-o", tmp_path / "o", "-q")
    assert code in (0, 2) and "internal warning" not in err and "Traceback" not in err, err
    if code == 2:
        assert_one_sentence(err, "tiny.xyz")


def test_a_header_only_csv_gives_no_loadtxt_warning(tmp_path, capsys):
    path = tmp_path / "header.csv"
    path.write_text("x,y,z\n")
    code, _, err = run_cli(capsys, "measure", path, "-o", tmp_path / "o")
    assert code == 2
    assert_one_sentence(err, "header.csv", "holds no points")


# 16. Cheap checks before expensive work.
def test_an_output_folder_that_is_a_file_is_refused_before_reading(tmp_path, capsys, cloud_file):
    target = tmp_path / "taken"
    target.write_text("a file")
    code, _, err = run_cli(capsys, "measure", tmp_path / "missing.xyz", "-o", target)
    assert code == 2
    assert_one_sentence(err, "taken", "is a file")


def test_an_output_folder_the_file_system_refuses_is_refused_before_reading(tmp_path, capsys, monkeypatch):
    # Root passes the permission bits where the file system refuses (/proc, a root-squashed
    # share): the refusal came when the results were written, after the whole measurement.
    import errno
    import tempfile

    def refuse(*args, **kwargs):
        raise OSError(errno.EROFS, "Read-only file system")

    monkeypatch.setattr(tempfile, "mkdtemp", refuse)
    code, _, err = run_cli(capsys, "measure", tmp_path / "missing.xyz", "-o", tmp_path / "new" / "out")
    assert code == 2
    assert_one_sentence(err, "new/out", "cannot be created in", "Read-only file system")
    assert not (tmp_path / "new").exists()


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="needs Linux's /proc")
def test_an_output_folder_under_proc_is_refused_before_reading(tmp_path, capsys):
    code, _, err = run_cli(capsys, "measure", tmp_path / "missing.xyz", "-o", "/proc/geostructure-out")
    assert code == 2
    assert_one_sentence(err, "/proc/geostructure-out", "cannot be created in /proc")


# 17. Clear messages.
@pytest.mark.parametrize(
    "argv, words",
    [
        (["measure", "x.xyz", "-o", "o", "--mesh-samples", "-5"], "--mesh-samples: -5 is less than 0"),
        (["frames", "v.mp4", "-o", "o", "--max-frames", "0"], "--max-frames: 0 is less than 1"),
        (["frames", "v.mp4", "-o", "o", "--min-motion", "-1"], "--min-motion: -1 is negative"),
    ],
)
def test_impossible_counts_are_refused_by_the_parser(capsys, argv, words):
    with pytest.raises(SystemExit) as stop:
        run_cli(capsys, *argv)
    assert stop.value.code == 2 and words in capsys.readouterr().err


@pytest.mark.parametrize("command", ["measure", "frames", "run"])
def test_an_empty_output_folder_name_is_refused(capsys, command):
    with pytest.raises(SystemExit) as stop:
        run_cli(capsys, command, "input.xyz", "-o", "")
    assert stop.value.code == 2 and "the output folder's name is empty" in capsys.readouterr().err


def test_frames_on_a_missing_file_says_so(tmp_path, capsys):
    code, _, err = run_cli(capsys, "frames", tmp_path / "gone.mp4", "-o", tmp_path / "f")
    assert code == 2
    assert_one_sentence(err, "gone.mp4", "no such file")


def test_random_bytes_named_jpg_are_named_before_sfm(tmp_path, capsys):
    photos = tmp_path / "photos"
    photos.mkdir()
    for i in range(3):
        (photos / f"img{i}.jpg").write_bytes(os.urandom(2000))
    code, _, err = run_cli(capsys, "run", photos, "-o", tmp_path / "out", "--assume-level", "-q")
    assert code == 2
    assert_one_sentence(err, "img0.jpg", "not an image")
    assert not (tmp_path / "out").exists()


def test_an_out_of_range_value_is_warned_about_once(tmp_path, capsys, cloud_file):
    code, _, err = run_cli(capsys, "measure", cloud_file, "-o", tmp_path / "o", "--theta", "45", "-q")
    assert code == 0 and err.count("theta=45.0 is outside") == 1, err


def test_every_command_leaves_no_partial_output_on_bad_input(tmp_path, capsys):
    bad = tmp_path / "bad.xyz"
    bad.write_text("1 2 3\n4 five 6\n")
    before = digest(bad)
    code, _, err = run_cli(capsys, "measure", bad, "-o", tmp_path / "out")
    assert code == 2
    assert_one_sentence(err, "bad.xyz", "line 2")
    assert not (tmp_path / "out").exists() and digest(bad) == before


def test_clouds_whose_axes_have_different_units_are_refused_before_reading(tmp_path, capsys):
    """A LAS whose CRS is geographic (EPSG:4326): x and y in degrees, z in metres. Measured,
    it gave dips of a cloud squeezed 80,000 times across and a traceback; now one sentence,
    exit 2, no output, in memory and streamed, and the same for --crs, and for a compound
    CRS with positions in feet and heights in metres."""
    import laspy
    from pyproj import CRS

    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales, header.offsets = [1e-7, 1e-7, 1e-3], [-123.0, 44.0, 0.0]
    header.add_crs(CRS.from_epsg(4326))
    las = laspy.LasData(header)
    rng = np.random.default_rng(0)
    las.x, las.y, las.z = -123 + rng.random(500) * 1e-4, 44 + rng.random(500) * 1e-4, 100 + rng.random(500)
    path = tmp_path / "wgs84.laz"
    las.write(str(path))
    for engine in ("memory", "stream"):
        code, _, err = run_cli(capsys, "measure", path, "-o", tmp_path / engine, "--engine", engine)
        assert code == 2 and "geographic" in err and not (tmp_path / engine).exists()
        assert_one_sentence(err, path)
    code, _, err = run_cli(capsys, "measure", path, "-o", tmp_path / "given", "--crs", "EPSG:4326")
    assert code == 2 and "--crs EPSG:4326" in err and "geographic" in err and not (tmp_path / "given").exists()
    # feet across, metres up (a State Plane with NAVD88 heights): every dip would be off
    code, _, err = run_cli(capsys, "measure", path, "-o", tmp_path / "mixed", "--crs", "EPSG:2992+5703")
    assert code == 2 and "heights in metre and positions in foot" in err and not (tmp_path / "mixed").exists()


@pytest.mark.parametrize("detector", ["facets", "voxel"])
def test_a_cloud_along_a_line_gives_no_plane_and_no_traceback(tmp_path, capsys, detector):
    """Points along a thin line (a pole, a cable): its voxels lie in no region, which once
    indexed an empty table in the facets' merge (IndexError); the voxel fit took its voxels
    for planes of arbitrary azimuth (four of them)."""
    rng = np.random.default_rng(0)
    points = np.c_[rng.random(20_000) * 1e-4, rng.random(20_000) * 1e-4, rng.random(20_000) * 5.0]
    path = tmp_path / "line.xyz"
    np.savetxt(path, points)
    code, _, err = run_cli(capsys, "measure", path, "-o", tmp_path / "out", "-q", "--detector", detector)
    assert code == 0 and "Traceback" not in err and "no plane found" in err


@pytest.mark.parametrize("engine", ["memory", "stream"])
def test_no_plane_because_of_min_points_says_so(cloud_file, tmp_path, capsys, engine):
    """Planes there, but none as large as --min-points asks: the advice named flatness,
    vegetation and noise (none of them the cause) and not the option the user set."""
    code, _, err = run_cli(capsys, "measure", cloud_file, "-o", tmp_path / "o", "-q", "--min-points", "1000000",
                           "--engine", engine)  # fmt: skip
    assert code == 0 and "no plane found of 1,000,000 points or more (--min-points)" in err, err
    assert "vegetation" not in err


def _outcrop_file(tmp_path, name, *, float32="", las_scale=None):
    """A 6 x 4 m synthetic outcrop (2.5 cm spacing) at UTM coordinates, as a PLY whose axes
    ``float32`` (some of "xyz") are 32-bit floats, or a LAS with the given scale."""
    import laspy
    from plyfile import PlyData, PlyElement

    from geostructure.synthetic import outcrop_scene

    points = outcrop_scene(width=6.0, height=4.0, seed=1, offset=(657_500.0, 4_984_000.0, 300.0)).cloud.points
    path = tmp_path / name
    if float32:
        vertex = np.empty(len(points), dtype=[(a, "f4" if a in float32 else "f8") for a in "xyz"])
        vertex["x"], vertex["y"], vertex["z"] = points.T
        PlyData([PlyElement.describe(vertex, "vertex")], text=False).write(str(path))
    else:
        header = laspy.LasHeader(point_format=6, version="1.4")
        header.scales, header.offsets = [las_scale] * 3, [657_000.0, 4_984_000.0, 0.0]
        las = laspy.LasData(header)
        las.x, las.y, las.z = points.T
        las.write(str(path))
    return path


def test_coordinates_stored_coarser_than_the_points_are_refused_or_warned_of(tmp_path, capsys):
    """32-bit floats at a UTM northing round to 0.5 m, 13 times the outcrop's 2.5 cm spacing:
    measured, every point sat on one of a few planes y = const and the run reported those,
    exit 0. Now one sentence, exit 2, no output. A LAS stored to 1 cm (0.4 spacings) is
    measured with a warning of the noise it adds; one stored to 1 mm, and doubles with 32-bit
    heights, without."""
    coarse = _outcrop_file(tmp_path, "float32.ply", float32="xyz")
    code, _, err = run_cli(capsys, "measure", coarse, "-o", tmp_path / "f32", "-q")
    assert code == 2 and "32-bit floats" in err and "steps of 0.5" in err and not (tmp_path / "f32").exists()
    assert_one_sentence(err, coarse)
    heights = _outcrop_file(tmp_path, "heights32.ply", float32="z")  # 32-bit heights of 300 m: 3e-5 steps
    code, _, err = run_cli(capsys, "measure", heights, "-o", tmp_path / "z32", "-q")
    assert code == 0 and "warning" not in err
    for scale, warned in ((0.01, True), (0.001, False)):
        path = _outcrop_file(tmp_path, f"scale_{scale}.las", las_scale=scale)
        code, _, err = run_cli(capsys, "measure", path, "-o", tmp_path / f"las_{scale}", "-q")
        assert code == 0 and ("geostructure: warning:" in err and "noise of about 0.0029" in err) == warned, err


def test_integer_ply_coordinates_are_judged_by_their_step_of_one(tmp_path, capsys):
    """Integer PLY axes step by 1: in millimetres a 2.5 cm outcrop is measured quietly; in
    metres it is a lattice of 1 m and refused (it was measured on that lattice, exit 0)."""
    from plyfile import PlyData, PlyElement

    from geostructure.synthetic import outcrop_scene

    points = outcrop_scene(width=6.0, height=4.0, seed=1).cloud.points
    for name, factor, refused in (("mm.ply", 1000.0, False), ("m.ply", 1.0, True)):
        vertex = np.empty(len(points), dtype=[(a, "i4") for a in "xyz"])
        vertex["x"], vertex["y"], vertex["z"] = np.round(points * factor).T
        PlyData([PlyElement.describe(vertex, "vertex")], text=False).write(str(tmp_path / name))
        code, _, err = run_cli(capsys, "measure", tmp_path / name, "-o", tmp_path / name[:-4], "-q")
        assert (
            (code == 2 and "stored as integers, in steps of 1," in err)
            if refused
            else code == 0 and "warning" not in err
        ), err


def test_streamed_coordinates_stored_coarser_than_the_points_are_refused_or_warned_of(tmp_path, capsys):
    """The same check streamed, where each file is judged on its first chunk: the 32-bit
    UTM PLY is refused (it used to be measured on its rounding grid, exit 0), the 1 cm LAS
    warned of, the 1 mm LAS measured without a word."""
    coarse = _outcrop_file(tmp_path, "float32.ply", float32="xyz")
    code, _, err = run_cli(capsys, "measure", coarse, "-o", tmp_path / "f32", "-q", "--engine", "stream")
    assert code == 2 and "32-bit floats" in err and "steps of 0.5" in err and not (tmp_path / "f32").exists()
    assert_one_sentence(err, coarse)
    for scale, warned in ((0.01, True), (0.001, False)):
        path = _outcrop_file(tmp_path, f"scale_{scale}.las", las_scale=scale)
        code, _, err = run_cli(capsys, "measure", path, "-o", tmp_path / f"las_{scale}", "-q", "--engine", "stream")
        assert code == 0 and ("geostructure: warning:" in err and "noise of about 0.0029" in err) == warned, err
    # tiles stored in one step: judged once, one warning for the survey
    tiles = tmp_path / "tiles"
    tiles.mkdir()
    for name in ("a.las", "b.las"):
        (tiles / name).write_bytes((tmp_path / "scale_0.01.las").read_bytes())
    code, _, err = run_cli(capsys, "measure", tiles, "-o", tmp_path / "tiled", "-q", "--engine", "stream")
    assert code == 0 and err.count("noise of about 0.0029") == 1, err


@pytest.mark.parametrize("engine", ["memory", "stream"])
def test_points_a_las_marks_withheld_or_noise_are_not_measured(tmp_path, capsys, engine):
    """A classified LiDAR tile: its noise (class 7, stray returns 5 m off the face) and its
    withheld points (a copy 50 m above) were measured with the rest. They are left out, the
    command says how many in a note (none under -q), and run.json counts the points kept."""
    import laspy

    path = _outcrop_file(tmp_path, "face.las", las_scale=0.001)
    las = laspy.read(str(path))
    n = len(las.points)
    rng = np.random.default_rng(0)
    face = np.column_stack([las.x, las.y, las.z])
    marked = laspy.LasData(las.header)
    marked.x, marked.y, marked.z = np.vstack([face, face[:200] + rng.normal(0, 5, (200, 3)), face[:300] + [0, 0, 50]]).T
    marked.classification = np.r_[np.full(n, 1), np.full(200, 7), np.full(300, 1)].astype(np.uint8)
    marked.withheld = np.r_[np.zeros(n + 200, bool), np.ones(300, bool)]
    marked.write(str(tmp_path / "marked.las"))
    code, _, err = run_cli(capsys, "measure", tmp_path / "marked.las", "-o", tmp_path / "o", "--engine", engine)
    assert (
        code == 0
        and "note: " in err
        and "500 point(s) left out, as the file marks them: 300 withheld, 200 noise" in err
    )
    record = json.loads((tmp_path / "o" / "run.json").read_text())
    assert record["counts"]["input"] == n and record["left_out"] == {"withheld": 300, "noise": 200}
    code, _, err = run_cli(capsys, "measure", tmp_path / "marked.las", "-o", tmp_path / "q", "-q", "--engine", engine)
    assert code == 0 and "left out" not in err


def test_a_cloud_of_repeated_points_is_measured_as_its_distinct_points(tmp_path, capsys):
    """Merged copies of one scan: every point written ten times. Each point's 8th neighbour
    was a copy of itself, the point spacing read 0, and the facet detector's grid of edge 0
    ended in an IndexError traceback. Now the copies are left out as the file is read
    (and the spacing would be the distinct points' in any case), and the planes are the
    single copy's."""
    from geostructure.synthetic import outcrop_scene

    points = outcrop_scene(width=4.0, height=3.0, seed=1).cloud.points
    once, repeated = write_xyz(tmp_path / "once.xyz", points), write_xyz(tmp_path / "ten.xyz", np.repeat(points, 10, 0))
    counts = {}
    for name, path in (("once", once), ("ten", repeated)):
        code, _, err = run_cli(capsys, "measure", path, "-o", tmp_path / name, "-q")
        assert code == 0 and "Traceback" not in err and "internal warning" not in err, err
        record = json.loads((tmp_path / name / "run.json").read_text())
        counts[name] = (record["counts"]["planes"], record["detection"]["facet_thresholds"]["spacing"])
    assert counts["ten"][1] == pytest.approx(counts["once"][1], rel=0.02)
    assert abs(counts["ten"][0] - counts["once"][0]) <= 0.15 * counts["once"][0], counts


def test_a_cloud_written_twice_is_measured_as_once(tmp_path, capsys):
    """A scan merged twice: each copy was read as a neighbour at distance 0, the spacing came
    out short by sqrt 2, and a flat 5 m square gave 1,937 planes (the observatory 29 for 8).
    The copies are now left out as the file is read, counted in run.json's left_out, and
    the planes are the single copy's."""
    from geostructure.synthetic import observatory_scene

    points = observatory_scene(60_000, seed=1).cloud.points
    once, twice = (
        write_xyz(tmp_path / "once.xyz", points),
        write_xyz(tmp_path / "twice.xyz", np.vstack([points, points])),
    )
    planes = {}
    for name, path in (("once", once), ("twice", twice)):
        code, _, err = run_cli(capsys, "measure", path, "-o", tmp_path / name)
        assert code == 0, err
        record = json.loads((tmp_path / name / "run.json").read_text())
        assert record["counts"]["input"] == len(points)
        planes[name] = (tmp_path / name / "planes.csv").read_text()
    assert record["left_out"] == {"copies": len(points)} and f"{len(points):,} point(s) repeat others exactly" in err
    assert planes["twice"] == planes["once"]  # the same points measured: the same table, bit for bit


def test_tiles_that_overlap_are_measured_once_where_they_overlap(tmp_path, capsys):
    """Two tiles cut with a shared strip (a tiler's buffer): the strip's points are in both.
    They are left out once, as copies, and the planes are the whole cloud's."""
    from geostructure.synthetic import observatory_scene

    points = observatory_scene(60_000, seed=2).cloud.points + [500_000.0, 4_500_000.0, 0.0]
    x = points[:, 0] - points[:, 0].min()
    west, east = x < 0.6 * np.ptp(x), x > 0.4 * np.ptp(x)  # a fifth of the cloud in both
    write_xyz(tmp_path / "west.xyz", points[west])
    write_xyz(tmp_path / "east.xyz", points[east])
    write_xyz(tmp_path / "whole.xyz", points)
    code, _, err = run_cli(
        capsys, "measure", tmp_path / "west.xyz", tmp_path / "east.xyz", "-o", tmp_path / "tiles", "-q"
    )
    assert code == 0, err
    record = json.loads((tmp_path / "tiles" / "run.json").read_text())
    assert record["left_out"] == {"copies": int((west & east).sum())}
    assert record["counts"]["input"] == len(points)
    assert run_cli(capsys, "measure", tmp_path / "whole.xyz", "-o", tmp_path / "whole", "-q")[0] == 0
    tiles, whole = (list(csv.DictReader(open(tmp_path / n / "planes.csv"))) for n in ("tiles", "whole"))
    assert len(tiles) == len(whole)
    for a, b in zip(tiles, whole):  # the same points in another order: the same planes to rounding
        assert int(a["n_points"]) == int(b["n_points"])
        assert abs(float(a["dip"]) - float(b["dip"])) < 1e-6


def test_sets_and_a_report_of_a_cloud_without_planes(tmp_path, capsys):
    """Random scatter (vegetation, noise) measured with --sets: no plane, and the set column
    of regions.laz indexed the empty plane table, an IndexError traceback. Now the usual
    warning, every file written, no set."""
    cloud = write_xyz(tmp_path / "scatter.xyz", np.random.default_rng(0).random((5000, 3)) * 10)
    out = tmp_path / "o"
    args = ["measure", cloud, "-o", out, "-q", "--sets", "--report", "--kinematics", "--friction", "30"]
    code, _, err = run_cli(capsys, *args)
    assert code == 0 and "no plane found" in err and "Traceback" not in err and "internal warning" not in err, err
    assert (out / "sets.csv").read_text().count("\n") == 1 and (out / "report.html").is_file()  # a header, no set
    assert "--detector voxel fits coarser planes" in err  # the facet detector's advice, not the voxels'
    # No plane, so no share of planes critical: dashes in the report's kinematic table (it
    # failed on kinematics.json's null) and on the console, not "nan".
    assert "<td>Planar sliding</td><td>0</td><td>—</td>" in (out / "report.html").read_text()
    code, printed, _ = run_cli(capsys, "kinematics", out, "--friction", "30", "--slope", "60/180")
    assert code == 0 and "nan" not in printed.lower() and "—" in printed
    code, _, err = run_cli(capsys, "measure", cloud, "-o", tmp_path / "s", "-q", "--engine", "stream")
    assert code == 0 and "no plane found; if the cloud is sparse, try a larger --zeta" in err, err  # was silent
    # A ball of scatter: its "face" turns, so it is measured in sections, and each section
    # indexed the empty plane table: the same IndexError, one step later.
    ball = write_xyz(tmp_path / "ball.xyz", np.random.default_rng(2).standard_normal((20_000, 3)))
    code, printed, err = run_cli(capsys, "measure", ball, "-o", tmp_path / "b", "--sets")
    assert code == 0 and "measured in 2 sections" in " ".join(err.split()), err
    assert "No joint set: 0 planes, and a set needs 3." in printed
