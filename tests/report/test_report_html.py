"""report.html without a browser: projection arithmetic, payload contents, bad folders."""

import json
import re

import numpy as np
import pytest

from geostructure.cli import main
from geostructure.core.projection import great_circle_xy, pole_density, pole_xy
from geostructure.evaluation.groundtruth import match_scene
from geostructure.io.writers import write_evaluation, write_outputs
from geostructure.report.html import build_report
from geostructure.report.scene import load_scene


def payload(html: str) -> dict:
    match = re.search(r'<script id="payload" type="application/json">(.*?)</script>', html, re.S)
    return json.loads(match.group(1))


def test_pole_projection_agrees_with_mplstereonet():
    import warnings

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    with warnings.catch_warnings():  # mplstereonet 0.6's Axes.cla override
        warnings.simplefilter("ignore", PendingDeprecationWarning)
        import mplstereonet

    ax = plt.figure().add_subplot(111, projection="stereonet")
    for dip_direction, dip in [(89, 40), (0, 10), (225, 75), (300, 89.5)]:
        lon, lat = mplstereonet.pole(dip_direction - 90, dip)
        expected = ax.transProjection.transform(np.column_stack([lon, lat]))[0] / np.sqrt(2)
        np.testing.assert_allclose(np.ravel(pole_xy(dip_direction, dip)), expected, atol=1e-9)
    plt.close("all")
    # dip 40 towards 089: pole plunges 50 towards 269, Lambert radius sqrt(2) sin(20 deg).
    x, y = pole_xy(89, 40)
    assert np.hypot(x, y) == pytest.approx(np.sqrt(2) * np.sin(np.radians(20)))
    assert np.degrees(np.arctan2(x, y)) % 360 == pytest.approx(269)


def test_great_circle_runs_strike_to_strike_through_the_dip_line():
    x, y = great_circle_xy(89, 40)
    assert np.hypot(x[0], y[0]) == pytest.approx(1) and np.hypot(x[-1], y[-1]) == pytest.approx(1)
    assert np.degrees(np.arctan2(x[0], y[0])) % 360 == pytest.approx(359)  # the strike
    mid = len(x) // 2  # the dip line: plunge 40 to 089
    assert np.hypot(x[mid], y[mid]) == pytest.approx(np.sqrt(2) * np.sin(np.radians(25)))
    assert np.degrees(np.arctan2(x[mid], y[mid])) == pytest.approx(89)


def test_pole_density_peaks_on_the_cluster():
    rng = np.random.default_rng(0)
    dd, dip = 120 + rng.normal(0, 3, 40), 30 + rng.normal(0, 3, 40)
    x, y, density = pole_density(np.r_[dd, rng.uniform(0, 360, 10)], np.r_[dip, rng.uniform(0, 90, 10)])
    row, col = np.unravel_index(np.nanargmax(density), density.shape)
    px, py = pole_xy(120, 30)
    assert np.hypot(x[col] - px, y[row] - py) < 0.06
    assert np.isnan(density[0, 0])  # outside the primitive circle


@pytest.fixture(scope="module")
def measured(tmp_path_factory, scene, scene_result):
    out = tmp_path_factory.mktemp("report")
    write_outputs(scene_result, out)
    write_evaluation(match_scene(scene_result, scene), out)
    return out


def test_report_is_self_contained_and_lists_every_plane(measured, scene_result):
    path = build_report(measured, max_points=5_000)
    html = path.read_text()
    assert not re.search(r"<(script|link)[^>]+(src|href)=", html), "the page must not load anything"
    data = payload(html)
    ids = [p["region_id"] for p in data["planes"]]
    assert ids == list(range(len(scene_result)))
    assert data["meta"]["points_shown"] == 5_000 and data["meta"]["points_total"] == len(scene_result.filtered)
    first = data["planes"][0]
    assert first["dip"] == pytest.approx(scene_result.orientation.dip[0])
    # the largest plane is the ground (no truth surface); the first that is one reads its error
    matched = next(p for p in data["planes"] if "truth" in p)
    assert matched["truth_error"] < 0.5 and matched["truth"]["surface"]
    # the rectangle drawn is the region plane's, in offset-free coordinates
    expected = scene_result.planes.local_corners[0] + scene_result.cloud.offset - np.array(data["meta"]["offset"])
    np.testing.assert_allclose(np.array(first["corners"]), expected, atol=1e-3)
    assert data["scene"]["data"][3]["type"] == "mesh3d" and len(data["stereonet"]["data"]) >= 4


