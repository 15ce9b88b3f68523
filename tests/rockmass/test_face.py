"""The face told from its ground and its clutter (face.py): on synthetic cases with exact
answers, and on a real drone cloud whose vegetation was classified by hand."""

import csv

import numpy as np
import pytest

from geostructure import measure
from geostructure.detect.auto import choose_params
from geostructure.rockmass.face import CLUTTER, FACE, clutter_points, face_parts
from geostructure.workflows.sets_and_mass import detected_spacing


def slab(rng, n, size, z=0.0, noise=0.002):
    return np.column_stack([rng.random((n, 2)) * size, z + noise * rng.standard_normal(n)])


def test_the_level_planes_of_a_gentle_slope_are_its_face_not_its_ground():
    """Two level benches and a 30-degree ramp between them: without the level planes what is
    left is not steep, so they are the face (a berm-free slope, a bedding-plane slab); with a
    70-degree wall in its place they are the ground before and above it."""
    rng = np.random.default_rng(0)
    low = slab(rng, 4000, 4.0)
    for dip, expect_ground in ((30.0, False), (70.0, True)):
        run = 1.0 / np.tan(np.radians(dip))  # the ramp rises 1 m from the low bench's edge
        t = rng.random((3000, 2))
        ramp = np.column_stack([4.0 + t[:, 0] * run, t[:, 1] * 4.0, t[:, 0]])
        high = slab(rng, 4000, 4.0) + [4.0 + run, 0.0, 1.0]
        normal = [-np.sin(np.radians(dip)), 0.0, np.cos(np.radians(dip))]
        points = np.vstack([low, ramp, high])
        labels = np.repeat([0, 1, 2], [4000, 3000, 4000])
        parts = face_parts(points, labels, [[0, 0, 1.0], normal, [0, 0, 1.0]], spacing=0.06)
        assert parts.ground.tolist() == [expect_ground, False, expect_ground], dip
        assert (parts.members is None) == (not expect_ground)


def test_a_cloud_all_clutter_is_all_face():
    """Random scatter has no surface to tell clutter from: no point is left out."""
    points = np.random.default_rng(1).random((20_000, 3)) * 3.0
    parts = face_parts(points, np.full(len(points), -1), np.zeros((0, 3)))
    assert parts.members is None


def test_a_bush_is_clutter_and_the_wall_behind_it_is_not():
    rng = np.random.default_rng(2)
    wall = slab(rng, 40_000, 6.0)  # 3 cm spacing, a plane
    shell = rng.normal(size=(6000, 3))
    shell /= np.linalg.norm(shell, axis=1, keepdims=True)
    shell[:, 2] = np.abs(shell[:, 2])
    bush = [3.0, 3.0, 0.0] + 0.8 * shell + 0.03 * rng.standard_normal((6000, 3))
    labels = np.r_[np.zeros(len(wall), int), np.full(len(bush), -1)]
    found = clutter_points(np.vstack([wall, bush]), labels, spacing=0.03)
    assert not found[: len(wall)].any() and found[len(wall) :].mean() > 0.8


@pytest.mark.real_data
def test_on_a_drone_cloud_the_ground_is_not_clutter():
    """ODMSemantic3D's brighton_small (drone SfM, 401,286 points, classified by hand: ground,
    vegetation, buildings). Measured: 0.3% of the ground's points are clutter, 3% of the
    vegetation's. Vegetation that SfM makes a surface of (a canopy seen from above) is not
    found: clutter is a volume of points, as a bush before a face seen from the side is."""
    import laspy
    from conftest import shared_file

    from geostructure.io.readers import read_cloud

    path = shared_file("odmsemantic3d/brighton_small.laz")
    classes = np.asarray(laspy.read(str(path)).classification)
    cloud = read_cloud(path)
    choice = choose_params(cloud.local)
    result = measure(cloud, choice.params, moments=choice.moments)
    kept = classes[result.filter_result.keep]
    clutter = clutter_points(result.filtered.local, result.labels, detected_spacing(result.detection))
    assert clutter[kept == 2].mean() < 0.01
    assert clutter[kept == 3].mean() > 3 * clutter[kept == 2].mean()
    # The file's own classes say it: read with the cloud, every vegetation point is clutter.
    assert result.filtered.vegetation is not None
    parts = face_parts(result.filtered.local, result.labels, result.planes.normal, result.frame.matrix[2],
                       spacing=detected_spacing(result.detection), vegetation=result.filtered.vegetation)  # fmt: skip
    part = parts.point_part if parts.point_part is not None else np.zeros(len(kept), dtype=np.uint8)
    assert (part[kept == 3] == CLUTTER).all() and (part[kept == 2] == CLUTTER).mean() < 0.01


