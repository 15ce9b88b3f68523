"""A survey in tiles (issue "Scale"): 16 LAZ tiles, given as a folder, a quoted glob or one by
one, measure as the whole file does; a plane across four tiles is one region; tiles that
disagree on their CRS are refused before any work; the order of the points changes nothing."""

import json

import laspy
import numpy as np
import pyproj
import pytest
from helpers import UTM, assert_one_sentence, planes_of, run_cli, tile_index, write_laz
from plyfile import PlyData

from geostructure import Cloud, measure
from geostructure.synthetic import outcrop_scene


@pytest.fixture(scope="module")
def survey(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("tiles")
    points = outcrop_scene(width=8.0, height=4.0, seed=1, offset=UTM).cloud.points
    write_laz(tmp / "whole.laz", points)
    (tmp / "tiles").mkdir()
    tile = tile_index(points)
    for t in np.unique(tile):
        write_laz(tmp / "tiles" / f"tile_{t:02d}.laz", points[tile == t])
    (tmp / "tiles" / "README.txt").write_text("Sixteen tiles of the 2024 survey, 1 mm grid.\n")  # not a cloud
    return tmp, points


def test_sixteen_tiles_measure_as_the_whole_file(survey, capsys):
    tmp, _ = survey
    assert len(list((tmp / "tiles").glob("*.laz"))) == 16
    assert run_cli(capsys, "measure", tmp / "whole.laz", "-o", tmp / "whole", "-q")[0] == 0
    tiles = sorted((tmp / "tiles").glob("*.laz"))
    for name, given in (("folder", [tmp / "tiles"]), ("glob", [str(tmp / "tiles" / "*.laz")]), ("files", tiles)):
        assert run_cli(capsys, "measure", *given, "-o", tmp / name, "-q")[0] == 0, name
        centroid, normal = planes_of(tmp / name)
        whole_centroid, whole_normal = planes_of(tmp / "whole")
        assert len(centroid) == len(whole_centroid) > 20
        cosine = np.abs(np.einsum("ij,ij->i", normal, whole_normal))
        assert np.degrees(np.arccos(np.clip(cosine, 0, 1))).max() < 0.05
        assert np.abs(centroid - whole_centroid).max() < 1e-3
        record = json.loads((tmp / name / "run.json").read_text())
        assert len(record["inputs"]) == 16 and pyproj.CRS(record["crs"]).to_epsg() == 32633
    # the LAS grid the tiles share is kept: the points go back on their own integers
    regions = laspy.read(str(tmp / "folder" / "regions.laz"))
    assert regions.header.scales.tolist() == [0.001] * 3 and regions.header.offsets.tolist() == list(UTM)


def test_a_plane_across_four_tiles_is_one_region(tmp_path, capsys):
    rng = np.random.default_rng(4)
    uv = rng.uniform(-3, 3, (60_000, 2))
    slab = np.column_stack([uv[:, 0], 0.3 * uv[:, 0] + 0.2 * uv[:, 1] + rng.normal(0, 0.003, len(uv)), uv[:, 1]])
    points = slab + UTM
    tile = tile_index(points, n=2)
    for t in range(4):
        write_laz(tmp_path / f"quarter_{t}.laz", points[tile == t])
    assert run_cli(capsys, "measure", str(tmp_path / "quarter_*.laz"), "-o", tmp_path / "out", "-q")[0] == 0
    vertex = PlyData.read(str(tmp_path / "out" / "regions.ply"))["vertex"].data
    xyz = np.column_stack([vertex[a] for a in "xyz"])
    largest = vertex["scalar_region_id"] == 0
    assert largest.mean() > 0.9
    assert set(tile_index(xyz[largest], n=2).tolist()) == {0, 1, 2, 3}  # it spans all four tiles


def test_tiles_that_disagree_on_their_crs_are_refused_before_any_work(tmp_path, capsys):
    points = outcrop_scene(width=4.0, height=3.0, seed=2, offset=UTM).cloud.points
    half = points[:, 0] < np.median(points[:, 0])
    write_laz(tmp_path / "a.laz", points[half])
    write_laz(tmp_path / "b.laz", points[~half], crs="EPSG:32634")
    code, _, err = run_cli(capsys, "measure", tmp_path / "a.laz", tmp_path / "b.laz", "-o", tmp_path / "out")
    assert code == 2 and "UTM zone 34N" in err and "UTM zone 33N" in err
    assert_one_sentence(err, tmp_path / "b.laz")
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("given", ["empty_folder", "no_match"])
def test_a_folder_or_pattern_without_clouds_is_one_sentence(tmp_path, capsys, given):
    (tmp_path / "empty_folder").mkdir()
    (tmp_path / "empty_folder" / "notes.txt.bak").write_text("not a cloud")
    spec = tmp_path / "empty_folder" if given == "empty_folder" else str(tmp_path / "tiles_*.laz")
    code, _, err = run_cli(capsys, "measure", spec, "-o", tmp_path / "out")
    assert code == 2
    assert_one_sentence(err, spec)
    assert not (tmp_path / "out").exists()


@pytest.mark.real_data
def test_a_real_data_folder_reads_its_cloud_and_not_its_notes(tmp_path, capsys):
    """jfm_outcrop_test holds test.txt (the cloud) and PROVENANCE.txt (a note), both .txt."""
    from conftest import shared_file

    folder = shared_file("jfm_outcrop_test")
    assert run_cli(capsys, "measure", folder, "-o", tmp_path / "out", "-q")[0] == 0
    record = json.loads((tmp_path / "out" / "run.json").read_text())
    assert record["input"].endswith("test.txt") and record["counts"]["input"] == 1133


def test_the_order_of_the_points_changes_no_plane():
    """The samples the parameters are read from are drawn by the points' coordinates, not
    their places in the array: a shuffled cloud gives the same planes."""
    points = outcrop_scene(width=6.0, height=4.0, seed=3, offset=UTM).cloud.points
    a = measure(Cloud.from_points(points)).planes
    b = measure(Cloud.from_points(points[np.random.default_rng(0).permutation(len(points))])).planes
    assert len(a) == len(b)
    np.testing.assert_allclose(a.centroid, b.centroid, atol=1e-6)
    assert np.degrees(np.arccos(np.clip(np.abs(np.einsum("ij,ij->i", a.normal, b.normal)), 0, 1))).max() < 1e-3


def test_the_vegetation_a_tile_classifies_is_kept_when_the_tiles_are_read_as_one(tmp_path):
    """Two tiles, one with points in a vegetation class (LAS 4): the merged cloud marks
    those points and no other."""
    from helpers import write_classified_las

    from geostructure.io.survey_files import read_tiles

    rng = np.random.default_rng(0)
    points = rng.random((200, 3)) * [10.0, 10.0, 1.0]
    write_classified_las(tmp_path / "a.laz", points[:100], np.full(100, 2), origin=UTM)
    write_classified_las(tmp_path / "b.laz", points[100:], np.r_[np.full(30, 4), np.full(70, 2)], origin=UTM)
    cloud = read_tiles([tmp_path / "a.laz", tmp_path / "b.laz"])
    assert cloud.vegetation is not None and cloud.vegetation.sum() == 30
    marked = cloud.points[cloud.vegetation] - UTM
    np.testing.assert_allclose(np.sort(marked[:, 0]), np.sort(points[100:130, 0]), atol=1e-3)


@pytest.mark.parametrize("damage", ["random bytes", "empty", "one word"])
def test_a_damaged_tile_in_a_folder_is_refused_by_name_not_left_out(tmp_path, capsys, damage):
    """One of four XYZ tiles garbage or empty: the survey was measured from the other three
    with no word (the tile was passed over as a folder's note). Now it is refused, by name,
    before any work; a README.txt beside the tiles is still passed over, and said so."""
    grid = np.mgrid[0:4:0.05, 0:4:0.05].reshape(2, -1).T
    folder = tmp_path / "tiles"
    folder.mkdir()
    for i in range(3):
        np.savetxt(folder / f"tile_{i}.xyz", np.c_[grid[:, 0] + 4 * i, grid[:, 1], np.zeros(len(grid))])
    bad = folder / "tile_3.xyz"
    bad.write_bytes(
        {"random bytes": np.random.default_rng(0).bytes(4000), "empty": b"", "one word": b"hello\n"}[damage]
    )
    code, _, err = run_cli(capsys, "measure", folder, "-o", tmp_path / "out")
    assert code == 2
    assert_one_sentence(err, bad)
    assert not (tmp_path / "out").exists()
    bad.unlink()
    (folder / "README.txt").write_text("Four tiles of the 2024 survey.\n")
    code, _, err = run_cli(capsys, "measure", folder, "-o", tmp_path / "out")
    assert code == 0 and "README.txt: passed over, a note" in err
