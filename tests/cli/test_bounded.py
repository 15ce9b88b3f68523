"""Sizes bounded before the work (issue 53, items 5, 8, 9, 11, 13): options whose product
no machine holds, headers that promise more than their file holds, tables no person
writes, and control points that fix nothing are refused in one sentence, exit 2, before
a byte is allocated for them, and nothing is left behind."""

import csv
import struct
import zlib

import numpy as np
import pytest
from helpers import assert_one_sentence, run_cli, write_xyz


@pytest.fixture(scope="module")
def flat(tmp_path_factory):
    folder = tmp_path_factory.mktemp("bounded")
    rng = np.random.default_rng(0)
    return write_xyz(folder / "c.xyz", rng.random((3000, 3)) * [10.0, 10.0, 0.01])


def refused(capsys, *argv) -> str:
    """stderr of a command argparse or the program refuses with exit 2."""
    try:
        code, _, err = run_cli(capsys, *argv)
    except SystemExit as exit_:  # argparse's refusal of an option's value
        code, err = exit_.code, capsys.readouterr().err
    assert code == 2, err
    assert "Traceback" not in err
    return err


@pytest.mark.parametrize(
    "argv, words",
    [
        (["measure", "{flat}", "--k", "1000000000"], ["--k"]),
        (["measure", "{flat}", "--k", str(2**63)], ["--k"]),
        (["measure", "{flat}", "--zeta", "1e-300"], ["zeta"]),
        (["measure", "{flat}", "--engine", "dask", "--workers", "1000000000"], ["--workers"]),
        (["sweep", "--demo", "--workers", "1000000000"], ["--workers"]),
        (["demo", "--points", str(2**70)], ["--points"]),
        (["sweep", "--demo", "--points", str(10**10)], ["--points"]),
    ],
)
def test_options_past_any_machine_are_refused_before_the_work(flat, tmp_path, capsys, argv, words):
    out = tmp_path / "out"
    err = refused(capsys, *[a.format(flat=flat) for a in argv], "-o", out, "-q")
    assert all(w in err for w in words), err
    assert not out.exists()


def _ply_bomb(path, binary: bool):
    header = (
        f"ply\nformat {'binary_little_endian' if binary else 'ascii'} 1.0\nelement vertex 3\n"
        "property float x\nproperty float y\nproperty float z\nelement face 1000000000\n"
        "property list uchar int vertex_indices\nend_header\n"
    ).encode()
    if binary:
        body = struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0) + b"\x03" + struct.pack("<3i", 0, 1, 2)
    else:
        body = b"0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"
    path.write_bytes(header + body)


@pytest.mark.parametrize("binary", [False, True])
def test_a_ply_claiming_a_billion_faces_is_refused_at_once(tmp_path, capsys, binary):
    path = tmp_path / "bomb.ply"
    _ply_bomb(path, binary)
    err = refused(capsys, "measure", path, "-o", tmp_path / "out")
    assert_one_sentence(err, path)
    assert "1,000,000,000 face" in err


def test_a_sixty_megabyte_line_is_refused_by_its_number(tmp_path, capsys):
    path = tmp_path / "long.xyz"
    with open(path, "w") as fh:
        fh.write("1 2 3\n4 5 6\n")
        fh.write("7" * 60_000_000 + " 1 2\n")
    err = refused(capsys, "measure", path, "-o", tmp_path / "out")
    assert_one_sentence(err, path)
    assert "line 3 runs past" in err


@pytest.mark.parametrize("what", ["truth", "fractures"])
def test_a_sparse_two_gigabyte_table_is_refused_by_its_size(flat, tmp_path, capsys, what):
    from geostructure.cli import main

    assert main(["measure", str(flat), "-o", str(tmp_path / "out"), "-q"]) == 0
    table = tmp_path / "table.csv"
    table.write_text("surface,dip,dip_direction\nA,40,100\n")
    with open(table, "r+b") as fh:
        fh.truncate(2 * 1024**3)
    err = refused(capsys, "evaluate", tmp_path / "out", f"--{what}", table, "-q")
    assert_one_sentence(err, table)
    assert "bytes, more than any" in err


