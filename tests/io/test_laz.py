"""regions.laz and voxel_planes.laz (issue "Outputs"): LAS 1.4 on the input's grid or a
0.1 mm one, the CRS, region_id and set as extra dimensions; read back with laspy's lazrs
and with LASzip, the reference library, and with CloudCompare where its build reads LAS."""

import json
import shutil
import subprocess

import laspy
import numpy as np
import pytest
from helpers import run_cli
from plyfile import PlyData

from geostructure.io.laz import LAS_QUANTUM, las_grid
from geostructure.synthetic import outcrop_scene

UTM_33N = "EPSG:32633"


@pytest.fixture(scope="module")
def las_input(tmp_path_factory):
    """A synthetic outcrop at UTM 33N stored as LAZ on a 1 mm grid with its CRS declared."""
    tmp = tmp_path_factory.mktemp("laz")
    scene = outcrop_scene(width=6.0, height=4.0, seed=1, offset=(500_000.0, 4_600_000.0, 300.0))
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales, header.offsets = [0.001, 0.001, 0.001], [499_990.0, 4_599_990.0, 290.0]
    header.add_crs(__import__("pyproj").CRS(UTM_33N))
    las = laspy.LasData(header)
    las.x, las.y, las.z = scene.cloud.points.T
    path = tmp / "outcrop.laz"
    las.write(str(path))
    return path, laspy.read(str(path))


def read_with(path, backend):
    with laspy.open(str(path), laz_backend=backend) as reader:
        return reader.read()


def test_a_las_input_comes_back_on_its_own_integers_with_its_crs(las_input, tmp_path, capsys):
    path, original = las_input
    out = tmp_path / "out"
    before = path.read_bytes()
    code, _, _ = run_cli(capsys, "measure", path, "-o", out, "-q", "--sets")
    assert code == 0 and path.read_bytes() == before
    for backend in (laspy.LazBackend.Lazrs, laspy.LazBackend.Laszip):  # two independent decoders
        regions = read_with(out / "regions.laz", backend)
        assert regions.header.version.minor == 4 and regions.header.point_format.id == 6
        np.testing.assert_array_equal(regions.header.scales, original.header.scales)
        np.testing.assert_array_equal(regions.header.offsets, original.header.offsets)
        assert regions.header.parse_crs().to_epsg() == 32633
        assert {"region_id", "set"} <= set(regions.point_format.extra_dimension_names)

    # every point written is one of the input's, on the same integers (the filter drops some)
    def integers(las):
        return {tuple(row) for row in np.column_stack([las.X, las.Y, las.Z]).tolist()}

    assert integers(regions) <= integers(original)
    # the same points, labels and sets as the PLY and the plane table say
    vertex = PlyData.read(str(out / "regions.ply"))["vertex"].data
    assert np.abs(regions.xyz - np.column_stack([vertex[a] for a in "xyz"])).max() < 1e-9
    np.testing.assert_array_equal(regions.region_id, vertex["scalar_region_id"])
    planes = np.genfromtxt(out / "planes.csv", delimiter=",", names=True)
    set_of = dict(zip(planes["region_id"].astype(int), planes["set"].astype(int)))
    labelled = regions.region_id >= 0
    assert labelled.mean() > 0.5
    np.testing.assert_array_equal(regions.set[labelled], [set_of[r] for r in regions.region_id[labelled]])
    assert (regions.set[~labelled] == -1).all()
    voxels = read_with(out / "voxel_planes.laz", laspy.LazBackend.Laszip)
    normals = np.column_stack([voxels.nx, voxels.ny, voxels.nz])
    np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-5)
    assert voxels.header.parse_crs().to_epsg() == 32633 and (voxels["count"] > 0).all()


