import numpy as np
import pytest

from geostructure.core.orientation import (
    Frame,
    angle_between_normals,
    azimuth_difference,
    normal_from_orientation,
    orientation_from_normals,
)
from geostructure.errors import GeoStructureError
from geostructure.synthetic import PAPER_NORMALS, PAPER_TABLE

PAPER = Frame.named("paper")


@pytest.mark.parametrize("surface", [0, 1, 2, 4, 5])
def test_paper_vectors_match_the_table_within_rounding(surface):
    o = orientation_from_normals(PAPER_NORMALS[surface], PAPER)
    strike, dip, dd = PAPER_TABLE[surface]
    assert azimuth_difference(o.strike[0], strike) <= 1.0
    assert abs(o.dip[0] - dip) <= 1.0
    assert azimuth_difference(o.dip_direction[0], dd) <= 1.0


def test_paper_surface_4_normal_and_table_disagree_by_ten_degrees():
    # ORIENTATION.md: the normal gives 182/92, the table says 192/102; one was mistyped.
    o = orientation_from_normals(PAPER_NORMALS[3], PAPER)
    assert round(float(o.dip_direction[0])) == 182 and round(float(o.strike[0])) == 92
    assert azimuth_difference(o.dip_direction[0], PAPER_TABLE[3, 2]) == pytest.approx(10, abs=1)


def test_right_hand_rule_and_dip_direction_for_cardinal_planes():
    # A plane dipping 30 degrees to the east: normal tilts east.
    n = [np.sin(np.radians(30)), 0, np.cos(np.radians(30))]
    o = orientation_from_normals(n)
    assert o.dip[0] == pytest.approx(30)
    assert o.dip_direction[0] == pytest.approx(90)
    assert o.strike[0] == pytest.approx(0)
    # Downward-pointing normal gives the same plane.
    o2 = orientation_from_normals(-np.asarray(n))
    assert o2.dip_direction[0] == pytest.approx(90) and o2.dip[0] == pytest.approx(30)


def test_horizontal_and_vertical_planes():
    assert orientation_from_normals([0, 0, 1]).dip[0] == pytest.approx(0)
    o = orientation_from_normals([0, -1, 0])  # a vertical wall facing south
    assert o.dip[0] == pytest.approx(90)
    # No side known: dip direction is settled in [0, 180).
    assert o.dip_direction[0] == pytest.approx(0)
    # The face's outward side decides when known.
    o = orientation_from_normals([0, 1, 0], outward=[0, -1, 0.0])
    assert o.dip_direction[0] == pytest.approx(180)


@pytest.mark.parametrize("dd", [0.0, 0.4, 45.0, 89.9, 90.0, 179.5, 180.0, 270.0, 359.6])
@pytest.mark.parametrize("dip", [0.5, 10.0, 40.0, 75.0, 89.5])
def test_round_trip_many_orientations(dd, dip):
    o = orientation_from_normals(normal_from_orientation(dd, dip))
    assert o.dip[0] == pytest.approx(dip, abs=1e-9)
    assert azimuth_difference(o.dip_direction[0], dd) < 1e-9
    assert azimuth_difference(o.strike[0], dd - 90) < 1e-9
    assert 0 <= o.dip_direction[0] < 360 and 0 <= o.strike[0] < 360


def test_wrap_around_at_360():
    assert azimuth_difference(359, 1) == pytest.approx(2)
    assert azimuth_difference(0, 360) == pytest.approx(0)
    assert azimuth_difference(10, 190) == pytest.approx(180)
    o = orientation_from_normals(normal_from_orientation(0.5, 30))
    assert o.strike[0] == pytest.approx(270.5)
    o = orientation_from_normals(normal_from_orientation(359.5, 30))
    assert o.dip_direction[0] == pytest.approx(359.5)


def test_custom_up_north_equals_named_paper_frame():
    custom = Frame.from_up_north([0, 0, 1], [1, 0, 0])
    np.testing.assert_allclose(custom.matrix, PAPER.matrix, atol=1e-12)
    # A tilted north is projected onto the horizontal.
    tilted = Frame.from_up_north([0, 0, 2], [1, 0, 0.3])
    np.testing.assert_allclose(tilted.matrix, PAPER.matrix, atol=1e-12)


def test_frame_of_a_rotated_cloud_gives_the_same_angles(rng=np.random.default_rng(5)):
    from conftest import random_rotation

    rot = random_rotation(rng)
    normals = rng.normal(size=(20, 3))
    base = orientation_from_normals(normals)
    frame = Frame.from_up_north(rot @ [0, 0, 1], rot @ [0, 1, 0])
    turned = orientation_from_normals(normals @ rot.T, frame)
    np.testing.assert_allclose(turned.dip, base.dip, atol=1e-9)
    assert azimuth_difference(turned.dip_direction, base.dip_direction).max() < 1e-7


