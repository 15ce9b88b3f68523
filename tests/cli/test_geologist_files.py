"""What a geologist opens (issue 45): each file's columns say what they hold, in the
client the user has."""

import csv

import numpy as np
import pytest
from helpers import run_cli, scene_points, write_xyz


def dips_rows(out) -> np.ndarray:
    """(dip direction, dip, east, north, elevation, points) of planes_dips.csv's large planes."""
    rows = list(csv.DictReader(open(out / "planes_dips.csv")))
    table = np.array([[float(r[c]) for c in ("Dip Direction", "Dip", "X (East)", "Y (North)", "Z (Elev.)", "Points")]
                      for r in rows])  # fmt: skip
    return table[table[:, 5] >= 1000]


def turned(rotation: np.ndarray, points: np.ndarray) -> np.ndarray:
    """ENU points written in a cloud whose axes are ``rotation``'s rows' duals: cloud = R^T enu."""
    return points @ rotation


@pytest.mark.parametrize("frame", ["paper", "vectors"])
def test_dips_locations_are_east_north_and_elevation_in_every_frame(tmp_path, capsys, frame):
    """planes_dips.csv's X (East) and Y (North) held the cloud's raw x and y whatever the
    frame: in the paper frame (x north) Dips placed every plane a quarter turn away."""
    enu = scene_points(20_000, seed=3)
    assert run_cli(capsys, "measure", write_xyz(tmp_path / "enu.xyz", enu), "-o", tmp_path / "enu", "-q")[0] == 0
    if frame == "paper":
        rotation = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # rows: east, north, up
        options = ["--frame", "paper"]
    else:
        angle = np.radians(35.0)
        rotation = np.array([[np.cos(angle), np.sin(angle), 0.0], [-np.sin(angle), np.cos(angle), 0.0], [0, 0, 1.0]])
        options = ["--up", *map(str, rotation[2]), "--north", *map(str, rotation[1])]
    cloud = write_xyz(tmp_path / "turned.xyz", turned(rotation, enu))
    assert run_cli(capsys, "measure", cloud, "-o", tmp_path / "turned", "-q", *options)[0] == 0
    truth, found = dips_rows(tmp_path / "enu"), dips_rows(tmp_path / "turned")
    assert len(truth) >= 5
    for plane in truth:
        axial = np.abs((found[:, 0] - plane[0] + 180) % 360 - 180) + np.abs(found[:, 1] - plane[1])
        near = np.linalg.norm(found[:, 2:5] - plane[2:5], axis=1)
        best = np.argmin(axial + near)
        assert axial[best] < 2.0 and near[best] < 0.1, (plane, found[best])


@pytest.fixture(scope="module")
def outcrop_sets(tmp_path_factory):
    """The synthetic outcrop's default size (20 x 9 m), measured with --sets."""
    from geostructure.synthetic import outcrop_scene

    folder = tmp_path_factory.mktemp("outcrop_sets")
    cloud = write_xyz(folder / "outcrop.xyz", outcrop_scene(seed=0).cloud.points)
    return cloud, folder / "out"


def test_no_mean_trace_is_longer_than_the_exposure(outcrop_sets, capsys):
    """The 20 m face gave mean traces of 22.1 and 32.9 m (and, before, 106.3 m with a standard
    error as large): no face this size measures them. Now a bound, a flag and a sentence."""
    from geostructure.rockmass.tracelengths import persistence_class

    cloud, out = outcrop_sets
    code, stdout, _ = run_cli(capsys, "measure", cloud, "-o", out, "--sets")
    assert code == 0
    rows = list(csv.DictReader(open(out / "sets.csv")))
    flagged = [r for r in rows if "trace_longer_than_exposure" in r["flags"].split(";")]
    assert flagged
    for row in rows:
        mean, span = float(row["joint_trace_mean_m"]), float(row["exposure_span_m"])
        assert 15.0 < span < 25.0  # the 20 x 9 m face's diagonal
        assert np.isnan(mean) or mean <= span
    for row in flagged:
        assert float(row["joint_trace_estimate_m"]) > float(row["exposure_span_m"])
        assert row["persistence"] == persistence_class(float(row["exposure_span_m"]), at_least=True)
        assert f"Set {row['set']}'s joint traces, most of them running out of sight" in " ".join(stdout.split())


