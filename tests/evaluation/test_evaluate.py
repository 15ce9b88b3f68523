import numpy as np
import pytest
from helpers import TESTS_DIR

from geostructure.core.orientation import Frame, normal_from_orientation, orientation_from_normals
from geostructure.core.planes import Planes
from geostructure.errors import GeoStructureError, InputError
from geostructure.evaluation.groundtruth import evaluate, run_score, z_score
from geostructure.io.truth import GroundTruth, TruthWarning, dip_direction_from_strike, read_truth

PAPER_TRUTH = TESTS_DIR / "data" / "paper_truth.csv"


def plane_set(dd_dip, centres=None):
    dd_dip = np.asarray(dd_dip, float).reshape(-1, 2)
    normals = normal_from_orientation(dd_dip[:, 0], dd_dip[:, 1])
    o = orientation_from_normals(normals)
    n = len(dd_dip)
    centres = np.zeros((n, 3)) if centres is None else np.asarray(centres, float)
    u = np.cross(normals, [0, 0, 1.0])
    u[np.linalg.norm(u, axis=1) < 1e-9] = [1, 0, 0]
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    return Planes(
        normal=normals,
        local_centroid=centres,
        n_points=np.arange(n, 0, -1) * 100,
        strike=o.strike,
        dip=o.dip,
        dip_direction=o.dip_direction,
        local_rect_center=centres,
        rect_u=u,
        rect_width=2.0,
        rect_height=2.0,
    )


def truth_of(dd_dip, centres=None, names=None):
    dd_dip = np.asarray(dd_dip, float).reshape(-1, 2)
    n = len(dd_dip)
    return GroundTruth(
        names or [f"s{i}" for i in range(n)],
        dd_dip[:, 1],
        dd_dip[:, 0],
        normal_from_orientation(dd_dip[:, 0], dd_dip[:, 1]),
        np.full((n, 3), np.nan) if centres is None else np.asarray(centres, float),
    )


def test_z_by_hand():
    # truth strike 10 / dip 40 / dd 100; measured strike 12 / dip 43 / dd 102
    assert z_score(10, 12, "strike") == pytest.approx(2 / 360)
    assert z_score(40, 43, "dip") == pytest.approx(3 / 90)
    ev = evaluate(plane_set([[102, 43]]), truth_of([[100, 40]]))
    s = ev.surfaces[0]
    assert s.z_region == pytest.approx((2 / 360 + 3 / 90 + 2 / 360) / 3)
    assert ev.z == pytest.approx(s.z_region)  # sqrt(z^2) / 1
    assert run_score([0.3, 0.4]) == pytest.approx(0.25)  # sqrt(0.09 + 0.16) / 2


def test_strike_does_not_wrap_as_printed_but_does_in_the_wrapped_score():
    assert z_score(359, 1, "strike") == pytest.approx(358 / 360)
    assert z_score(359, 1, "strike", wrap=True) == pytest.approx(2 / 360)
    ev = evaluate(plane_set([[90.5, 30]]), truth_of([[89.5, 30]]))  # strikes 0.5 and 359.5
    s = ev.surfaces[0]
    assert s.z_strike == pytest.approx(359 / 360)
    assert s.z_region_wrapped == pytest.approx((1 / 360 + 0 + 1 / 360) / 3)
    assert s.normal_error_deg == pytest.approx(np.sin(np.radians(30)), abs=1e-3)  # 1 deg of azimuth at 30 deg dip


def test_matching_by_orientation_is_one_to_one_and_reports_the_missed():
    planes = plane_set([[90, 30], [180, 60], [270, 10]])
    truth = truth_of([[91, 31], [182, 58], [45, 85]])  # the third matches nothing within 30 degrees
    ev = evaluate(planes, truth)
    assert [s.region for s in ev.surfaces] == [0, 1, -1]
    assert ev.n_missed == 1 and ev.surfaces[2].z_region == 1.0
    assert ev.z == pytest.approx(np.sqrt(ev.surfaces[0].z_region ** 2 + ev.surfaces[1].z_region ** 2 + 1) / 3)


