import numpy as np
import pytest
from conftest import shared_file
from helpers import write_ply

from geostructure.errors import GeoStructureError, GeoStructureNote, GeoStructureWarning
from geostructure.io.readers import read_cloud


@pytest.fixture
def points():
    rng = np.random.default_rng(0)
    return rng.random((500, 3)) * [10, 20, 5] + [500_000.25, 5_000_000.5, 120.0]


@pytest.mark.parametrize("text", [True, False])
@pytest.mark.parametrize("dtype", ["f4", "f8"])
def test_ply_ascii_and_binary_float_and_double(tmp_path, points, text, dtype):
    path = tmp_path / "c.ply"
    write_ply(path, points, text=text, dtype=dtype)
    if dtype == "f4":  # float32 cannot hold UTM coordinates to the centimetre, and says so
        with pytest.warns(GeoStructureWarning, match="32-bit floats, which at 5,000,020 round to steps of 0.5"):
            cloud = read_cloud(path)
    else:
        cloud = read_cloud(path)
    tol = 1e-9 if dtype == "f8" else 1.0
    np.testing.assert_allclose(cloud.points, points, atol=tol, rtol=0)
    if dtype == "f8":
        assert np.abs(cloud.local).max() < 30  # centred on an offset before any arithmetic


@pytest.mark.parametrize(
    "layout, byte_order",
    [(("x", "y", "z"), "<"), (("z", "x", "y"), "<"), (("y", "intensity", "x", "z"), "<"), (("x", "y", "z"), ">")],
)
def test_ply_doubles_in_any_order_and_byte_order_round_trip_exactly(tmp_path, points, layout, byte_order):
    # x, y and z side by side in native doubles are read as a view of the mapped file; any
    # other layout is copied: both give the file's doubles, bit for bit.
    from plyfile import PlyData, PlyElement

    v = np.zeros(len(points), dtype=[(n, byte_order + ("u2" if n == "intensity" else "f8")) for n in layout])
    for axis, name in enumerate("xyz"):
        v[name] = points[:, axis]
    path = tmp_path / "c.ply"
    PlyData([PlyElement.describe(v, "vertex")], text=False, byte_order=byte_order).write(str(path))
    cloud = read_cloud(path)
    assert np.array_equal(cloud.points, points)
    assert cloud.local.flags.writeable and cloud.local.flags.c_contiguous


def test_a_ply_without_x_y_z_names_what_it_has(tmp_path):
    """PLY names its coordinates x, y and z; a file with other names is refused, saying
    which it has, so that the user sees the cause at once."""
    from plyfile import PlyData, PlyElement

    vertex = np.zeros(5, dtype=[("X", "f8"), ("Y", "f8"), ("Z", "f8")])
    path = tmp_path / "upper.ply"
    PlyData([PlyElement.describe(vertex, "vertex")]).write(str(path))
    with pytest.raises(GeoStructureError, match=r"upper.ply: vertex has no 'x' property \(it has: X, Y, Z\)"):
        read_cloud(path)


def test_a_bad_point_is_named_counting_from_1(tmp_path):
    """A user counts points (and lines) from 1: the third point is point number 3."""
    path = tmp_path / "c.xyz"
    path.write_text("0 0 0\n1 0 0\nnan 1 0\n0 1 0\n")
    with pytest.raises(GeoStructureError, match=r"1 point\(s\) have NaN .* point number 3, counting from 1"):
        read_cloud(path)
    path.write_text("0 0 0\n1 0 0\n0 1 0\n0 1 1e300\n")
    with pytest.raises(GeoStructureError, match=r"point number 4 \(counting from 1\) has a coordinate beyond"):
        read_cloud(path)


def test_ply_mesh_is_sampled_on_its_faces(tmp_path):
    v = np.array([[0, 0, 0], [4, 0, 0], [4, 2, 0], [0, 2, 0]], float)
    path = tmp_path / "m.ply"
    write_ply(path, v, text=True, extra=False, faces=np.array([[0, 1, 2], [0, 2, 3]]))
    cloud = read_cloud(path, mesh_samples=1000)
    assert len(cloud) == 1000
    p = cloud.points
    assert np.allclose(p[:, 2], 0) and p[:, 0].min() >= 0 and p[:, 0].max() <= 4
    assert len(read_cloud(path, mesh_samples=None)) == 4