@pytest.mark.real_data
def test_no_block_volume_from_fewer_than_three_sets(tmp_path, capsys):
    """The indoor pump room's one 'set' (its floor and shelves) gave an 11 m³ block."""
    import json

    from conftest import shared_file

    out = tmp_path / "pump"
    code, stdout, _ = run_cli(capsys, "measure", shared_file("pye57_pump/pumpAVisualReferenceImage.e57"), "-o", out,
                              "--sets", "--report")  # fmt: skip
    assert code == 0
    rock = json.loads((out / "run.json").read_text())["sets"]["rock_mass"]
    measured = [r for r in csv.DictReader(open(out / "sets.csv")) if np.isfinite(float(r["spacing_m"]))]
    assert len(measured) < 3 and rock["block_volume_m3"] is None and rock["jv_lower_bound"] is True
    assert "Jv at least" in " ".join(stdout.split()) and "RQD at most" in " ".join(stdout.split())
    assert "no block volume" in " ".join(stdout.split()) and "m³ (large)" not in stdout
    assert "no block volume" in (out / "report.html").read_text()


@pytest.mark.real_data
def test_a_run_says_how_few_points_lie_in_a_plane(tmp_path, capsys):
    """On jfm_outcrop_test a third of the points end in a plane, and the command said nothing."""
    from conftest import shared_file

    code, _, err = run_cli(capsys, "measure", shared_file("jfm_outcrop_test/test.txt"), "-o", tmp_path / "o")
    assert code == 0
    line = next(line for line in err.splitlines() if "lie in a plane" in line)
    assert "of the 1,132 points" in line and "note:" in line


@pytest.mark.real_data
def test_files_that_do_not_touch_are_measured_with_a_note(tmp_path, capsys):
    """A folder of two unrelated clouds (a town and a test scene 160 m below it) was merged
    into one cloud without a word, and the table was titled with the last file's name."""
    from conftest import shared_file

    folder = shared_file("odmsemantic3d/test.laz").parent
    code, stdout, err = run_cli(capsys, "measure", folder, "-o", tmp_path / "o")
    assert code == 0
    assert "2 groups that do not touch (brighton_small.laz; test.laz)" in " ".join(err.split())
    assert "Planes in brighton_small.laz, test.laz" in stdout


def test_a_level_plane_prints_no_azimuth(tmp_path, capsys):
    rng = np.random.default_rng(2)
    level = np.c_[rng.random((4000, 2)) * 10, rng.normal(0, 0.002, 4000)]
    code, stdout, _ = run_cli(capsys, "measure", write_xyz(tmp_path / "level.xyz", level), "-o", tmp_path / "o")
    assert code == 0
    row = next(line for line in stdout.splitlines() if line.startswith("│  0 │"))
    assert row.count("level") == 2  # strike and dip direction
    assert float(next(csv.DictReader(open(tmp_path / "o" / "planes.csv")))["dip"]) < 0.1
    assert "\n1 plane from 4,000 points" in stdout


def test_set_wording_agrees_with_its_numbers(tmp_path, capsys):
    from geostructure.errors import GeoStructureWarning
    from geostructure.rockmass.sets import find_sets

    normals = np.array([[0.0, 0.0, 1.0], [0.0, 0.05, 1.0], [0.05, 0.0, 1.0], [1.0, 0, 0.1]])
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    with pytest.warns(GeoStructureWarning, match="4 planes make at most 1 set of 3 planes, not the 2 asked for"):
        find_sets(normals, n_sets=2)


def report_payload(folder) -> dict:
    import json
    import re

    html = (folder / "report.html").read_text()
    return json.loads(re.search(r'<script id="payload" type="application/json">(.*?)</script>', html, re.S).group(1))


@pytest.mark.real_data
def test_the_report_gives_areas_in_square_metres_and_blanks_for_no_set(tmp_path, capsys):
    """pdal_autzen (Oregon feet): the set table said m² and the plane table ft² on one page;
    -1 stood for "no set" and "no joint"."""
    from conftest import shared_file

    out = tmp_path / "autzen"
    code, _, _ = run_cli(capsys, "measure", shared_file("pdal_autzen/autzen_trim.laz"), "-o", out, "--sets",
                         "--report", "-q")  # fmt: skip
    assert code == 0
    page = report_payload(out)
    labels = {c["key"]: c["label"] for c in page["columns"]}
    assert labels["area_m2"] == "Area (m²)" and labels["fit_residual"] == "Roughness (ft)"
    table = {int(r["region_id"]): r for r in csv.DictReader(open(out / "planes.csv"))}
    for row in page["planes"]:
        assert row["area_m2"] == pytest.approx(float(table[row["region_id"]]["area_m2"]), rel=1e-9)
        written = int(table[row["region_id"]]["set"])
        assert row["set"] == (None if written < 0 else written)
    assert any(row["set"] is None for row in page["planes"])


