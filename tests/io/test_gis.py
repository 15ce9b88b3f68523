"""GIS files (issue "Outputs"): planes.geojson in WGS84 (RFC 7946) and planes.gpkg in the
cloud's own CRS, read back with GDAL (pyogrio, and ``ogrinfo`` where Debian's gdal-bin is
installed), the planes where pyproj puts them."""

import json
import shutil
import subprocess

import numpy as np
import pytest
import shapely
from conftest import shared_file
from helpers import run_cli
from pyogrio import read_info
from pyogrio.raw import read as read_layer
from pyproj import Transformer

from geostructure.io.gis import NO_CRS_NOTE
from geostructure.synthetic import outcrop_scene

UTM_33N = "EPSG:32633"


@pytest.fixture(scope="module")
def utm_run(tmp_path_factory):
    """A synthetic outcrop at UTM 33N coordinates, as a text cloud that declares no CRS."""
    tmp = tmp_path_factory.mktemp("gis")
    scene = outcrop_scene(width=6.0, height=4.0, seed=1, offset=(500_000.0, 4_600_000.0, 300.0))
    cloud = tmp / "outcrop.xyz"
    np.savetxt(cloud, scene.cloud.points, fmt="%.4f")
    out = tmp / "out"
    return cloud, out, scene


def centroids_csv(out):
    import csv

    rows = list(csv.DictReader(open(out / "planes.csv")))
    return np.array([[float(r[f"centroid_{a}"]) for a in "xyz"] for r in rows])


def test_without_a_crs_no_gis_file_and_one_line_saying_how(utm_run, capsys, tmp_path):
    """A note, in memory and streamed alike, and, as every note, not under ``-q``."""
    cloud, out, _ = utm_run
    code, _, err = run_cli(capsys, "measure", cloud, "-o", out, "-q")
    assert code == 0 and err == ""
    assert not (out / "planes.geojson").exists() and not (out / "planes.gpkg").exists()
    for options in ([], ["--engine", "stream", "--detector", "voxel"]):
        code, _, err = run_cli(capsys, "measure", cloud, "-o", tmp_path / f"o{len(options)}", *options)
        assert code == 0
        assert [line for line in err.splitlines() if "note:" in line] == [f"geostructure: note: {NO_CRS_NOTE}"]
        assert not (tmp_path / f"o{len(options)}" / "planes.geojson").exists()


def test_with_crs_the_geopackage_is_native_and_the_geojson_wgs84(utm_run, capsys):
    cloud, out, _ = utm_run
    code, _, _ = run_cli(capsys, "measure", cloud, "-o", out, "-q", "--crs", UTM_33N, "--sets")
    assert code == 0
    assert json.loads((out / "run.json").read_text())["crs"] == UTM_33N
    native = centroids_csv(out)
    # GeoPackage: the cloud's CRS, every column (the set too), centroids as 3-D points, exact
    info = read_info(out / "planes.gpkg", layer="centroids")
    assert info["crs"] == UTM_33N and info["geometry_type"] == "Point Z" and info["features"] == len(native)
    assert {"dip", "dip_direction", "strike", "set", "trace_strike_m"} <= set(info["fields"])
    _, _, geometry, _ = read_layer(out / "planes.gpkg", layer="centroids")
    np.testing.assert_allclose(shapely.get_coordinates(shapely.from_wkb(geometry), include_z=True), native, atol=1e-6)
    assert read_info(out / "planes.gpkg", layer="planes")["geometry_type"] == "Polygon Z"
    # GeoJSON: RFC 7946, longitude and latitude; no crs member
    data = json.loads((out / "planes.geojson").read_text())
    assert "crs" not in data and "crs_wkt" not in data
    assert read_info(out / "planes.geojson")["crs"] in ("EPSG:4326", "EPSG:4979")
    to_wgs84 = Transformer.from_crs(UTM_33N, "EPSG:4326", always_xy=True)
    back = Transformer.from_crs("EPSG:4326", UTM_33N, always_xy=True)
    for feature, centre in zip(data["features"], native):
        ring = np.array(feature["geometry"]["coordinates"][0])
        assert 14.9 < ring[0, 0] < 15.1 and 41.5 < ring[0, 1] < 41.6  # UTM 33N, 500 km E, 4600 km N
        x, y = back.transform(ring[:-1, 0].mean(), ring[:-1, 1].mean())
        assert np.hypot(x - centre[0], y - centre[1]) < 1.0  # the rectangle's middle, near its centroid
    lon, lat = to_wgs84.transform(native[0, 0], native[0, 1])
    assert abs(lon - 15.0) < 0.1 and abs(lat - 41.55) < 0.1