def test_a_mesh_of_quads_and_polygons_is_sampled_on_all_its_faces(tmp_path):
    """Faces of four or more corners were dropped: a quad mesh was measured on its vertices."""
    from plyfile import PlyData, PlyElement

    v = np.zeros(9, dtype=[("x", "f8"), ("y", "f8"), ("z", "f8")])
    v["x"], v["y"] = [0, 2, 4, 0, 2, 4, 5, 6, 5], [0, 0, 0, 2, 2, 2, 0, 1, 2]
    faces = np.empty(2, dtype=[("vertex_indices", "O")])
    faces["vertex_indices"] = [np.array([0, 1, 4, 3]), np.array([1, 2, 6, 7, 8, 5, 4])]  # a quad, a heptagon
    path = tmp_path / "quads.ply"
    PlyData([PlyElement.describe(v, "vertex"), PlyElement.describe(faces, "face")], text=True).write(str(path))
    p = read_cloud(path, mesh_samples=20_000).points
    assert len(p) == 20_000 and np.allclose(p[:, 2], 0)
    assert abs((p[:, 0] < 2).mean() - 4 / 11) < 0.02  # by area: 4 in the quad, 7 in the heptagon


@pytest.mark.parametrize("suffix", [".las", ".laz"])
def test_las_and_laz_scaled_coordinates(tmp_path, points, suffix):
    import laspy

    header = laspy.LasHeader(point_format=3, version="1.2")
    header.scales = [0.001, 0.001, 0.001]
    header.offsets = [500_000, 5_000_000, 0]
    las = laspy.LasData(header)
    las.x, las.y, las.z = points.T
    path = tmp_path / f"c{suffix}"
    las.write(str(path))
    cloud = read_cloud(path)
    np.testing.assert_allclose(cloud.points, points, atol=0.0006, rtol=0)


def write_marked_las(path, points, classification, withheld, point_format):
    import laspy

    header = laspy.LasHeader(point_format=point_format, version="1.4" if point_format >= 6 else "1.2")
    header.scales, header.offsets = [0.001] * 3, [500_000, 5_000_000, 0]
    las = laspy.LasData(header)
    las.x, las.y, las.z = points.T
    las.classification = classification
    las.withheld = withheld
    las.write(str(path))
    return path


@pytest.mark.parametrize("point_format", [3, 6])
def test_points_a_las_marks_withheld_or_noise_are_left_out(tmp_path, points, point_format):
    """The LAS specification has withheld points treated as deleted; classes 7 (low noise)
    and 18 (high noise, LAS 1.4's formats) are the survey's own noise. They were measured."""
    classification = np.full(len(points), 2, dtype=np.uint8)
    classification[:40] = 7
    if point_format >= 6:
        classification[40:60] = 18
    withheld = np.zeros(len(points), dtype=bool)
    withheld[30:50] = True  # some of them noise too: counted once, as withheld
    path = write_marked_las(tmp_path / "marked.las", points, classification, withheld, point_format)
    with pytest.warns(GeoStructureNote, match="point\\(s\\) left out, as the file marks them: 20 withheld, "):
        cloud = read_cloud(path)
    keep = ~(withheld | np.isin(classification, (7, 18)))
    np.testing.assert_allclose(cloud.points, points[keep], atol=0.0006, rtol=0)
    assert len(cloud.points) == (450 if point_format < 6 else 440)
    noise = 30 if point_format < 6 else 40  # the noise not withheld too
    assert cloud.left_out == {"withheld": 20, "noise": noise}  # for run.json
    from geostructure.io.survey_files import read_tiles

    other = write_marked_las(tmp_path / "other.las", points + [0, 0, 100], classification, withheld, point_format)
    with pytest.warns(GeoStructureNote):
        assert read_tiles([path, other]).left_out == {"withheld": 40, "noise": 2 * noise}
    with pytest.raises(GeoStructureError, match="every point is marked withheld or noise"):
        read_cloud(write_marked_las(tmp_path / "all.las", points, classification, np.ones(len(points), bool), 6))


def test_e57_round_trip_applies_the_scan_pose(tmp_path, points):
    import pye57

    # pye57 stores float32 coordinates: the offset travels in the scan's pose instead.
    offset = np.round(points.mean(axis=0))
    local = points - offset
    path = tmp_path / "c.e57"
    with pye57.E57(str(path), mode="w") as e57:
        e57.write_scan_raw(
            {"cartesianX": local[:, 0], "cartesianY": local[:, 1], "cartesianZ": local[:, 2]},
            translation=offset,
            rotation=np.array([1.0, 0, 0, 0]),
        )
    cloud = read_cloud(path)
    np.testing.assert_allclose(cloud.points, points, atol=1e-5, rtol=0)