def test_the_report_net_names_its_envelopes_and_kinematics_per_plane(outcrop_sets, tmp_path, capsys):
    from geostructure.report.view3d import SET_COLORS, TOPPLING_COLOR

    cloud, _ = outcrop_sets
    out = tmp_path / "k"
    assert run_cli(capsys, "measure", cloud, "-o", out, "-q", "--sets", "--kinematics", "--friction", "30",
                   "--report")[0] == 0  # fmt: skip
    page = report_payload(out)
    net = page["stereonet"]
    assert net["layout"]["showlegend"] is True
    named = {t.get("name") for t in net["data"] if t.get("showlegend") is not False}
    assert {"toppling envelope", "planar daylight envelope", "pole friction cone", "set 0"} <= named
    assert "primitive" not in named and "selected pole" not in named
    kinds = {row["kinematics"] for row in page["planes"]}
    assert "not critical" in kinds and any(k.startswith("planar sliding (FS ") for k in kinds)
    assert TOPPLING_COLOR not in SET_COLORS  # orange was a set's, the toppling poles' and its envelope's


@pytest.mark.real_data
def test_no_kamb_contours_from_a_handful_of_poles(tmp_path, capsys):
    from conftest import shared_file

    from geostructure.report.stereonet import MIN_CONTOUR_POLES

    out = tmp_path / "jfm"
    code, _, _ = run_cli(capsys, "measure", shared_file("jfm_outcrop_test/test.txt"), "-o", out, "--report", "-q")
    assert code == 0
    planes = list(csv.DictReader(open(out / "planes.csv")))
    assert len(planes) < MIN_CONTOUR_POLES
    assert not [t for t in report_payload(out)["stereonet"]["data"] if t["type"] == "contour"]


def test_the_report_shows_the_tables_spacing_and_a_scaled_3d_view(outcrop_sets, tmp_path, capsys):
    """The spacing histogram fitted the gaps (mean 0.41 m) while the table said 6.16 m, with
    nothing on the plot to say which was the set's; the 3D view had no scale bar, no unit on
    its axes, and its Up label was cut at the view's edge."""
    cloud, _ = outcrop_sets
    out = tmp_path / "r"
    assert run_cli(capsys, "measure", cloud, "-o", out, "-q", "--sets", "--report")[0] == 0
    page = report_payload(out)
    rows = {int(r["set"]): float(r["spacing_m"]) for r in csv.DictReader(open(out / "sets.csv"))}
    names = [t.get("name", "") for t in page["spacing"]["data"]]
    for s, spacing in rows.items():
        assert any(n.startswith(f"set {s}: spacing {spacing:.2f} m (the table's") for n in names), names
    scene = page["scene"]["layout"]["scene"]
    assert [scene[f"{a}axis"]["title"]["text"] for a in "xyz"] == ["x (m)", "y (m)", "z (m)"]
    triad = [t for t in page["scene"]["data"] if t.get("mode") == "lines+text"]
    assert [t["text"][1] for t in triad][1:] == ["N", "Up"] and triad[0]["text"][1].endswith(" m")
    for trace in triad:  # every label inside the view's box
        for axis in "xyz":
            low, high = scene[f"{axis}axis"]["range"]
            assert all(low <= v <= high for v in trace[axis])


def test_a_level_plane_has_no_dip_direction_in_the_files(tmp_path, capsys):
    """The demo's ground printed a dip direction of 75.15 at a dip of 0.0007 degrees in
    planes.csv: a number there is read as a direction. Now blank where the dip is under two
    of its standard errors; Dips, which needs a number, gets 0 (its pole at the centre)."""
    cloud = write_xyz(tmp_path / "scene.xyz", scene_points(20_000, seed=3))
    assert run_cli(capsys, "measure", cloud, "-o", tmp_path / "out", "-q")[0] == 0
    rows = list(csv.DictReader(open(tmp_path / "out" / "planes.csv")))
    dip = np.array([float(r["dip"]) for r in rows])
    se = np.array([float(r["dip_uncertainty_deg"]) for r in rows])
    dd = np.array([float(r["dip_direction"]) for r in rows])
    level = dip < 2 * se
    assert level.any() and (dip[level] < 1.0).all()  # a small near-level patch
    assert np.isnan(dd[level]).all() and np.isfinite(dd[~level]).all()
    dips = list(csv.DictReader(open(tmp_path / "out" / "planes_dips.csv")))
    assert [float(r["Dip Direction"]) for r, flat in zip(dips, level) if flat] == [0.0] * int(level.sum())
    assert run_cli(capsys, "report", tmp_path / "out")[0] == 0