def test_a_bad_crs_is_refused_before_any_work(utm_run, capsys, tmp_path):
    cloud, _, _ = utm_run
    code, _, err = run_cli(capsys, "measure", cloud, "-o", tmp_path / "o", "--crs", "EPSG:999999")
    assert code == 2 and "--crs" in err and "Traceback" not in err
    assert not (tmp_path / "o").exists()


@pytest.mark.real_data
def test_a_las_crs_is_kept_and_the_planes_land_in_oregon(tmp_path, capsys):
    """autzen: Oregon Lambert in feet, declared by the file; GDAL places the planes in Oregon."""
    out = tmp_path / "autzen"
    code, _, _ = run_cli(capsys, "measure", shared_file("pdal_autzen/autzen_trim.laz"), "-o", out, "-q")
    assert code == 0
    native = centroids_csv(out)
    crs = json.loads((out / "run.json").read_text())["crs"]
    to_wgs84 = Transformer.from_crs(crs, "EPSG:4326", always_xy=True)
    lon, lat = to_wgs84.transform(native[:, 0], native[:, 1])
    assert (-124 < lon).all() and (lon < -122).all() and (43.5 < lat).all() and (lat < 44.5).all()  # Eugene
    data = json.loads((out / "planes.geojson").read_text())
    first = np.array(data["features"][0]["geometry"]["coordinates"][0])
    assert -124 < first[0, 0] < -122 and 43.5 < first[0, 1] < 44.5
    if shutil.which("ogrinfo"):  # the real client, from Debian's gdal-bin
        text = subprocess.run(
            ["ogrinfo", "-so", "-al", str(out / "planes.gpkg")], capture_output=True, text=True
        ).stdout
        assert "Lambert" in text and "Feature Count: " in text
        text = subprocess.run(
            ["ogrinfo", "-so", "-al", str(out / "planes.geojson")], capture_output=True, text=True
        ).stdout
        assert "WGS 84" in text and "Extent: (-12" in text
    # Issue 45: the GeoJSON's properties were Oregon feet beside WGS84 geometry
    feet = json.loads((out / "run.json").read_text())
    properties = [feature["properties"] for feature in data["features"]]
    assert not any(name in p for p in properties for name in ("centroid_x", "centroid_y", "rect_center_x"))
    centres = np.array([[p["centroid_lon"], p["centroid_lat"], p["centroid_height_m"]] for p in properties])
    np.testing.assert_allclose(centres[:, 0], lon, atol=1e-9)
    np.testing.assert_allclose(centres[:, 1], lat, atol=1e-9)
    np.testing.assert_allclose(
        centres[:, 2], native[:, 2] * 0.3048, rtol=1e-9
    )  # international feet (the CRS) to metres
    assert feet["crs"]
    # Issue 52: its sizes were Oregon feet beside metres; its all-empty columns read as text
    csv_rows = list(__import__("csv").DictReader(open(out / "planes.csv")))
    for p, row in zip(properties, csv_rows):
        assert "rect_width" not in p and p["rect_width_m"] == pytest.approx(float(row["rect_width"]) * 0.3048)
        assert p["fit_residual_m"] == pytest.approx(float(row["fit_residual"]) * 0.3048)
    assert not any("facing" in p for p in properties) or any(p.get("facing") is not None for p in properties)
    if shutil.which("ogrinfo"):
        text = subprocess.run(["ogrinfo", "-so", "-al", str(out / "planes.geojson")], capture_output=True, text=True)
        assert "centroid_lon: Real" in text.stdout and "centroid_x" not in text.stdout
        assert "rect_width_m: Real" in text.stdout and "facing: String" not in text.stdout


def _orientations(out):
    import csv

    rows = list(csv.DictReader(open(out / "planes.csv")))
    return np.array([[float(r["dip"]), float(r["dip_direction"])] for r in rows])