@pytest.mark.parametrize(
    "content",
    [
        "{x} {y} {z}\n",
        "{x},{y},{z}\n",
        "{x}\t{y}\t{z}\n",
        "{x};{y};{z}\n",
        "{x} {y} {z} 12 200 3\n",
        "  {x}   {y}  {z}  \n",
    ],
)
@pytest.mark.parametrize("header", ["", "X Y Z R G B\n", "# a comment\n", "x,y,z\n"])
def test_text_layouts(tmp_path, content, header):
    pts = np.array([[1.5, 2.0, 3.25], [4.0, 5.0, 6.0], [7.0, 8.5, 9.0], [1.0, 0.0, 2.0]])
    path = tmp_path / "c.xyz"
    if "," in header and "," not in content:
        header = header.replace(",", " ")
    path.write_text(header + "".join(content.format(x=x, y=y, z=z) for x, y, z in pts))
    np.testing.assert_allclose(read_cloud(path).points, pts)


@pytest.mark.parametrize("separator", [";", "\t", " "])
@pytest.mark.parametrize("header", ["", "x;y;z\n"])
def test_decimal_commas_are_read(tmp_path, separator, header):
    """A spreadsheet in much of Europe saves 657500,25;4984000,5;300,125: it was refused
    ("'5;2' is not a number"), the comma taken for the separator."""
    pts = np.array(
        [[657_500.25, 4_984_000.5, 300.125], [657_501.0, 4_984_001.75, 300.5], [657_502.5, 4_984_000.0, 301.0]]
    )
    rows = [separator.join(f"{v:.3f}".replace(".", ",") for v in row) for row in pts]
    path = tmp_path / "eu.csv"
    path.write_text(header.replace(";", separator) + "\n".join(rows) + "\n")
    np.testing.assert_array_equal(read_cloud(path).points, pts)
    path.write_text(header.replace(";", separator) + "\n".join([*rows, separator.join(["1,5", "2,5", "x"])]) + "\n")
    with pytest.raises(GeoStructureError, match="line .*: 'x' is not a number"):
        read_cloud(path)


@pytest.mark.parametrize(
    "header,row",
    [
        ('"x","y","z"\n', '"{x}","{y}","{z}"\n'),
        ('"id";"x";"y";"z"\n', '"P{i}";"{x:.3f}";"{y:.3f}";"{z:.3f}"\n'),
        ("", '"{x}" "{y}" "{z}" "r"\n'),
    ],
)
def test_quoted_fields_are_read(tmp_path, header, row):
    """Some spreadsheets and scripts quote every field: it was refused ("'"657500.25"' is
    not a number"). Quoted, with decimal commas, and a quoted header naming the columns."""
    pts = np.array(
        [[657_500.25, 4_984_000.5, 300.125], [657_501.0, 4_984_001.75, 300.5], [657_502.5, 4_984_000.0, 301.0]]
    )
    path = tmp_path / "quoted.csv"
    rows = [row.format(i=i, x=x, y=y, z=z) for i, (x, y, z) in enumerate(pts)]
    rows = [r.replace(".", ",") for r in rows] if ";" in row else rows
    path.write_text(header + "".join(rows))
    np.testing.assert_array_equal(read_cloud(path).points, pts)
    path.write_text(header + "".join(rows) + rows[0].replace("657", "6o7"))
    with pytest.raises(GeoStructureError, match="line .*: .* is not a number"):
        read_cloud(path)


@pytest.mark.parametrize(
    "header,row",
    [
        ("id,x,y,z\n", "{i},{x},{y},{z}\n"),
        ("Point;Easting (m);Northing (m);Elevation (m);Intensity\n", "P{i};{x};{y};{z};17\n"),
        ("X Y Z\n", "{x} {y} {z}\n"),
        ('"z","x","y"\n', "{z},{x},{y}\n"),
    ],
)
def test_text_columns_named_by_the_header(tmp_path, header, row):
    """A point id first (id,x,y,z) was read as x, and the true z dropped: exit 0, every
    plane wrong. A header that names the coordinates now says where they are."""
    pts = np.array(
        [[657_500.25, 4_984_000.5, 300.125], [657_501.0, 4_984_001.75, 300.5], [657_502.5, 4_984_000.0, 301.0]]
    )
    path = tmp_path / "survey.csv"
    path.write_text(header + "".join(row.format(i=i, x=x, y=y, z=z) for i, (x, y, z) in enumerate(pts)))
    np.testing.assert_array_equal(read_cloud(path).points, pts)


