"""Georeferencing: similarity from control points, manual frame, EXIF GPS arithmetic."""

import numpy as np
import pytest
from conftest import random_rotation, shared_file

from geostructure.core.geodesy import enu_to_geodetic, geodetic_to_enu
from geostructure.core.orientation import angle_between_vectors
from geostructure.errors import GeoStructureError
from geostructure.reconstruct.georef import gps_from_exif, manual, read_gcp, read_gcp_csv, solve_gcp, umeyama


def test_umeyama_recovers_a_similarity_in_utm_sized_coordinates():
    rng = np.random.default_rng(1)
    model = rng.normal(size=(8, 3)) * 3
    rotation, scale, shift = random_rotation(rng), 2.7, np.array([651_234.5, 5_401_987.25, 120.0])
    world = scale * model @ rotation.T + shift
    s, r, t = umeyama(model, world)
    assert s == pytest.approx(scale) and np.allclose(r, rotation) and np.allclose(t, shift, atol=1e-6)


def test_solve_gcp_reports_each_residual_and_flags_the_bad_point():
    rng = np.random.default_rng(2)
    model = {f"p{i}": rng.normal(size=3) for i in range(6)}
    world = {k: 10 * v + [500.0, 200.0, 30.0] for k, v in model.items()}
    world["p3"] = world["p3"] + [0.5, 0, 0]  # a mistyped coordinate
    geo = solve_gcp(model, world)
    assert max(geo.residuals, key=geo.residuals.get) == "p3"
    assert geo.scale == pytest.approx(10, rel=0.02) and geo.source == "gcp" and not geo.approximate


def test_solve_gcp_refuses_too_few_or_collinear_points():
    line = {f"p{i}": np.array([i, 2.0 * i, 0.0]) for i in range(4)}
    with pytest.raises(GeoStructureError, match="one line"):
        solve_gcp(line, {k: v * 2 for k, v in line.items()})
    with pytest.raises(GeoStructureError, match="at least 3"):
        solve_gcp({"a": np.zeros(3)}, {"a": np.zeros(3), "b": np.ones(3)})


def test_manual_frame_turns_model_axes_into_east_north_up():
    geo = manual(up=(0, -1, 0), north=(0, 0, 1), scale=2.0)  # a camera-like model: y down, z forward
    np.testing.assert_allclose(geo.apply([[0, -1, 0], [0, 0, 1]]), [[0, 0, 2], [0, 2, 0]], atol=1e-12)
    with pytest.raises(GeoStructureError, match="scale"):
        manual((0, 0, 1), (0, 1, 0), scale=0)


def test_geodetic_to_enu_small_steps():
    origin = (48.78, 2.30, 100.0)
    enu = geodetic_to_enu(
        np.array([48.78 + 1e-4, 48.78]), np.array([2.30, 2.30 + 1e-4]), np.array([100.0, 105.0]), origin
    )
    assert enu[0, 1] == pytest.approx(11.12, abs=0.02) and abs(enu[0, 0]) < 1e-6  # 1e-4 deg of latitude
    assert enu[1, 0] == pytest.approx(7.34, abs=0.02) and enu[1, 2] == pytest.approx(5.0, abs=0.01)


def test_enu_to_geodetic_inverts_geodetic_to_enu():
    origin = (55.7, 13.19, 0.0)
    enu = np.array([[100.0, -250.0, 35.0], [2000.0, 3000.0, -10.0], [0.0, 0.0, 0.0]])
    geodetic = enu_to_geodetic(enu, origin)
    assert np.allclose(geodetic[2], origin, atol=1e-9)
    assert np.abs(geodetic_to_enu(*geodetic.T, origin) - enu).max() < 1e-6  # sub-micrometre
    assert geodetic[1, 0] > origin[0] and geodetic[1, 1] > origin[1]  # north-east is north-east


@pytest.mark.real_data
def test_gps_from_exif_of_a_real_photo():
    folder = shared_file("opensfm_lund/images")
    lat, lon, alt = gps_from_exif(sorted(folder.iterdir())[0])
    assert 55.6 < lat < 55.8 and 13.1 < lon < 13.3  # Lund, Sweden


def test_gcp_csv_errors_name_the_file_and_the_problem(tmp_path):
    bad = tmp_path / "gcp.csv"
    bad.write_text("name,E,N\na,1,2\n")
    with pytest.raises(GeoStructureError, match="gcp.csv: needs columns"):
        read_gcp_csv(bad)
    bad.write_text("name,E,N,Up,x,y,z\na,1,2,three,0,0,0\n")
    with pytest.raises(GeoStructureError, match="line 2"):
        read_gcp_csv(bad)


