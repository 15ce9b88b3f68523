"""Options and names a hostile or careless user gives: one sentence and exit 2, never a
traceback (each case failed so before 2026-12-06)."""

import numpy as np
import pytest
from helpers import assert_one_sentence, folder_digests, run_cli, write_xyz


@pytest.fixture(scope="module")
def flat(tmp_path_factory):
    folder = tmp_path_factory.mktemp("hostile_options")
    rng = np.random.default_rng(0)
    return write_xyz(folder / "c.xyz", rng.random((3000, 3)) * [10.0, 10.0, 0.01])


@pytest.mark.parametrize(
    "options, words",
    [
        (["--sets", "--kinematics", "--friction", "30", "--cohesion", "10", "--height", "1e308"], ["--height"]),
        (["--sets", "--kinematics", "--friction", "30", "--cohesion", "1e308"], ["--cohesion"]),
        (["--sets", "--kinematics", "--friction", "30", "--unit-weight", "1e300"], ["--unit-weight"]),
        (
            ["--sets", "--kinematics", "--friction", "30", "--cohesion", "5", "--unit-weight", "1e-300"],
            ["--unit-weight"],
        ),
        (["--engine", "dask", "--scheduler", "garbage"], ["--scheduler", "garbage"]),
        (["--crs", ""], ["--crs"]),
        (["--psi", "1e308"], ["psi", "1/zeta"]),
        (["--sigma", "1e308"], ["sigma", "--filter none"]),
        (["--engine", "stream", "--spill-dir", "/nonexistent/spill"], ["--spill-dir", "/nonexistent/spill"]),
    ],
)
def test_options_that_cannot_mean_anything_are_refused_before_the_work(flat, tmp_path, capsys, options, words):
    out = tmp_path / "out"
    code, _, err = run_cli(capsys, "measure", flat, "-o", out, "-q", *options)
    assert code == 2
    assert_one_sentence(err, *words)
    assert not out.exists()


def test_a_mesh_sample_count_no_memory_holds_is_refused_by_its_option(flat, tmp_path, capsys):
    """--mesh-samples 1000000000000 was reported as the cloud file not fitting in memory."""
    with pytest.raises(SystemExit) as exit_:
        run_cli(capsys, "measure", flat, "-o", tmp_path / "o", "-q", "--mesh-samples", "1000000000000")
    err = capsys.readouterr().err
    assert exit_.value.code == 2 and "--mesh-samples" in err and "Traceback" not in err
    assert not (tmp_path / "o").exists()


def test_a_las_offset_of_infinity_is_a_damaged_header(tmp_path, capsys):
    """The offset gave numpy's 'invalid value in subtract' as an internal warning beside the
    refusal."""
    import struct

    from helpers import write_classified_las

    path = write_classified_las(tmp_path / "c.las", np.random.default_rng(1).random((500, 3)) * 10, np.full(500, 2))
    data = bytearray(path.read_bytes())
    struct.pack_into("<d", data, 155, float("inf"))
    path.write_bytes(bytes(data))
    for engine in ("memory", "stream"):
        code, _, err = run_cli(capsys, "measure", path, "-o", tmp_path / "o", "-q", "--engine", engine)
        assert code == 2
        assert_one_sentence(err, "c.las", "x offset")
        assert not (tmp_path / "o").exists()