def test_regions_laz_says_which_points_are_face_ground_and_clutter(tmp_path, capsys):
    """`measure --sets` writes each point's part in regions.laz (face_part: 0 face, 1 ground,
    2 clutter), and `sets OUTDIR` writes the same again."""
    import laspy
    from helpers import run_cli

    from geostructure.synthetic import bushes_on, outcrop_scene, road_before

    scene = outcrop_scene(width=8.0, height=5.0, seed=3)
    bushes, hidden = bushes_on(scene, 2, seed=3)
    road = road_before(scene, depth=2.5, seed=3)
    points = np.vstack([scene.cloud.points[~hidden], road, bushes])
    truth = np.repeat([0, 1, 2], [int((~hidden).sum()), len(road), len(bushes)])
    np.savetxt(tmp_path / "cut.xyz", points, fmt="%.4f")
    assert run_cli(capsys, "measure", tmp_path / "cut.xyz", "-o", tmp_path / "out", "--sets", "-q")[0] == 0
    regions = laspy.read(str(tmp_path / "out" / "regions.laz"))
    part = np.asarray(regions.face_part)
    xyz = np.column_stack([regions.x, regions.y, regions.z])
    from scipy.spatial import cKDTree

    kept = truth[cKDTree(points).query(xyz)[1]]  # each written point's truth, by its nearest input point
    assert (part[kept == 1] == 1).mean() > 0.9  # the road
    assert (part[kept == 2] == 2).mean() > 0.8  # the bushes
    assert (part[kept == 0] == 0).mean() > 0.95  # the rock
    assert run_cli(capsys, "sets", tmp_path / "out", "-q")[0] == 0
    assert np.array_equal(np.asarray(laspy.read(str(tmp_path / "out" / "regions.laz")).face_part), part)


def test_points_a_las_classifies_as_vegetation_are_clutter(tmp_path, capsys):
    """A survey's vegetation classes (LAS 3 to 5) say what the geometry can only guess: every
    such point is clutter, and a plane mostly of them joins no set; `sets OUTDIR` reads them
    back from regions.ply. Three bushes before a 12 x 6 m face (seed 4): by their shape alone
    92% of their points are clutter; classified, all."""
    import laspy
    from helpers import LAS_ORIGIN, run_cli, write_classified_las

    from geostructure.synthetic import bushes_on, outcrop_scene

    scene = outcrop_scene(width=12.0, height=6.0, seed=4)
    bushes, hidden = bushes_on(scene, 3, seed=4)
    rock = scene.cloud.points[~hidden]
    classes = np.repeat([1, 4], [len(rock), len(bushes)])  # rock unclassified, bushes medium vegetation
    write_classified_las(tmp_path / "cut.laz", np.vstack([rock, bushes]), classes)
    out = tmp_path / "out"
    code, _, err = run_cli(capsys, "measure", tmp_path / "cut.laz", "-o", out, "--sets")  # notes: not -q
    assert code == 0 and "points classified as vegetation (LAS classes 3 to 5) are taken for clutter" in err
    regions = laspy.read(str(out / "regions.laz"))
    part = np.asarray(regions.face_part)
    from scipy.spatial import cKDTree

    written = np.column_stack([regions.x, regions.y, regions.z]) - LAS_ORIGIN
    is_bush = cKDTree(bushes).query(written)[0] < 1e-3
    assert is_bush.sum() > 0.9 * len(bushes) and (part[is_bush] == CLUTTER).all()
    assert (part[~is_bush] == FACE).mean() > 0.95
    with open(out / "planes.csv", newline="") as fh:
        planes = list(csv.DictReader(fh))
    assert all(int(p["set"]) == -1 for p in planes if int(p["clutter"]))
    assert len(set(int(p["set"]) for p in planes) - {-1}) == 3
    # From the folder: the same parts again, the vegetation read back from regions.ply.
    assert run_cli(capsys, "sets", out, "-q")[0] == 0
    assert (np.asarray(laspy.read(str(out / "regions.laz")).face_part) == part).all()


def test_a_cloud_all_vegetation_is_measured_as_its_face_and_says_so(tmp_path, capsys):
    """Every point in a vegetation class: there is no rock to tell it from, so the points are
    the face (as a cloud all clutter is), and the note says that, not that they were left out."""
    from helpers import run_cli, write_classified_las

    rng = np.random.default_rng(0)
    points = np.column_stack([rng.random(20_000) * 10, rng.random(20_000) * 10, rng.random(20_000) * 0.05])
    write_classified_las(tmp_path / "canopy.laz", points, np.full(len(points), 5))  # high vegetation
    code, _, err = run_cli(capsys, "measure", tmp_path / "canopy.laz", "-o", tmp_path / "out", "--sets")
    assert code == 0 and "with no rock face to tell them from, they are measured as the face" in err
    assert "taken for clutter" not in err