def test_pts_blocks_open_with_their_point_count(tmp_path):
    """Leica's and FARO's PTS: each scan's block starts with a line of its count. The file was
    refused ("line 1 has 1 field(s)") although .pts is a suffix the reader claims."""
    pts = np.array(
        [[657_500.25, 4_984_000.5, 300.125], [657_501.0, 4_984_001.75, 300.5], [657_502.5, 4_984_000.0, 301.0]]
    )
    rows = [f"{x} {y} {z} -1200 10 20 30\n" for x, y, z in pts]
    path = tmp_path / "scan.pts"
    path.write_text("# two scans\n2\n" + "".join(rows[:2]) + "1\n" + rows[2])
    np.testing.assert_array_equal(read_cloud(path).points, pts)
    path.write_text("2\n" + "".join(rows[:2]) + "1\n" + rows[2].replace("300.5", "x").replace("301.0", "x"))
    with pytest.raises(GeoStructureError, match="line 5: 'x' is not a number"):
        read_cloud(path)


def test_text_in_latitude_and_longitude_is_refused(tmp_path):
    path = tmp_path / "gps.csv"
    path.write_text("Latitude,Longitude,Height\n45.1,7.2,300\n45.2,7.3,301\n45.3,7.1,302\n")
    with pytest.raises(GeoStructureError, match="latitude and longitude, in degrees"):
        read_cloud(path)


@pytest.mark.real_data
def test_real_outcrop_text_in_utm():
    cloud = read_cloud(shared_file("jfm_outcrop_test/test.txt"))
    assert len(cloud) == 1133
    assert cloud.points[:, 1].min() > 5_000_000


@pytest.mark.real_data
def test_real_airborne_laz_with_crs():
    cloud = read_cloud(shared_file("pdal_autzen/autzen_trim.laz"))
    assert len(cloud) == 110_000
    assert cloud.crs and "Lambert" in cloud.crs


@pytest.mark.real_data
def test_real_e57_scan():
    cloud = read_cloud(shared_file("pye57_pump/pumpAVisualReferenceImage.e57"))
    assert len(cloud) == 155_201


@pytest.mark.real_data
def test_real_poisson_mesh_from_the_paper():
    path = shared_file("observatory/dense_poisson_oc_6.ply")
    assert len(read_cloud(path, mesh_samples=None)) == 9693
    cloud = read_cloud(path, mesh_samples=50_000)
    assert len(cloud) == 50_000 and cloud.normals is not None


@pytest.mark.parametrize("control", [b"\x0b", b"\x0c", b"\x00"])
def test_a_control_character_inside_a_row_is_refused_by_line(tmp_path, capsys, control):
    """A vertical tab inside a number at line 300 was read as a break between columns: the
    point kept with a wrong z, 14 planes where the clean file gives 20."""
    from helpers import run_cli

    rows = [f"{x * 0.1:.3f} {y * 0.1:.3f} {0.01 * x:.4f}" for x in range(30) for y in range(30)]
    rows[299] = rows[299][:-2] + control.decode("latin-1") + rows[299][-2:]
    path = tmp_path / "rock.xyz"
    path.write_bytes(("\n".join(rows) + "\n").encode("latin-1"))
    code, _, err = run_cli(capsys, "measure", path, "-o", tmp_path / "out")
    assert code == 2 and "line 300 holds a control character" in err, err
    assert not (tmp_path / "out").exists()


def test_a_text_cloud_rounded_far_coarser_than_its_spacing_is_refused(tmp_path, capsys):
    """An XYZ of a 3 cm face rounded to 0.5 m gave 0 planes and a numpy warning; a cloud
    stored to 1 mm measures as before."""
    from helpers import run_cli, write_xyz

    g = np.mgrid[0:6:0.03, 0:4:0.03].reshape(2, -1).T
    face = np.c_[g[:, 0], 0.3 * g[:, 1], g[:, 1]] + [500_000.0, 5_000_000.0, 300.0]
    write_xyz(tmp_path / "coarse.xyz", np.round(face * 2) / 2)
    code, _, err = run_cli(capsys, "measure", tmp_path / "coarse.xyz", "-o", tmp_path / "out")
    assert code == 2 and "least step between values of 0.5" in err and "heaped" in err, err
    assert not (tmp_path / "out").exists()
    write_xyz(tmp_path / "fine.xyz", np.round(face, 3))
    code, _, err = run_cli(capsys, "measure", tmp_path / "fine.xyz", "-o", tmp_path / "out", "-q")
    assert code == 0 and "step" not in err, err


def test_a_pipe_named_like_a_cloud_is_refused_not_waited_on(tmp_path, capsys):
    import os

    from helpers import run_cli

    fifo = tmp_path / "scan.laz"
    os.mkfifo(fifo)
    code, _, err = run_cli(capsys, "measure", fifo, "-o", tmp_path / "out")
    assert code == 2 and "not a regular file" in err, err