def test_a_text_cloud_at_utm_is_stored_within_a_tenth_of_a_millimetre(tmp_path, capsys):
    scene = outcrop_scene(width=4.0, height=3.0, seed=2, offset=(500_000.0, 4_600_000.0, 300.0))
    cloud = tmp_path / "outcrop.xyz"
    np.savetxt(cloud, scene.cloud.points, fmt="%.6f")
    out = tmp_path / "out"
    code, _, _ = run_cli(capsys, "measure", cloud, "-o", out, "-q", "--crs", UTM_33N)
    assert code == 0
    regions = read_with(out / "regions.laz", laspy.LazBackend.Laszip)
    vertex = PlyData.read(str(out / "regions.ply"))["vertex"].data
    exact = np.column_stack([vertex[a] for a in "xyz"])
    np.testing.assert_array_equal(regions.header.scales, [LAS_QUANTUM] * 3)
    assert np.abs(regions.xyz - exact).max() <= LAS_QUANTUM / 2 + 1e-9
    assert regions.header.parse_crs().to_epsg() == 32633
    assert "set" not in regions.point_format.extra_dimension_names  # no sets asked for
    # `sets` afterwards adds the set dimension, the points on the same integers
    code, _, _ = run_cli(capsys, "sets", out, "-q")
    assert code == 0
    again = laspy.read(str(out / "regions.laz"))
    np.testing.assert_array_equal(again.X, regions.X)
    assert "set" in again.point_format.extra_dimension_names and (again.set >= 0).mean() > 0.5
    assert "regions.laz" in json.loads((out / "run.json").read_text())["outputs"]


def test_without_a_crs_the_laz_claims_none(tmp_path, capsys):
    scene = outcrop_scene(width=4.0, height=3.0, seed=2)
    cloud = tmp_path / "outcrop.xyz"
    np.savetxt(cloud, scene.cloud.points, fmt="%.6f")
    code, _, _ = run_cli(capsys, "measure", cloud, "-o", tmp_path / "out", "-q")
    assert code == 0
    assert laspy.read(str(tmp_path / "out" / "regions.laz")).header.parse_crs() is None


def test_the_grid_coarsens_only_where_32_bits_cannot_reach():
    offset = [0.0, 0.0, 0.0]
    scales, _ = las_grid(np.array([[250_000.0, 10.0, 1.0], [-250_000.0, 0.0, 0.0]]), offset)
    np.testing.assert_allclose(scales, [0.001, 1e-4, 1e-4])  # 250 km / 1e-4 overflows int32
    scales, offsets = las_grid(np.zeros((1, 3)), offset, grid=([0.01] * 3, [5.0] * 3))
    assert scales.tolist() == [0.01] * 3 and offsets.tolist() == [5.0] * 3  # the input's own


CLOUDCOMPARE = shutil.which("CloudCompare")
XVFB = shutil.which("xvfb-run")


def cloudcompare_reads_las(tmp_path) -> bool:
    """Whether this CloudCompare build has a LAS reader (Debian's 2.11.3 has none: it
    answers "unhandled file extension")."""
    probe = tmp_path / "probe.las"
    las = laspy.LasData(laspy.LasHeader(point_format=6, version="1.4"))
    las.x, las.y, las.z = np.zeros((3, 2))
    las.write(str(probe))
    command = [XVFB, "-a", CLOUDCOMPARE, "-SILENT", "-AUTO_SAVE", "OFF", "-O", str(probe)]
    text = subprocess.run(command, capture_output=True, text=True, timeout=120).stdout
    return "unhandled file extension" not in text