@pytest.mark.parametrize(
    "row, words", [(["A", "40", "1e308"], ["dip_direction"]), (["A", "40", "100", "1e308", "0", "0"], ["center_x"])]
)
def test_truth_values_no_surface_has_are_refused(flat, tmp_path, capsys, row, words):
    from geostructure.cli import main

    assert main(["measure", str(flat), "-o", str(tmp_path / "out"), "-q"]) == 0
    truth = tmp_path / "truth.csv"
    with open(truth, "w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(["surface", "dip", "dip_direction", "center_x", "center_y", "center_z"][: len(row)])
        writer.writerow(row)
    err = refused(capsys, "evaluate", tmp_path / "out", "--truth", truth, "-q")
    assert_one_sentence(err, truth, *words)


def _png_header(width: int, height: int) -> bytes:
    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(b"")) + chunk(b"IEND", b"")


def test_a_decompression_bomb_photo_is_refused_by_name(tmp_path):
    pytest.importorskip("PIL")
    from geostructure.errors import InputError
    from geostructure.reconstruct.sfm import check_images

    bomb = tmp_path / "bomb.png"
    bomb.write_bytes(_png_header(40_000, 40_000))
    with pytest.raises(InputError, match="bomb.png: its header claims more pixels"):
        check_images([bomb])


@pytest.mark.parametrize(
    "rows, words",
    [
        ([["a", "0", "0", "0", "1", "1", "1"], ["b", "10", "0", "0", "2", "1", "1"]], ["2 control point"]),
        (
            [
                ["a", "0", "0", "0", "1", "1", "1"],
                ["b", "10", "0", "0", "2", "1", "1"],
                ["c", "20", "0", "0", "3", "1", "1"],
            ],
            ["one line"],
        ),
    ],
)
def test_control_points_that_fix_nothing_are_refused_before_any_folder(tmp_path, capsys, rows, words):
    pytest.importorskip("pycolmap")
    photos = tmp_path / "photos"
    photos.mkdir()
    gcp = tmp_path / "gcp.csv"
    with open(gcp, "w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(["name", "E", "N", "Up", "x", "y", "z"])
        writer.writerows(rows)
    out = tmp_path / "out"
    err = refused(capsys, "run", photos, "-o", out, "--gcp", gcp, "-q")
    assert all(w in err for w in words), err
    assert not out.exists()


def test_a_scale_without_its_axes_is_refused_before_any_folder(tmp_path, capsys):
    pytest.importorskip("pycolmap")
    photos = tmp_path / "photos"
    photos.mkdir()
    out = tmp_path / "out"
    err = refused(capsys, "run", photos, "-o", out, "--scale", "2", "-q")
    assert "--scale" in err and "--up" in err
    assert not out.exists()


@pytest.mark.parametrize(
    "argv, words",
    [
        (["demo", "--unit", "mm", "--crs", "EPSG:32633"], ["--crs", "--unit"]),
        (["demo", "--unit", "ft"], ["--unit"]),
        (["sweep", "{flat}", "--demo"], ["--demo"]),
    ],
)
def test_combinations_that_mean_nothing_are_refused(flat, tmp_path, capsys, argv, words):
    """demo --unit mm --crs EPSG:32633 exited 0; sweep FILE --demo swept the demo and left
    the file unread."""
    out = tmp_path / "out"
    err = refused(capsys, *[a.format(flat=flat) for a in argv], "-o", out, "-q")
    assert_one_sentence(err, *words)
    assert not out.exists()


def test_a_las_offset_of_1e308_is_a_damaged_header_without_numpy_warnings(tmp_path, capsys):
    from helpers import write_classified_las

    path = write_classified_las(tmp_path / "c.las", np.random.default_rng(1).random((500, 3)) * 10, np.full(500, 2))
    data = bytearray(path.read_bytes())
    struct.pack_into("<d", data, 163, 1e308)  # the y offset
    path.write_bytes(bytes(data))
    err = refused(capsys, "measure", path, "-o", tmp_path / "out")
    assert_one_sentence(err, path, "y offset")


def test_a_ply_of_random_floats_is_refused_without_numpy_warnings(tmp_path, capsys):
    header = b"ply\nformat binary_little_endian 1.0\nelement vertex 100\n"
    header += b"property float x\nproperty float y\nproperty float z\nend_header\n"
    path = tmp_path / "random.ply"
    path.write_bytes(header + np.random.default_rng(0).bytes(1200))
    err = refused(capsys, "measure", path, "-o", tmp_path / "out")
    assert_one_sentence(err, path)