def test_gcp_csv_with_semicolons_and_decimal_commas(tmp_path):
    us, eu = tmp_path / "us.csv", tmp_path / "eu.csv"
    us.write_text("name,E,N,Up,x,y,z\nA,657500.25,4984000.5,300.125,0.5,1,2\nB,657510,4984010,301,1,2.5,3\n")
    eu.write_text("name;E;N;Up;x;y;z\nA;657500,25;4984000,5;300,125;0,5;1;2\nB;657510;4984010;301;1;2,5;3\n")
    assert read_gcp_csv(us) == read_gcp_csv(eu)
    eu.write_text("name;E;N;Up;x;y;z\nA;657500,25;4984000,5\n")  # a short row: named, not a traceback
    with pytest.raises(GeoStructureError, match="line 2"):
        read_gcp_csv(eu)


@pytest.mark.real_data
def test_opensfm_gcp_json_of_the_berlin_set(tmp_path):
    """WGS84 positions become local ENU metres; OpenSfM's normalised projections become pixels."""
    path = shared_file("opensfm_berlin/ground_control_points.json")
    world, observations, model, origin = read_gcp(path, path.parent / "images")
    assert sorted(world) == ["0", "3"] and model == {}  # point 1 has no position
    assert origin[0] == pytest.approx(52.51926, abs=1e-4) and origin[2] == 0.0
    east_north = np.array([world["3"][:2]]) - np.array([world["0"][:2]])
    assert np.linalg.norm(east_north) == pytest.approx(4.13, abs=0.01)
    assert world["0"][2] == pytest.approx(14.946, abs=1e-3)  # Up stays the altitude
    first = next(o for o in observations if o[:2] == ("0", "02.jpg"))
    assert first[2] == pytest.approx(-0.015689 * 3264 + 1632) and first[3] == pytest.approx(-0.0625362 * 3264 + 1224)
    broken = tmp_path / "gcp.json"
    broken.write_text('{"points": [{"id": "a"}]}')
    with pytest.raises(GeoStructureError, match="gcp.json: no control point has a position"):
        read_gcp(broken, tmp_path)
    broken.write_text("{not json")
    with pytest.raises(GeoStructureError, match="gcp.json: not an OpenSfM"):
        read_gcp(broken, tmp_path)


class _Pose:
    def __init__(self, matrix):
        self._matrix = matrix

    def inverse(self):
        return _Pose(np.c_[self._matrix[:, :3].T, -self._matrix[:, :3].T @ self._matrix[:, 3]])

    def matrix(self):
        return self._matrix


class _Image:
    has_pose = True

    def __init__(self, world_from_cam):
        self._cam_from_world = _Pose(world_from_cam).inverse()

    def cam_from_world(self):
        return self._cam_from_world


def _camera(heading_deg, pitch_deg, centre, model_from_world):
    """A camera held without roll, looking along ``heading`` (clockwise from north), tilted up."""
    h, p = np.radians(heading_deg), np.radians(pitch_deg)
    view = np.array([np.sin(h) * np.cos(p), np.cos(h) * np.cos(p), np.sin(p)])
    right = np.array([np.cos(h), -np.sin(h), 0.0])
    down = np.cross(view, right)
    world_from_cam = np.c_[right, down, view, centre]
    return _Image(np.c_[model_from_world @ world_from_cam[:, :3], model_from_world @ centre])


def test_camera_up_ignores_pitch_but_not_roll_free_headings():
    from types import SimpleNamespace

    from geostructure.reconstruct.georef import camera_up

    rng = np.random.default_rng(5)
    model_from_world = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    model_from_world *= np.sign(np.linalg.det(model_from_world))
    cameras = [
        _camera(heading, 12.0, np.array([x, -20.0, 1.6]), model_from_world)
        for heading, x in zip(np.linspace(-25, 25, 9), np.linspace(-10, 10, 9))
    ]
    model = SimpleNamespace(images={i: c for i, c in enumerate(cameras)})
    up = camera_up(model)
    true_up = model_from_world @ np.array([0.0, 0.0, 1.0])
    mean_up = np.mean([-c.cam_from_world().inverse().matrix()[:, 1] for c in cameras], axis=0)
    mean_up /= np.linalg.norm(mean_up)
    assert angle_between_vectors(up, true_up)[0] < 0.5  # pitched 12 deg up, still found
    assert angle_between_vectors(mean_up, true_up)[0] > 10.0  # what the mean camera up gives

    # All facing one way: the x axes leave the pitch open, and the mean camera up stands in.
    same = SimpleNamespace(
        images={
            i: _camera(0.0, 12.0, np.array([x, -20.0, 1.6]), model_from_world)
            for i, x in enumerate(np.linspace(-10, 10, 5))
        }
    )
    fallback = camera_up(same)
    assert angle_between_vectors(fallback, true_up)[0] == pytest.approx(12.0, abs=0.01)