@pytest.mark.slow
@pytest.mark.skipif(not (CLOUDCOMPARE and XVFB), reason="CloudCompare and xvfb-run are not installed")
def test_cloudcompare_loads_region_id_from_the_laz(las_input, tmp_path, capsys):
    if not cloudcompare_reads_las(tmp_path):
        pytest.skip("this CloudCompare build reads no LAS/LAZ (Debian's 2.11.3 is built without its LAS plugin)")
    path, _ = las_input
    out = tmp_path / "out"
    assert run_cli(capsys, "measure", path, "-o", out, "-q")[0] == 0
    exported = tmp_path / "regions.asc"
    command = [XVFB, "-a", CLOUDCOMPARE, "-SILENT", "-AUTO_SAVE", "OFF", "-O", "-GLOBAL_SHIFT", "AUTO"]
    command += [str(out / "regions.laz"), "-C_EXPORT_FMT", "ASC", "-PREC", "6", "-ADD_HEADER"]
    command += ["-SAVE_CLOUDS", "FILE", str(exported)]
    subprocess.run(command, check=True, capture_output=True, timeout=120)
    header = exported.read_text().splitlines()[0].split()
    table = np.loadtxt(exported, comments="//")
    regions = laspy.read(str(out / "regions.laz"))
    assert np.abs(table[:, :3] - regions.xyz).max() < 1e-3
    np.testing.assert_array_equal(table[:, header.index("region_id")].astype(int), regions.region_id)


def test_stored_integers_are_laspys_own_and_refuse_what_32_bits_cannot_hold():
    """The writer makes the LAS integers itself (one buffer, no record grown by np.append):
    they must be the very integers laspy's own setter gives, UTM coordinates included."""
    from geostructure.io.laz import stored_integers

    rng = np.random.default_rng(5)
    local = rng.normal(0.0, 300.0, 20_000)
    origin, offset, scale = 4_600_123.4567, 4_600_000.0, 1e-4
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales, header.offsets = [scale] * 3, [offset] * 3
    las = laspy.LasData(header)
    las.x = local + origin
    ours = stored_integers(local, origin, offset, scale, np.empty(len(local)))
    assert np.array_equal(ours.astype(np.int32), np.asarray(las.X))
    with pytest.raises(OverflowError):
        stored_integers(np.array([1e6]), 0.0, 0.0, 1e-4, np.empty(1))


def test_point_sets_are_added_chunk_by_chunk_on_the_same_integers(tmp_path):
    """`sets OUTDIR` writes regions.laz again with set, joint and face_part, a chunk at a time:
    any chunk size gives the same file's points, and a short list of values is an error, not
    a file cut short."""
    from geostructure.core.planes import Planes
    from geostructure.io.laz import add_point_sets, rewrite_point_sets, write_laz

    rng = np.random.default_rng(3)
    points = rng.uniform(0.0, 10.0, (1_003, 3))
    region = rng.integers(-1, 3, len(points)).astype(np.int32)
    source = write_laz(tmp_path / "regions.laz", points, {"region_id": region}, offset=np.array([500_000.0, 0, 0]),
                       origin=np.array([500_000.0, 0, 0]))  # fmt: skip
    planes = Planes(normal=np.eye(3), region_id=[0, 1, 2]).with_columns(set=[1, -1, 0], joint=[5, -1, 6])
    part = rng.integers(0, 3, len(points)).astype(np.uint8)
    whole = laspy.read(str(add_point_sets(source, tmp_path / "whole.laz", planes, part)))
    pieces = laspy.read(str(add_point_sets(source, tmp_path / "pieces.laz", planes, part, rows=97)))
    original = laspy.read(str(source))
    for las in (whole, pieces):
        assert np.array_equal(las.X, original.X) and np.array_equal(las.region_id, region)
        assert np.array_equal(las.set, np.select([region == 0, region == 2], [1, 0], -1))
        assert np.array_equal(las.joint, np.select([region == 0, region == 2], [5, 6], -1))
        assert np.array_equal(las.face_part, part)
    short = iter([{"set": np.zeros(97), "face_part": np.zeros(97), "joint": np.zeros(97)}] * 3)
    with pytest.raises(ValueError, match="more points than"):
        from geostructure.stream.output import rewrite_regions_laz

        rewrite_regions_laz(source, tmp_path / "short.laz", short, 97)
    with pytest.raises(ValueError, match="its set gives 5"):
        rewrite_point_sets(source, tmp_path / "wrong.laz", lambda chunk, start: {"set": np.zeros(5)}, 97)