def test_report_warns_when_a_reconstruction_is_only_approximately_referenced(tmp_path, scene_result):
    from geostructure.reconstruct.georef import manual

    plain = tmp_path / "plain"
    write_outputs(scene_result, plain)
    assert payload(build_report(plain, max_points=1_000).read_text())["meta"]["georeference"] is None
    level = manual([0, 0, 1], [0, 1, 0]).to_dict() | {"source": "cameras-level", "approximate": True}
    gcp = manual([0, 0, 1], [0, 1, 0]).to_dict() | {"source": "gcp", "residuals": {"a": 0.01}, "rms_residual": 0.01}
    for record, warned in ((level, True), (gcp, False)):
        out = tmp_path / record["source"]
        write_outputs(scene_result, out, extra={"reconstruction": {"georef": record}})
        note = payload(build_report(out, max_points=1_000).read_text())["meta"]["georeference"]
        assert note["text"].startswith(record["source"])
        assert (note["warning"] is not None) is warned
        if warned:
            assert "azimuths relative to the view" in note["warning"]


def test_decimation_keeps_regions_and_is_seeded(measured):
    a, b = load_scene(measured, max_points=2_000), load_scene(measured, max_points=2_000)
    np.testing.assert_array_equal(a.points, b.points)
    assert len(a.points) == 2_000 and (a.point_region >= 0).mean() > 0.5
    assert len(a.voxel_centroids) > 0 and np.allclose(np.linalg.norm(a.voxel_normals, axis=1), 1, atol=1e-5)


def test_report_command_refuses_a_folder_without_a_run(tmp_path, capsys):
    assert main(["report", str(tmp_path), "-q"]) == 2
    err = capsys.readouterr().err
    assert "planes.csv" in err or "run.json" in err
    assert "Traceback" not in err and not (tmp_path / "report.html").exists()


def test_the_triad_stands_beside_the_cloud_as_the_camera_sees_it(measured):
    """The north and Up arrows and the scale bar were drawn at the cloud's lowest corner in
    the cloud's axes: cut by the view's edge from the south (the demo), over the rock on a
    face. On the screen they must lie left of or below every point, and every axis must
    get ticks in proportion to its length on the screen."""
    from geostructure.report.view3d import screen_axes

    scene = payload(build_report(measured, max_points=5_000).read_text())["scene"]
    camera = scene["layout"]["scene"]["camera"]
    eye = np.array([camera["eye"][a] for a in "xyz"])
    axes = screen_axes(eye, np.array([camera["up"][a] for a in "xyz"]))
    cloud = next(t for t in scene["data"] if t.get("mode") == "markers")
    points = np.c_[[np.asarray(decoded(cloud[a]), dtype=float) for a in "xyz"]].T @ axes.T
    triad = [t for t in scene["data"] if t.get("mode") == "lines+text"]
    assert [t["text"][1] for t in triad][1:] == ["N", "Up"]
    for line in triad:
        ends = np.c_[[np.asarray(line[a], dtype=float) for a in "xyz"]].T @ axes.T
        left, below = ends[:, 0].max() < points[:, 0].min(), ends[:, 1].max() < points[:, 1].min()
        assert left or below, line["name"]
    ticks = [scene["layout"]["scene"][f"{a}axis"]["nticks"] for a in "xyz"]
    assert min(ticks) >= 2 and max(ticks) == 8


def decoded(values):
    """A plotly typed array (``{"dtype", "bdata"}``) or a list, as numbers."""
    import base64

    if isinstance(values, dict):
        return np.frombuffer(base64.b64decode(values["bdata"]), dtype=values["dtype"])
    return values
