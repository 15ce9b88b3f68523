"""Georeferencing: similarity from control points, manual frame, EXIF GPS arithmetic."""
import numpy as np
import pytest
from conftest import random_rotation, shared_file

from geostructure.errors import GeoStructureError
from geostructure.reconstruct.georef import (gps_from_exif, geodetic_to_enu, manual, read_gcp_csv, solve_gcp,
                                             umeyama)


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
    enu = geodetic_to_enu(np.array([48.78 + 1e-4, 48.78]), np.array([2.30, 2.30 + 1e-4]), np.array([100.0, 105.0]), origin)
    assert enu[0, 1] == pytest.approx(11.12, abs=0.02) and abs(enu[0, 0]) < 1e-6    # 1e-4 deg of latitude
    assert enu[1, 0] == pytest.approx(7.34, abs=0.02) and enu[1, 2] == pytest.approx(5.0, abs=0.01)


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