@pytest.mark.parametrize("engine", ["memory", "stream"])
def test_azimuths_are_read_against_true_north(tmp_path, capsys, engine):
    """UTM 33N two degrees east of its central meridian, at 45 N: grid north lies 1.41
    degrees east of true north (Delta lambda sin phi). The dip directions are the grid's
    plus that convergence, the dips the same; --grid-north keeps the grid's. Streamed, the
    --crs given is the survey's too (it was once dropped: no GIS file, no CRS recorded)."""
    scene = outcrop_scene(width=6.0, height=4.0, seed=1, offset=(657_500.0, 4_984_000.0, 300.0))
    cloud = tmp_path / "outcrop.xyz"
    np.savetxt(cloud, scene.cloud.points, fmt="%.4f")
    options = ["--crs", UTM_33N, "--engine", engine, "-q"] + (["--detector", "voxel"] if engine == "stream" else [])
    runs = {}
    for north in ("true", "grid"):
        out = tmp_path / north
        code, _, _ = run_cli(
            capsys, "measure", cloud, "-o", out, *options, *(["--grid-north"] if north == "grid" else [])
        )
        assert code == 0 and (out / "planes.gpkg").exists()
        runs[north] = (_orientations(out), json.loads((out / "run.json").read_text()))
    (true, record), (grid, grid_record) = runs["true"], runs["grid"]
    gamma = record["north"]["grid_convergence_deg"]
    assert gamma == pytest.approx(1.41, abs=0.01) and record["crs"] == UTM_33N and "north" not in grid_record
    assert record["unit"] == grid_record["unit"] == {"symbol": "m", "metres": 1.0}
    assert record["frame"]["name"] == "enu, true north" and grid_record["frame"]["name"] == "enu"
    np.testing.assert_allclose(true[:, 0], grid[:, 0], atol=1e-9)
    turned = (true[:, 1] - grid[:, 1] + 180.0) % 360.0 - 180.0
    np.testing.assert_allclose(turned[true[:, 0] > 1.0], gamma, atol=1e-6)
    if engine == "memory":  # the report's header says which north, and by how much
        assert run_cli(capsys, "report", tmp_path / "true", "-q")[0] == 0
        assert "true north (grid convergence +1.41" in (tmp_path / "true" / "report.html").read_text()


@pytest.mark.parametrize("engine", ["memory", "stream"])
def test_a_crs_given_over_the_files_own_is_warned_of(tmp_path, capsys, engine):
    """A LAS declaring UTM 33N given --crs in Oregon feet was measured in feet without a
    word (its sizes read 3.28 times too large, its planes placed in Oregon). --crs still wins,
    as it fixes a mislabelled file, but the command now says so; the same CRS passes quietly."""
    import laspy
    from pyproj import CRS

    points = outcrop_scene(width=6.0, height=4.0, seed=1, offset=(657_500.0, 4_984_000.0, 300.0)).cloud.points
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales, header.offsets = [0.001] * 3, [657_000.0, 4_984_000.0, 0.0]
    header.add_crs(CRS.from_user_input(UTM_33N))
    las = laspy.LasData(header)
    las.x, las.y, las.z = points.T
    las.write(str(tmp_path / "utm.las"))
    options = ["--engine", engine, "-q"] + (["--detector", "voxel"] if engine == "stream" else [])
    code, _, err = run_cli(capsys, "measure", tmp_path / "utm.las", "-o", tmp_path / "same", "--crs", UTM_33N, *options)
    assert code == 0 and "warning" not in err, err
    code, _, err = run_cli(
        capsys, "measure", tmp_path / "utm.las", "-o", tmp_path / "other", "--crs", "EPSG:2992", *options
    )
    assert code == 0 and "declares WGS 84 / UTM zone 33N, but --crs gives NAD83 / Oregon GIC Lambert (ft)" in err, err
    assert json.loads((tmp_path / "other" / "run.json").read_text())["unit"]["symbol"] == "ft"


@pytest.mark.real_data
def test_the_geopackage_holds_the_traces_as_lines_in_the_crs(tmp_path, capsys):
    """Issue 55: the traces as lines in the GeoPackage, in the cloud's CRS, as GDAL reads them."""
    out = tmp_path / "lastoni"
    cloud = shared_file("dice_lastoni_sw/Lastoni_SW_3cm.txt")
    code, _, _ = run_cli(capsys, "measure", cloud, "-o", out, "--sets", "--crs", "EPSG:32633", "-q")
    assert code == 0
    import pyogrio

    layers = [name for name, _ in pyogrio.list_layers(out / "planes.gpkg")]
    assert layers == ["planes", "centroids", "traces"]
    info = read_info(out / "planes.gpkg", layer="traces")
    with open(out / "traces.csv", newline="") as fh:
        rows = list(__import__("csv").DictReader(fh))
    assert info["features"] == len(rows) > 0 and info["geometry_type"] == "LineString Z"
    assert "32633" in info["crs"]
    _, _, geometry, fields = read_layer(out / "planes.gpkg", layer="traces")
    lengths = fields[list(info["fields"]).index("length")]
    assert lengths == pytest.approx([float(r["length_m"]) for r in rows])  # metres: the cloud's unit here
    first = shapely.from_wkb(geometry[0])
    assert 276_000 < first.coords[0][0] < 278_000 and first.has_z  # in UTM, not moved
    if shutil.which("ogrinfo"):
        text = subprocess.run(["ogrinfo", "-so", str(out / "planes.gpkg"), "traces"], capture_output=True, text=True)
        assert "3D Line String" in text.stdout and f"Feature Count: {len(rows)}" in text.stdout