def test_declination_reads_azimuths_against_magnetic_north():
    n = normal_from_orientation(100, 45)
    o = orientation_from_normals(n, Frame(declination=10))
    assert o.dip_direction[0] == pytest.approx(90)
    assert o.dip[0] == pytest.approx(45)
    np.testing.assert_allclose(normal_from_orientation(90, 45, Frame(declination=10)), n, atol=1e-12)


def test_angle_between_normals_ignores_sign():
    assert angle_between_normals([0, 0, 1], [0, 0, -1])[0] == pytest.approx(0)
    assert angle_between_normals([0, 0, 1], [0, 1, 0])[0] == pytest.approx(90)


def test_bad_frames_are_refused():
    with pytest.raises(GeoStructureError):
        Frame.named("nwu")
    with pytest.raises(GeoStructureError):
        Frame.from_up_north([0, 0, 1], [0, 0, 5])


def test_dip_is_never_over_90_and_agrees_with_mplstereonet():
    """Issue "Outputs": a normal kept on its face's side may point a little down near vertical;
    its dip is still in [0, 90]. Checked against mplstereonet's vector2pole (x east, y north)."""
    from mplstereonet.stereonet_math import vector2pole

    from geostructure.core.orientation import VERTICAL_TOLERANCE

    rng = np.random.default_rng(0)
    n = rng.normal(size=(20_000, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    n[:2000, 2] *= 1e-4  # within 0.06 deg of vertical, half of them pointing down
    o = orientation_from_normals(n)
    strike, dip = vector2pole(n[:, 0], n[:, 1], n[:, 2])
    assert o.dip.min() >= 0.0 and o.dip.max() <= 90.0
    np.testing.assert_allclose(o.dip, dip, atol=1e-9)
    turn = np.abs((o.strike - strike + 180.0) % 360.0 - 180.0)
    steep = np.abs(n[:, 2]) < VERTICAL_TOLERANCE
    assert turn[~steep].max() < 1e-9
    assert np.minimum(turn, 180.0 - turn)[steep].max() < 1e-9  # vertical: the same strike up to its sense


def test_the_face_side_is_its_own_column_and_the_dip_stays_in_range():
    """Issue "Outputs": which way a face looks (the cloud's stored normals) goes in
    ``facing``/``overhang``, never into the dip: a wall seen from the west and the underside
    of a slab dipping 30 deg east, seen from below."""
    from geostructure import Cloud, measure
    from geostructure.core.orientation import face_side

    rng = np.random.default_rng(3)
    u, v = rng.uniform(0, 4, size=(2, 40_000))
    wall = np.column_stack([rng.normal(0, 0.002, u.size), u, v])  # x = 0, looking west
    slope = np.radians(30.0)
    up_normal = np.array([np.sin(slope), 0.0, np.cos(slope)])  # dips 30 toward east
    along = np.array([np.cos(slope), 0.0, -np.sin(slope)])
    slab = 10.0 + u[:, None] * along + (v[:, None] * [0, 1, 0]) + rng.normal(0, 0.002, (u.size, 1)) * up_normal
    points = np.vstack([wall, slab])
    normals = np.vstack([np.tile([-1.0, 0.0, 0.0], (u.size, 1)), np.tile(-up_normal, (u.size, 1))])
    planes = measure(Cloud.from_points(points + [500_000.0, 4_600_000.0, 0.0], normals=normals)).planes
    assert len(planes) == 2
    wall_row, slab_row = np.argsort(-planes.dip)
    assert planes.dip[wall_row] > 89.5 and planes.dip[wall_row] <= 90.0
    assert abs(planes.facing[wall_row] - 270.0) < 0.5 and planes.overhang[wall_row] == 0.0
    assert abs(planes.dip[slab_row] - 30.0) < 0.5 and abs(planes.dip_direction[slab_row] - 90.0) < 0.5
    assert abs(planes.facing[slab_row] - 270.0) < 0.5 and planes.overhang[slab_row] == 1.0
    # the side turns with a declination as every azimuth does, and is unknown without normals
    facing, _ = face_side([[-1.0, 0.0, 0.0]], Frame(declination=10.0))
    assert abs(facing[0] - 260.0) < 1e-9
    assert np.isnan(measure(Cloud.from_points(points)).planes.facing).all()