def test_a_negative_demo_seed_is_refused(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_:
        run_cli(capsys, "demo", "-o", tmp_path / "d", "--seed", "-1", "-q")
    err = capsys.readouterr().err
    assert exit_.value.code == 2 and "--seed" in err and "Traceback" not in err
    assert not (tmp_path / "d").exists()


@pytest.mark.parametrize("engine", ["memory", "stream"])
def test_a_newline_in_the_file_name_is_written_escaped(flat, tmp_path, capsys, engine):
    named = tmp_path / "a\nb.xyz"
    named.write_bytes(flat.read_bytes())
    out = tmp_path / "o\nut"
    code, _, err = run_cli(capsys, "measure", named, "-o", out, "-q", "--engine", engine)
    assert code == 0, err
    header = (out / "regions.ply").read_bytes().split(b"end_header")[0]
    assert b"comment source a\\nb.xyz\n" in header


def test_collinear_points_streamed_give_no_plane_and_no_traceback(tmp_path, capsys):
    t = np.linspace(0.0, 1.0, 3000)
    line = write_xyz(tmp_path / "line.xyz", np.c_[t, 2 * t, 3 * t])
    code, _, err = run_cli(capsys, "measure", line, "-o", tmp_path / "o", "-q", "--engine", "stream")
    assert code == 0 and "no plane found" in err and "Traceback" not in err


def test_a_frame_fit_needs_two_truth_planes(flat, tmp_path, capsys):
    out = tmp_path / "m"
    assert run_cli(capsys, "measure", flat, "-o", out, "-q")[0] == 0
    truth = tmp_path / "t.csv"
    truth.write_text("surface,dip,dip_direction\na,40,90\n")
    before = folder_digests(out)
    code, _, err = run_cli(capsys, "evaluate", out, "--truth", truth, "--fit-frame")
    assert code == 2
    assert_one_sentence(err, "t.csv", "--fit-frame")
    assert folder_digests(out) == before


def test_a_file_in_the_working_folder_is_never_removed(flat, tmp_path, capsys):
    """An input inside OUTDIR/.geostructure-staging was deleted by the run it fed; a user's
    file left there was deleted by the next run. Both are refused now, the file kept."""
    out = tmp_path / "out"
    assert run_cli(capsys, "measure", flat, "-o", out, "-q")[0] == 0
    staging = out / ".geostructure-staging"
    staging.mkdir()
    inside = staging / "c.xyz"
    inside.write_bytes(flat.read_bytes())
    before = folder_digests(out)
    code, _, err = run_cli(capsys, "measure", inside, "-o", out, "-q")
    assert code == 2
    assert_one_sentence(err, "c.xyz", ".geostructure-staging")
    assert folder_digests(out) == before and inside.read_bytes() == flat.read_bytes()
    inside.rename(staging / "note.txt")
    code, _, err = run_cli(capsys, "measure", flat, "-o", out, "-q")
    assert code == 2
    assert_one_sentence(err, "note.txt")
    assert (staging / "note.txt").read_bytes() == flat.read_bytes()


@pytest.mark.parametrize("name", ["run.json", "planes.csv", "sets.csv"])
def test_a_folder_where_an_output_goes_is_refused_before_the_work(flat, tmp_path, capsys, name):
    out = tmp_path / "out"
    assert run_cli(capsys, "measure", flat, "-o", out, "-q")[0] == 0
    (out / name).unlink(missing_ok=True)
    (out / name).mkdir()
    before = folder_digests(out)
    for argv in (["measure", flat, "-o", out], ["sets", out]):
        code, _, err = run_cli(capsys, *argv, "-q")
        assert code == 2
        assert_one_sentence(err, name)
        assert folder_digests(out) == before and (out / name).is_dir()
        assert not (out / ".geostructure-staging").exists()


@pytest.mark.parametrize("extra", [[], ["--sets"]], ids=["voxel", "tiles"])
def test_dask_leaves_nothing_in_the_temporary_folder(flat, tmp_path, capsys, monkeypatch, extra):
    """Neither the chunks' passes nor the facet tiles (``--sets``) leave a scratch folder, a
    spill, a tile file or a worker process behind."""
    pytest.importorskip("distributed")
    import tempfile

    import psutil

    scratch = tmp_path / "tmp"
    scratch.mkdir()
    monkeypatch.setenv("TMPDIR", str(scratch))
    monkeypatch.setattr(tempfile, "tempdir", str(scratch))
    code, _, err = run_cli(capsys, "measure", flat, "-o", tmp_path / "o", "-q", "--engine", "dask", "--workers", "2",
                           *extra)  # fmt: skip
    assert code == 0, err
    assert sorted(p.name for p in scratch.iterdir()) == []  # was: dask-scratch-space
    # No worker left, nor Python's resource tracker beside them (it outlived the command
    # by a moment, a process left behind for whoever listed them then).
    assert [" ".join(p.cmdline()) for p in psutil.Process().children(recursive=True)] == []


@pytest.fixture(scope="module")
def outcrop_file(tmp_path_factory):
    from geostructure.synthetic import outcrop_scene

    folder = tmp_path_factory.mktemp("outcrop_file")
    return write_xyz(folder / "outcrop.xyz", outcrop_scene(width=8.0, height=5.0, seed=5).cloud.points)


KINEMATIC_RUN = ["--sets", "--kinematics", "--friction", "30", "-q"]


def test_a_late_refusal_commits_nothing(outcrop_file, tmp_path, capsys):
    """The upper slope is checked against the fitted face only after the measure: the
    refusal left a new folder with a complete measure and sets. One command, one commit."""
    out = tmp_path / "new"
    code, _, err = run_cli(capsys, "measure", outcrop_file, "-o", out, *KINEMATIC_RUN,
                           "--cohesion", "10", "--upper-slope", "89/180")  # fmt: skip
    assert code == 2
    assert_one_sentence(err, "upper slope")
    assert not out.exists()
    assert run_cli(capsys, "measure", outcrop_file, "-o", out, *KINEMATIC_RUN)[0] == 0
    before = folder_digests(out)
    code, _, _ = run_cli(capsys, "measure", outcrop_file, "-o", out, *KINEMATIC_RUN,
                         "--cohesion", "10", "--upper-slope", "89/180")  # fmt: skip
    assert code == 2 and folder_digests(out) == before


def test_an_interrupt_during_the_kinematics_commits_nothing(outcrop_file, tmp_path, capsys, monkeypatch):
    import geostructure.workflows.kinematics as stability

    out = tmp_path / "o"
    assert run_cli(capsys, "measure", outcrop_file, "-o", out, "-q")[0] == 0
    before = folder_digests(out)

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(stability, "kinematics_of", interrupted)
    code, _, err = run_cli(capsys, "measure", outcrop_file, "-o", out, *KINEMATIC_RUN, "--report")
    assert code != 0 and "Traceback" not in err
    assert folder_digests(out) == before  # the measure and sets before it are not committed alone
    assert not (out / ".geostructure-staging").exists()


def test_a_file_of_nul_bytes_is_refused_at_once(tmp_path, capsys):
    path = tmp_path / "nul.xyz"
    with open(path, "wb") as fh:  # sparse: 64 MB of NUL bytes, no newline
        fh.truncate(64 << 20)
    code, _, err = run_cli(capsys, "measure", path, "-o", tmp_path / "o", "-q")
    assert code == 2
    assert_one_sentence(err, "nul.xyz", "NUL")
    assert not (tmp_path / "o").exists()


def test_a_truth_of_too_many_surfaces_is_refused_before_the_matching(flat, tmp_path, capsys):
    out = tmp_path / "m"
    assert run_cli(capsys, "measure", flat, "-o", out, "-q")[0] == 0
    truth = tmp_path / "t.csv"
    truth.write_text("surface,dip,dip_direction\n" + "".join(f"s{i},40,90\n" for i in range(10_001)))
    before = folder_digests(out)
    code, _, err = run_cli(capsys, "evaluate", out, "--truth", truth)
    assert code == 2
    assert_one_sentence(err, "t.csv", "10,001")
    assert folder_digests(out) == before


def test_huge_frame_vectors_are_only_directions(flat, tmp_path, capsys):
    """--up 1e308 0 0 printed numpy's overflow as an internal warning beside the refusal."""
    code, _, err = run_cli(capsys, "measure", flat, "-o", tmp_path / "o", "-q",
                           "--up", "0", "0", "1e308", "--north", "0", "1e308", "0")  # fmt: skip
    assert code == 0 and "internal warning" not in err and "RuntimeWarning" not in err, err


def test_a_ply_of_random_bytes_is_refused_without_numpy_warnings(tmp_path, capsys):
    header = b"ply\nformat binary_little_endian 1.0\nelement vertex 1000\n"
    header += b"property float x\nproperty float y\nproperty float z\nend_header\n"
    path = tmp_path / "random.ply"
    path.write_bytes(header + np.random.default_rng(0).integers(0, 256, 12_000, dtype=np.uint8).tobytes())
    code, _, err = run_cli(capsys, "measure", path, "-o", tmp_path / "o", "-q")
    assert code == 2
    assert_one_sentence(err, "random.ply")  # no "internal warning: RuntimeWarning ... in cast"


@pytest.mark.parametrize("forge", ["object", "deep"])
def test_a_forged_run_record_is_refused_by_every_reader(flat, tmp_path, capsys, forge):
    """run.json of the wrong shape (an object where the offset's numbers go, or 100,000
    nested brackets) gave a TypeError or a RecursionError traceback."""
    import json

    out = tmp_path / "out"
    assert run_cli(capsys, "measure", flat, "-o", out, "-q")[0] == 0
    record = out / "run.json"
    if forge == "object":
        data = json.loads(record.read_text())
        data["offset"] = {"a": 1}
        record.write_text(json.dumps(data))
    else:
        record.write_text("[" * 100_000 + "]" * 100_000)
    truth = tmp_path / "t.csv"
    truth.write_text("surface,dip,dip_direction\na,40,90\nb,80,180\n")
    before = folder_digests(out)
    for argv in (
        ["report", out],
        ["sets", out],
        ["evaluate", out, "--truth", truth],
        ["kinematics", out, "--friction", "30"],
    ):
        code, _, err = run_cli(capsys, *argv, "-q")
        assert code == 2, argv
        assert_one_sentence(err, "run.json")
        assert folder_digests(out) == before


def test_a_forged_plane_table_is_refused_by_its_name(flat, tmp_path, capsys):
    """A NaN normal written into planes.csv, run.json resealed to match, went through 'sets'
    without a word."""
    import csv
    import json

    from geostructure.io.outdir import SEAL, file_entry, sealed

    out = tmp_path / "out"
    assert run_cli(capsys, "measure", flat, "-o", out, "-q")[0] == 0
    table = out / "planes.csv"
    rows = list(csv.reader(table.open(newline="")))
    rows[1][rows[0].index("normal_x")] = "nan"
    with table.open("w", newline="") as fh:
        csv.writer(fh).writerows(rows)
    record = json.loads((out / "run.json").read_text())

    def relisted(node):
        if isinstance(node, dict):
            return {k: file_entry(table) if k == "planes.csv" and isinstance(v, dict) else relisted(v)
                    for k, v in node.items() if k != SEAL}  # fmt: skip
        return [relisted(v) for v in node] if isinstance(node, list) else node

    (out / "run.json").write_text(json.dumps(sealed(relisted(record))))
    before = folder_digests(out)
    code, _, err = run_cli(capsys, "sets", out, "-q")
    assert code == 2
    assert_one_sentence(err, "planes.csv", "normal")
    assert folder_digests(out) == before