def test_matching_by_location_prefers_the_plane_that_contains_the_centre():
    # Two planes of the same orientation in different places: only location can tell them apart.
    planes = plane_set([[90, 30], [92, 31]], centres=[[0, 0, 0], [10, 0, 0]])
    ev = evaluate(planes, truth_of([[90, 30], [90, 30]], centres=[[10.2, 0.3, 0], [0.1, -0.2, 0]]))
    assert [s.region for s in ev.surfaces] == [1, 0]
    far = evaluate(planes, truth_of([[90, 30]], centres=[[50, 50, 50]]), max_distance=5.0)
    assert far.surfaces[0].region == -1


def test_paper_tables_typed_in_read_with_the_surface_4_inconsistency_flagged():
    with pytest.warns(TruthWarning, match="'4'.*10.0 degrees"):
        truth = read_truth(PAPER_TRUTH, Frame.named("paper"))
    assert truth.names == ["1", "2", "3", "4", "5", "6"]
    np.testing.assert_allclose(truth.dip_direction, [177, 94, 69, 192, 80, 89])
    np.testing.assert_allclose(truth.dip, [89, 89, 87, 86, 89, 40])


def test_dip_quadrant_gives_the_dip_direction():
    assert dip_direction_from_strike(87, "S") == 177
    assert dip_direction_from_strike(4, "E") == 94
    assert dip_direction_from_strike(4, "W") == 274
    assert dip_direction_from_strike(339, "") == 69


def test_truth_with_two_of_three_angles(tmp_path):
    path = tmp_path / "t.csv"
    path.write_text(
        "surface,strike,dip,dip_direction,center_x,center_y,center_z\na,,40,89,1,2,3\nb,10,30,,,,\nc,350,20(W),,,,\n"
    )
    truth = read_truth(path)
    np.testing.assert_allclose(truth.dip_direction, [89, 100, 260])
    assert truth.has_centres.tolist() == [True, False, False]


def test_a_truths_centre_may_be_named_x_y_z_as_in_a_field_map(tmp_path):
    """A truth whose centres were written x, y, z (the field map's names) had them passed
    over without a word: each surface matched by its orientation alone."""
    path = tmp_path / "t.csv"
    path.write_text("surface,dip,dip_direction,x,y,z\na,40,89,1,2,3\nb,30,100,,,\n")
    truth = read_truth(path)
    assert truth.has_centres.tolist() == [True, False]
    np.testing.assert_allclose(truth.centres[0], [1, 2, 3])
    path.write_text("surface,dip,dip_direction,x,y,z\na,40,89,1e308,2,3\n")
    with pytest.raises(InputError, match="line 2: x 1e308 is no center"):
        read_truth(path)
    both = tmp_path / "both.csv"  # center_x given: x is some other column, not read
    both.write_text("surface,dip,dip_direction,center_x,center_y,center_z,x,y,z\na,40,89,1,2,3,7,8,9\n")
    np.testing.assert_allclose(read_truth(both).centres[0], [1, 2, 3])


def test_truth_saved_by_a_european_spreadsheet(tmp_path):
    """Semicolons between cells, decimal commas: it was refused ("the header has no 'surface'
    column"), the whole line read as one cell. Names keep their commas."""
    us = tmp_path / "us.csv"
    us.write_text(
        'surface,strike,dip,dip_direction,center_x\n"a, north",,40.5,89.25,657500.5\nb,10.5,30,,\nc,350,20.5(W),,\n'
    )
    eu = tmp_path / "eu.csv"
    eu.write_text(
        "surface;strike;dip;dip_direction;center_x\na, north;;40,5;89,25;657500,5\nb;10,5;30;;\nc;350;20,5(W);;\n"
    )
    a, b = read_truth(us), read_truth(eu)
    assert a.names == b.names == ["a, north", "b", "c"]
    np.testing.assert_array_equal(a.dip, b.dip)
    np.testing.assert_array_equal(a.dip_direction, b.dip_direction)
    np.testing.assert_array_equal(a.centres, b.centres)


@pytest.mark.parametrize(
    "body,message",
    [
        ("surface,strike\na,10\n", "needs two of"),
        ("surface,dip,dip_direction\na,95,10\n", "outside 0 to 90"),
        ("surface,dip,dip_direction\na,steep,10\n", "not a number"),
        ("name,dip\n", "needs a header row"),
    ],
)
def test_bad_truth_files(tmp_path, body, message):
    path = tmp_path / "t.csv"
    path.write_text(body)
    with pytest.raises(GeoStructureError, match=message):
        read_truth(path)
