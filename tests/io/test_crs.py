"""What a cloud's CRS says (io/crs.py): its unit, its validity, and true north on its grid."""

import numpy as np
import pytest
from pyproj import CRS, Proj, Transformer

from geostructure.core.orientation import Frame, orientation_from_normals
from geostructure.errors import InputError
from geostructure.io.crs import check_cloud_crs, grid_convergence, metres_per_unit, true_north_frame, unit_symbol


@pytest.mark.parametrize(
    "epsg, lon, lat",
    [
        (32733, 17.0, -30.0),  # UTM south: east of the meridian, convergence negative
        (32633, 13.0, 60.0),  # UTM north, west of the meridian
        (2227, -121.0, 37.5),  # California State Plane (US feet), Lambert
        (3035, 25.0, 60.0),  # Europe's equal-area LAEA: 12.8 degrees
    ],
)
def test_grid_convergence_is_the_projections_own(epsg, lon, lat):
    """The convergence read as the grid direction of a step north along the meridian equals
    PROJ's analytic meridian convergence, for transverse Mercator, Lambert and azimuthal."""
    crs = CRS.from_epsg(epsg)
    x, y = Transformer.from_crs(4326, crs, always_xy=True).transform(lon, lat)
    expected = Proj(crs).get_factors(lon, lat).meridian_convergence
    assert grid_convergence(f"EPSG:{epsg}", [[x, y]])[0] == pytest.approx(expected, abs=1e-4)


def test_the_true_north_frame_adds_the_convergence_to_every_azimuth():
    """A plane dipping 40 degrees to grid azimuth 100 at a point where the convergence is
    -1.73 degrees has a true dip direction of 98.27; the dip does not change."""
    x, y = Transformer.from_crs(4326, 32633, always_xy=True).transform(13.0, 60.0)
    frame, north = true_north_frame(Frame(), "EPSG:32633", [x - 500, y - 500, 0], [x + 500, y + 500, 100])
    gamma = north["grid_convergence_deg"]
    assert gamma == pytest.approx(-1.732, abs=1e-3)
    low, high = north["grid_convergence_range_deg"]
    assert low < gamma < high and high - low < 0.02  # one kilometre: a hundredth of a degree
    normal = [np.sin(np.radians(40)) * np.sin(np.radians(100)), np.sin(np.radians(40)) * np.cos(np.radians(100)),
              np.cos(np.radians(40))]  # fmt: skip
    o = orientation_from_normals(normal, frame)
    assert o.dip_direction[0] == pytest.approx(100.0 + gamma, abs=1e-9) and o.dip[0] == pytest.approx(40.0)
    for other in (Frame.named("paper"), Frame.from_up_north([0, 0, 1], [1, 1, 0])):  # a frame of one's own
        assert true_north_frame(other, "EPSG:32633", [x, y, 0], [x, y, 1]) == (other, None)
    assert true_north_frame(Frame(), None, [0, 0, 0], [1, 1, 1]) == (Frame(), None)


def test_units_and_the_axes_that_cannot_be_measured():
    assert metres_per_unit("EPSG:2992") == 0.3048 and metres_per_unit(None) == 1.0
    assert metres_per_unit("EPSG:2227") == pytest.approx(1200 / 3937, rel=1e-12)
    assert [unit_symbol(c) for c in ("EPSG:32633", "EPSG:2992", "EPSG:2227")] == ["m", "ft", "US ft"]
    check_cloud_crs("EPSG:2992+6360", "a.laz")  # international feet across, US survey feet up: 2 ppm
    for crs, words in (
        ("EPSG:4326", "geographic"),
        ("EPSG:4979", "geographic"),
        ("EPSG:2992+5703", "heights in metre"),
    ):
        with pytest.raises(InputError, match=words):
            check_cloud_crs(crs, "a.laz")
