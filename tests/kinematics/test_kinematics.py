"""Kinematic tests: boundaries, published formulas, invariance, an outcrop, the command."""

import csv
import json
import re

import numpy as np
import pytest
from helpers import run_cli

from geostructure import measure
from geostructure.cli import main
from geostructure.core.orientation import normal_from_orientation, orientation_from_normals
from geostructure.core.projection import enu_vectors
from geostructure.kinematics.modes import (
    Slope,
    direct_toppling,
    flexural_toppling,
    intersection_lines,
    planar_factor_of_safety,
    planar_sliding,
    wedges,
)
from geostructure.kinematics.wedge import wedge_blocks, wedge_factor_of_safety
from geostructure.synthetic import outcrop_scene
from geostructure.workflows.kinematics import add_kinematics
from geostructure.workflows.saving import save_measurement
from geostructure.workflows.sets_and_mass import plane_sets

SLOPE = Slope(dip=60.0, dip_direction=135.0)


def apparent_dip(slope, azimuth):
    return np.degrees(np.arctan(np.tan(np.radians(slope.dip)) * np.cos(np.radians(azimuth - slope.dip_direction))))


def test_planar_sliding_on_each_side_of_each_boundary():
    eps = 0.5
    inside = apparent_dip(SLOPE, 150.0)  # the slope's apparent dip 15 degrees off its dip direction
    cases = [  # dip, dip direction, expected
        (45.0, 135.0, True),
        (inside - eps, 150.0, True),  # daylights, just
        (inside + eps, 150.0, False),  # steeper than the face in its direction: does not daylight
        (40.0, 135.0 + 20.0 - eps, True),  # lateral limit 20
        (40.0, 135.0 + 20.0 + eps, False),
        (40.0, 135.0 - 20.0 - eps, False),
        (30.0 + eps, 135.0, True),  # friction 30
        (30.0 - eps, 135.0, False),
        (45.0, 315.0, False),  # dips into the slope
    ]
    dip, dd, expected = (np.array(c) for c in zip(*cases))
    assert planar_sliding(dip, dd, SLOPE, friction=30.0).tolist() == expected.astype(bool).tolist()


def test_flexural_toppling_on_each_side_of_each_boundary():
    eps = 0.5
    limit = 90.0 - SLOPE.dip + 30.0  # Goodman: the dip must exceed 90 - slope dip + friction = 60
    cases = [
        (limit + eps, 315.0, True),
        (limit - eps, 315.0, False),
        (80.0, 315.0 + 20.0 - eps, True),
        (80.0, 315.0 + 20.0 + eps, False),
        (80.0, 135.0, False),  # dips out of the slope
        # 15 degrees off the slope's opposite, the slip limit plane (30/135) dips 29.14 along
        # the pole's trend, so the pole must plunge less: dip > 60.86
        (90.0 - apparent_dip(Slope(30.0, 135.0), 150.0) + eps, 330.0, True),
        (90.0 - apparent_dip(Slope(30.0, 135.0), 150.0) - eps, 330.0, False),
    ]
    dip, dd, expected = (np.array(c) for c in zip(*cases))
    assert flexural_toppling(dip, dd, SLOPE, friction=30.0).tolist() == expected.astype(bool).tolist()


def planes_through(trend, plunge, spread=40.0):
    """Dip and dip direction of two planes that meet on the line (trend, plunge)."""
    line = enu_vectors(trend, plunge)
    side = np.cross(line, [0.0, 0.0, 1.0])
    side /= np.linalg.norm(side)
    normals = []
    for angle in (-spread, spread):  # turn the plane about the line either way
        across = np.cross(line, side)
        normal = np.cos(np.radians(angle)) * across + np.sin(np.radians(angle)) * side
        normals.append(normal)
    o = orientation_from_normals(np.array(normals))
    return list(o.dip), list(o.dip_direction)


def test_direct_toppling_on_each_side_of_each_boundary():
    eps = 0.5
    base = ([20.0], [135.0])  # gentle, out of the slope: blocks stand on it
    for trend, plunge, expected in [
        (315.0, 90.0 - SLOPE.dip + eps, True),  # leans out of the face, just
        (315.0, 90.0 - SLOPE.dip - eps, False),
        (315.0 + 20.0 - eps, 60.0, True),  # lateral limit 20 about the slope's opposite
        (315.0 + 20.0 + eps, 60.0, False),
        (135.0, 60.0, False),  # plunges out of the slope
    ]:
        dip, dd = planes_through(trend, plunge)
        t = direct_toppling(dip + base[0], dd + base[1], SLOPE, 30.0)
        assert (len(t.a) == 1) is expected, (trend, plunge)
        assert t.base.tolist() == [False, False, True] and t.critical is expected
    dip, dd = planes_through(315.0, 60.0)
    assert not direct_toppling(dip, dd, SLOPE, 30.0).critical  # no base plane to topple over
    steep_base = direct_toppling(dip + [40.0], dd + [135.0], SLOPE, 30.0)
    assert steep_base.critical and steep_base.sliding_base.tolist() == [False, False, True]


def test_oblique_toppling_in_dips_secondary_zone_on_each_side_of_each_boundary():
    # Steeper than 90 - slope dip, outside the lateral limits of the slope's opposite, and not
    # daylighting through the face (SLOPE dips 60/135).
    eps = 0.5
    base = ([20.0], [135.0])
    for trend, plunge, oblique in [
        (315.0 + 20.0 + eps, 60.0, True),  # just outside the primary zone's lateral limit
        (315.0 + 20.0 - eps, 60.0, False),  # just inside: the primary zone's
        (45.0, 90.0 - SLOPE.dip + eps, True),  # along the strike, just steep enough
        (45.0, 90.0 - SLOPE.dip - eps, False),
        (135.0, SLOPE.dip + eps, True),  # out of the face but steeper than it: no daylight
        (135.0, SLOPE.dip - eps, False),  # daylights: a wedge's line, not a column's
    ]:
        dip, dd = planes_through(trend, plunge)
        t = direct_toppling(dip + base[0], dd + base[1], SLOPE, 30.0)
        assert (len(t.oblique_a) == 1) is oblique and t.oblique_critical is oblique, (trend, plunge)
        assert len(t.a) + len(t.oblique_a) <= 1
    # Oblique base planes: gentler than the slope, outside its lateral limits, poles not
    # daylighting. 20/45 strikes down the slope; 10/315 dips gently into it; 50/315 is too steep
    # (its pole, 40/135, daylights); 20/135 is a primary base plane; 65/45 is steeper than the slope.
    t = direct_toppling([20.0, 10.0, 50.0, 20.0, 65.0], [45.0, 315.0, 315.0, 135.0, 45.0], SLOPE, 30.0)
    assert t.oblique_base.tolist() == [True, True, False, False, False]
    assert t.base.tolist() == [False, False, False, True, False]


def test_wedge_lines_and_the_daylight_and_friction_limits():
    # Two planes symmetric about the slope's dip direction meet on a line trending along it,
    # plunging atan(tan(dip) cos(half the angle between their dip directions)).
    trend, plunge = intersection_lines(normal_from_orientation(115.0, 50.0), normal_from_orientation(155.0, 50.0))
    assert float(trend) == pytest.approx(135.0)
    assert float(plunge) == pytest.approx(np.degrees(np.arctan(np.tan(np.radians(50.0)) * np.cos(np.radians(20.0)))))
    assert len(wedges([50.0, 50.0], [115.0, 155.0], SLOPE, 30.0)) == 1
    assert len(wedges([50.0, 50.0], [115.0, 155.0], SLOPE, 50.0)) == 0  # plunge 48 under friction 50
    assert len(wedges([50.0, 50.0], [115.0, 155.0], Slope(45.0, 135.0), 30.0)) == 0  # steeper than the face


def test_wedge_factor_of_safety_is_hoek_and_brays():
    rng = np.random.default_rng(3)
    a_dd, b_dd = rng.uniform(80, 130, 300), rng.uniform(140, 190, 300)
    a_dip, b_dip = rng.uniform(40, 75, 300), rng.uniform(40, 75, 300)
    slope, phi = Slope(80.0, 135.0), 25.0
    for i in range(300):
        w = wedges([a_dip[i], b_dip[i]], [a_dd[i], b_dd[i]], slope, phi)
        if not len(w) or w.single_plane[0] >= 0:
            continue
        na, nb = normal_from_orientation(a_dd[i], a_dip[i]), normal_from_orientation(b_dd[i], b_dip[i])
        cos_t = float(na @ nb)  # Hoek & Bray (1981): FS = A tan(phi_a) + B tan(phi_b)
        sin_5 = np.sin(np.radians(w.plunge[0]))
        big_a = (np.cos(np.radians(a_dip[i])) - np.cos(np.radians(b_dip[i])) * cos_t) / (sin_5 * (1 - cos_t**2))
        big_b = (np.cos(np.radians(b_dip[i])) - np.cos(np.radians(a_dip[i])) * cos_t) / (sin_5 * (1 - cos_t**2))
        assert w.factor_of_safety[0] == pytest.approx((big_a + big_b) * np.tan(np.radians(phi)), rel=1e-9)


def test_a_symmetric_wedge_has_hoek_and_brays_wedge_factor():
    # FS_wedge = K FS_plane with K = sin(beta) / sin(xi / 2): beta = 90 for a wedge symmetric
    # about a vertical plane, xi the angle between the planes across their line.
    for half_spread, dip in ((20.0, 50.0), (35.0, 60.0), (10.0, 70.0)):
        dds = [135.0 - half_spread, 135.0 + half_spread]
        w = wedges([dip, dip], dds, Slope(85.0, 135.0), 20.0)
        na, nb = normal_from_orientation(dds[0], dip), normal_from_orientation(dds[1], dip)
        xi = 180.0 - np.degrees(np.arccos(np.clip(na @ nb, -1, 1)))  # the wedge's included angle
        expected = np.tan(np.radians(20.0)) / np.tan(np.radians(w.plunge[0])) / np.sin(np.radians(xi / 2))
        assert w.factor_of_safety[0] == pytest.approx(expected, rel=1e-9)


def test_a_wedge_that_lifts_off_one_plane_slides_on_the_other():
    # Plane a dips nearly along the line (Hocking 1976): the wedge rides on a alone.
    w = wedges([40.0, 80.0], [130.0, 200.0], Slope(70.0, 135.0), 30.0)
    assert len(w) == 1 and w.single_plane[0] == 0
    assert w.factor_of_safety[0] == pytest.approx(planar_factor_of_safety(40.0, 30.0))


def test_a_wedge_lifted_onto_a_plane_dipping_into_the_face_cannot_move():
    # Slope 70/180, friction 30. Planes 35/070 and 65/030 meet along a line trending 104.4
    # and plunging 30.03: steeper than friction, and it daylights (the face's apparent dip
    # along 104.4 is atan(tan 70 cos 75.6) = 35.0). But the normal force on 65/030 comes out
    # negative (-0.42): the block lifts off it onto 35/070 alone, which would give
    # FS = tan 30 / tan 35 = 0.82. 35/070 dips 110 degrees away from the face's dip
    # direction, into the rock: the block has nowhere to go.
    slope = Slope(70.0, 180.0)
    w = wedges([35.0, 65.0], [70.0, 30.0], slope, 30.0)
    assert len(w) == 0 and w.lifted_into_face == 1
    assert not planar_sliding([35.0], [70.0], slope, 30.0)[0]
    # The same pair's line under a face it does not lift into: 35/160 slides out within the
    # lateral limits, and the wedge on it alone stays, at that plane's planar factor.
    w = wedges([35.0, 40.0], [160.0, 130.0], slope, 30.0)
    assert len(w) == 1 and w.single_plane[0] == 0 and w.lifted_into_face == 0
    assert w.factor_of_safety[0] == pytest.approx(np.tan(np.radians(30.0)) / np.tan(np.radians(35.0)))
    # 35/140 and 50/190: the block lifts off 50/190 onto 35/140, which daylights but dips
    # 40 degrees off the slope's dip direction: critical within lateral limits of 45, not 20.
    assert len(wedges([35.0, 50.0], [140.0, 190.0], slope, 30.0, lateral_limit=20.0)) == 0
    assert wedges([35.0, 50.0], [140.0, 190.0], slope, 30.0, lateral_limit=45.0).single_plane.tolist() == [0]


def test_kinematics_leaves_out_clutter_ground_and_the_face_itself():
    # Four planes that would all slide out of a 70/180 slope at friction 30; three are marked
    # as no discontinuity. Only the joint is tested, and the shares divide by it alone.
    from geostructure.core.planes import Planes
    from geostructure.kinematics.summary import kinematics_of

    normals = normal_from_orientation([180.0, 175.0, 185.0, 180.0], [45.0, 50.0, 40.0, 55.0]).reshape(-1, 3)
    planes = Planes(normal=normals, area=[1.0, 2.0, 3.0, 4.0], n_points=np.array([500, 500, 500, 8]))
    planes = planes.with_columns(clutter=np.array([0, 1, 0, 0]), ground=np.array([0, 0, 1, 0]),
                                 face_surface=np.array([0, 0, 0, 0]))  # fmt: skip
    tested = kinematics_of(planes, [], Slope(70.0, 180.0), 30.0)
    summary, rows = tested.summary, tested.rows
    assert [r["left_out"] for r in rows] == ["", "clutter", "ground", ""]
    assert [r["planar_sliding"] for r in rows] == [True, False, False, True]
    assert summary["planes_tested"] == 2 and summary["left_out"] == {"ground": 1, "clutter": 1, "face_surface": 0}
    planar = summary["planar_sliding"]
    assert planar["planes"] == 2 and planar["percent_by_count"] == pytest.approx(100.0)
    # The headline comes from the 500-point plane, not the 8-point sliver of 55 degrees.
    assert planar["min_fs"] == pytest.approx(np.tan(np.radians(30.0)) / np.tan(np.radians(45.0)))
    assert planar["min_fs_any_size"] == pytest.approx(np.tan(np.radians(30.0)) / np.tan(np.radians(55.0)))
    assert planar["headline_planes"] == 1


def test_planar_factor_of_safety():
    assert planar_factor_of_safety([30.0, 45.0], 30.0) == pytest.approx([1.0, np.tan(np.radians(30.0))])


def test_planar_factor_of_safety_with_cohesion_follows_culmann():
    """Culmann (1866), as Hoek & Bray and Wyllie & Mah give it: on a face of dip psi_f, the
    weakest plane of a cohesive, frictional rock dips (psi_f + phi) / 2, and it is at FS = 1
    for H = 4 c sin(psi_f) cos(phi) / (gamma (1 - cos(psi_f - phi)))."""
    c, phi, face, gamma = 40.0, 32.0, 70.0, 25.0
    critical_height = 4 * c * np.sin(np.radians(face)) * np.cos(np.radians(phi))
    critical_height /= gamma * (1 - np.cos(np.radians(face - phi)))
    dips = np.linspace(phi + 1.0, face - 1.0, 3601)
    fs = planar_factor_of_safety(dips, phi, cohesion=c, height=critical_height, slope_dip=face, unit_weight=gamma)
    assert abs(dips[np.argmin(fs)] - (face + phi) / 2) < 0.05
    assert fs.min() == pytest.approx(1.0, abs=1e-6)
    # cohesion adds to friction; a higher face holds less; no block under a plane as steep as the face
    taller = planar_factor_of_safety(
        dips, phi, cohesion=c, height=2 * critical_height, slope_dip=face, unit_weight=gamma
    )
    assert (taller < fs).all() and (taller > planar_factor_of_safety(dips, phi)).all()
    assert np.isnan(planar_factor_of_safety([70.0, 75.0], phi, cohesion=c, height=10.0, slope_dip=face)).all()
    np.testing.assert_array_equal(planar_factor_of_safety(dips, phi, cohesion=0.0), planar_factor_of_safety(dips, phi))


def test_the_planar_factor_of_safety_does_not_depend_on_the_ground_above_the_crest():
    """With no tension crack the block is the triangle of the toe, the crest and the plane's
    exit on the ground above; built here from coordinates with that ground rising at 15
    degrees, its factor of safety is the level top's: the block's weight grows with the
    length of its sliding plane, so cohesion counts for as much."""
    c, phi, face, top, gamma, h = 25.0, 30.0, 70.0, 15.0, 26.0, 20.0
    dips = np.array([35.0, 45.0, 55.0, 65.0])
    crest = np.array([h / np.tan(np.radians(face)), h])
    rising = []
    for d in np.radians(dips):
        # the plane from the toe along (cos d, sin d) meets the ground crest + s (cos top, sin top)
        system = np.array([[np.cos(d), -np.cos(np.radians(top))], [np.sin(d), -np.sin(np.radians(top))]])
        t, _ = np.linalg.solve(system, crest)
        exit_point = t * np.array([np.cos(d), np.sin(d)])
        weight = gamma * 0.5 * abs(crest[0] * exit_point[1] - crest[1] * exit_point[0])
        rising.append((c * t + weight * np.cos(d) * np.tan(np.radians(phi))) / (weight * np.sin(d)))
        assert t > h / np.sin(d)  # a longer plane than under a level top
    level = planar_factor_of_safety(dips, phi, cohesion=c, height=h, slope_dip=face, unit_weight=gamma)
    np.testing.assert_allclose(rising, level, rtol=1e-12)


def test_turning_the_slope_and_every_plane_alike_changes_nothing():
    rng = np.random.default_rng(9)
    dip, dd = rng.uniform(0, 90, 400), rng.uniform(0, 360, 400)
    base = Slope(65.0, 40.0)
    reference = (
        planar_sliding(dip, dd, base, 30.0),
        flexural_toppling(dip, dd, base, 30.0),
        wedges(dip[:80], dd[:80], base, 30.0),
    )
    for turn in (37.0, 180.0, 313.0):
        turned = Slope(65.0, 40.0 + turn)
        assert (planar_sliding(dip, dd + turn, turned, 30.0) == reference[0]).all()
        assert (flexural_toppling(dip, dd + turn, turned, 30.0) == reference[1]).all()
        w = wedges(dip[:80], (dd[:80] + turn) % 360, turned, 30.0)
        assert w.a.tolist() == reference[2].a.tolist() and w.b.tolist() == reference[2].b.tolist()
        np.testing.assert_allclose((w.trend - turn) % 360.0, reference[2].trend % 360.0, atol=1e-9)
        np.testing.assert_allclose(w.factor_of_safety, reference[2].factor_of_safety, rtol=1e-9)
        topple, topple_turned = (
            direct_toppling(dip[:80], dd[:80], base, 30.0),
            direct_toppling(dip[:80], (dd[:80] + turn) % 360, turned, 30.0),
        )
        assert topple.a.tolist() == topple_turned.a.tolist() and (topple.base == topple_turned.base).all()
        assert topple.oblique_a.tolist() == topple_turned.oblique_a.tolist()
        assert (topple.oblique_base == topple_turned.oblique_base).all()


@pytest.fixture(scope="module")
def outcrop_folder(tmp_path_factory):
    # A 65 degree face: with the generator's 75, Goodman's test keeps a set dipping 70 into
    # the face critical at friction 50 (70 > 90 - 75 + 50); at 65 it needs 75.
    scene = outcrop_scene(width=12.0, height=6.0, seed=4, face_dip=65.0)
    out = tmp_path_factory.mktemp("kinematics")
    result = measure(scene.cloud)
    save_measurement(result, out, sets=plane_sets(result.planes, result.frame))
    return scene, out


@pytest.mark.parametrize("friction, critical", [(30.0, True), (50.0, False)])
def test_an_outcrops_sets_out_of_and_into_the_face(outcrop_folder, friction, critical):
    scene, out = outcrop_folder
    summary, _ = add_kinematics(out, friction)  # the slope fitted to the cloud
    assert summary["slope"]["source"] == "fitted" and abs(summary["slope"]["dip"] - 65.0) < 4.0
    by_truth = {}  # each measured set by the generated set it is
    sets = list(csv.DictReader(open(out / "sets.csv")))
    for row, result in zip(sets, summary["sets"]):
        normal = normal_from_orientation(float(row["dip_direction"]), float(row["dip"]))
        by_truth[int(np.abs(scene.set_normals @ normal).argmax())] = result
    assert abs(by_truth[0]["mean_dip"] - 45.0) < 3.0 and abs(by_truth[0]["mean_dip_direction"] - 180.0) < 3.0
    assert by_truth[0]["mean_planar_sliding"] is critical  # J1 45/180, out of the face
    assert by_truth[1]["mean_flexural_toppling"] is critical  # J2 70/000, into it
    assert not by_truth[2]["mean_planar_sliding"] and not by_truth[2]["mean_flexural_toppling"]


def test_the_kinematics_command(outcrop_folder, capsys):
    _, out = outcrop_folder
    assert main(["kinematics", str(out), "--friction", "30", "--slope", "65/180"]) == 0
    table = capsys.readouterr().out.split("Sets against the slope")[1]  # a row per set, J1 45/180 sliding
    assert re.search(r"│ +\d │ +4\d/1[78]\d │ +critical │", table) and table.count("critical") >= 2
    assert main(["kinematics", str(out), "--friction", "35", "--slope", "65/180", "-q"]) == 0
    rows = list(csv.DictReader(open(out / "kinematics.csv")))
    assert {"region_id", "planar_sliding", "flexural_toppling", "planar_fs"} <= set(rows[0])
    sliding = [r for r in rows if r["planar_sliding"] == "true"]
    assert sliding and all(float(r["planar_fs"]) < 1.0 for r in sliding)  # steeper than friction, dry
    wedge_rows = list(csv.DictReader(open(out / "wedges.csv")))
    assert wedge_rows and {"region_id_a", "region_id_b", "trend", "plunge", "wedge_fs"} <= set(wedge_rows[0])
    summary = json.load(open(out / "kinematics.json"))
    assert summary["slope"] == {
        "dip": 65.0,
        "dip_direction": 180.0,
        "dip_uncertainty_deg": 0.0,
        "dip_direction_uncertainty_deg": 0.0,
        "source": "given",
    }
    assert (out / "kinematics.png").stat().st_size > 20_000
    assert main(["report", str(out), "-q"]) == 0  # the folder verifies as one set
    # The page's data is JSON whose < and > are escapes (no name can close its script).
    html = (out / "report.html").read_text().replace("\\u003c", "<").replace("\\u003e", ">")
    assert "planar daylight envelope" in html and "Poles and kinematic envelopes<br>slope 65/180" in html
    # the tables beside the set table: a row per failure mode, a row per set
    modes = html.split('<table id="kinematics">')[1].split("</table>")[0]
    assert "Kinematics: slope 65/180 (given), friction 35°" in modes and modes.count("<tr>") == 4
    per_set = html.split('<table id="kinematic-sets">')[1].split("</table>")[0]
    assert per_set.count("<tr>") == 1 + len(summary["sets"]) and "critical" in per_set
    # the terminal's verdicts, word for word, under the report's tables (issue 52)
    from html import escape

    from geostructure.report.words import kinematic_verdicts, set_mean_wedge_lines

    for line in kinematic_verdicts(summary) + set_mean_wedge_lines(summary):
        assert f'<p class="verdict">{escape(line)}</p>' in html, line
    assert main(["kinematics", str(out), "--friction", "40", "--slope", "65/180", "-q"]) == 0
    assert "friction 40" in (out / "report.html").read_text()  # a report there is drawn again
    # A slope fitted no steeper than the friction angle (a terrain's, a floor's) says that
    # nothing slides on it and how to give the slope; the outcrop's own (75/180) does not.
    code, _, err = run_cli(capsys, "kinematics", out, "--friction", "30", "-q")
    assert code == 0 and "dips no steeper than the friction angle" not in err
    code, _, err = run_cli(capsys, "kinematics", out, "--friction", "80", "-q")
    assert code == 0 and "dips no steeper than the friction angle (80°), so no plane or wedge can slide" in err
    assert json.load(open(out / "kinematics.json"))["planar_sliding"]["planes"] == 0
    assert main(["kinematics", str(out), "--friction", "35", "--slope", "steep", "-q"]) == 2
    assert "--slope takes DIP/DIPDIR" in capsys.readouterr().err
    assert main(["kinematics", str(out), "--friction", "95", "-q"]) == 2
    assert "friction angle" in capsys.readouterr().err


def test_the_failure_modes_count_joints_once(tmp_path, capsys):
    # A joint exposed as many facets weighs many times in the planes' counts; the joints'
    # count takes it once: on the 65 degree face at friction 30, J1 (45/180, out of the face)
    # slides, and so do its joints, all of them or nearly, and no other set's.
    scene = outcrop_scene(width=12.0, height=6.0, seed=4, face_dip=65.0)
    cloud, out = tmp_path / "face.xyz", tmp_path / "out"
    np.savetxt(cloud, scene.cloud.points, fmt="%.4f")
    assert main(["measure", str(cloud), "-o", str(out), "--sets", "--kinematics", "--friction", "30"]) == 0
    assert re.search(r"planar sliding │ +\d+ │ .+│ +\d+ \(\d+%\) │", capsys.readouterr().out)
    summary = json.load(open(out / "kinematics.json"))
    sets = list(csv.DictReader(open(out / "sets.csv")))
    j1 = min(sets, key=lambda r: abs(float(r["dip"]) - 45.0) + abs(float(r["dip_direction"]) - 180.0))
    planar, n_joints = summary["planar_sliding"], sum(int(r["n_joints"]) for r in sets)
    assert int(j1["n_joints"]) - 1 <= planar["joints"] <= int(j1["n_joints"])
    assert planar["percent_of_joints"] == pytest.approx(100.0 * planar["joints"] / n_joints)
    assert planar["joints"] < planar["planes"]  # facets counted once per joint
    rows = list(csv.DictReader(open(out / "kinematics.csv")))
    sliding = [r for r in rows if r["planar_sliding"] == "true"]
    assert len(sliding) == planar["planes"] and all(int(r["joint"]) >= 0 for r in sliding if int(r["set"]) >= 0)
    j1_joints = {r["joint"] for r in sliding if r["set"] == j1["set"]}
    assert len(j1_joints) >= planar["joints"]  # the joints taken are J1's, each with facets sliding
    # Wedges between the joints' planes (their facets' area-weighted mean), far fewer pairs
    # than the facets': as many as joints.csv's own planes give, within a few
    wedge, joints = summary["wedge_sliding"], list(csv.DictReader(open(out / "joints.csv")))
    assert wedge["joint_pairs_tested"] <= len(joints) * (len(joints) - 1) // 2 < wedge["pairs_tested"]
    slope = Slope(summary["slope"]["dip"], summary["slope"]["dip_direction"])
    own = wedges([float(j["dip"]) for j in joints], [float(j["dip_direction"]) for j in joints], slope, 30.0)
    assert 0 < wedge["critical_joint_pairs"] == pytest.approx(len(own), rel=0.1, abs=2)


def test_measure_with_kinematics_and_its_bad_options(tmp_path, capsys):
    scene = outcrop_scene(width=5.0, height=3.0, seed=2, face_dip=65.0)
    cloud = tmp_path / "face.xyz"
    np.savetxt(cloud, scene.cloud.points, fmt="%.4f")
    out = tmp_path / "out"
    assert main(["measure", str(cloud), "-o", str(out), "--kinematics", "-q"]) == 2  # no friction
    assert "--friction" in capsys.readouterr().err and not out.exists()  # refused before any work
    assert main(["measure", str(cloud), "-o", str(out), "--kinematics", "--friction", "30", "--slope", "95/180"]) == 2
    assert "at most 90" in capsys.readouterr().err and not out.exists()
    assert main(["measure", str(cloud), "-o", str(out), "--kinematics", "--friction", "30", "--slope", "75/400"]) == 2
    assert "dip direction must be 0 to 360 degrees, not 400" in capsys.readouterr().err and not out.exists()
    assert main(["measure", str(cloud), "-o", str(out), "--kinematics", "--friction", "30", "-q"]) == 0
    assert json.load(open(out / "run.json"))["kinematics"]["slope"]["source"] == "fitted"
    assert (out / "wedges.csv").is_file() and (out / "planes.csv").is_file()
    # With --sets the slope is fitted on the face the sets were read on, in memory: the same
    # face, and the same tests, as the kinematics command fits from the folder.
    both, then = tmp_path / "both", tmp_path / "then"
    assert main(["measure", str(cloud), "-o", str(both), "--sets", "--kinematics", "--friction", "30", "-q"]) == 0
    assert main(["measure", str(cloud), "-o", str(then), "--sets", "-q"]) == 0
    assert main(["kinematics", str(then), "--friction", "30", "-q"]) == 0
    slopes = [json.load(open(folder / "kinematics.json"))["slope"] for folder in (both, then)]
    assert slopes[0]["dip"] == pytest.approx(slopes[1]["dip"], abs=1e-9)
    assert slopes[0]["dip_direction"] == pytest.approx(slopes[1]["dip_direction"], abs=1e-9)
    assert (both / "kinematics.csv").read_bytes() == (then / "kinematics.csv").read_bytes()


def test_the_planar_factor_of_safety_with_cohesion_from_the_command(outcrop_folder, capsys):
    _, out = outcrop_folder
    assert main(["kinematics", str(out), "--friction", "35", "--slope", "65/180", "-q"]) == 0
    dry = {r["region_id"]: r for r in csv.DictReader(open(out / "kinematics.csv"))}
    dry_wedges = {(r["region_id_a"], r["region_id_b"]): r for r in csv.DictReader(open(out / "wedges.csv"))}
    assert main(["kinematics", str(out), "--friction", "35", "--slope", "65/180", "--cohesion", "20", "-q"]) == 0
    wet = {r["region_id"]: r for r in csv.DictReader(open(out / "kinematics.csv"))}
    sliding = [k for k, r in dry.items() if r["planar_sliding"] == "true"]
    assert sliding and all(float(wet[k]["planar_fs"]) > float(dry[k]["planar_fs"]) for k in sliding)
    wet_wedges = {(r["region_id_a"], r["region_id_b"]): r for r in csv.DictReader(open(out / "wedges.csv"))}
    assert dry_wedges and wet_wedges.keys() == dry_wedges.keys()  # cohesion changes no kinematic test
    held = [float(wet_wedges[k]["wedge_fs"]) > float(r["wedge_fs"]) for k, r in dry_wedges.items()]
    assert np.mean(held) > 0.9  # the rest cut no block under the face (NaN)
    strength = json.load(open(out / "kinematics.json"))["strength"]
    assert strength["wedge_fs"].startswith("with cohesion")
    assert strength["cohesion_kpa"] == 20.0 and strength["height_source"] == "the cloud's height"
    assert 4.0 < strength["height_m"] < 8.0  # the 12 x 6 m face at 65 degrees
    assert main(["kinematics", str(out), "--friction", "35", "--cohesion", "20", "--height", "30", "-q"]) == 0
    assert json.load(open(out / "kinematics.json"))["strength"]["height_m"] == 30.0
    # the ground above the crest rising at 12 degrees: each wedge is the block under that ground
    args = ["kinematics", str(out), "--friction", "35", "--slope", "65/180", "--cohesion", "20", "-q"]
    assert main([*args, "--upper-slope", "12/195"]) == 0
    strength = json.load(open(out / "kinematics.json"))["strength"]
    assert (strength["upper_slope_dip"], strength["upper_slope_dip_direction"]) == (12.0, 195.0)
    assert "upper slope" in strength["wedge_fs"]
    uphill = list(csv.DictReader(open(out / "wedges.csv")))
    planes = {int(r["region_id"]): r for r in csv.DictReader(open(out / "planes.csv"))}
    row = next(r for r in uphill if r["wedge_fs"] not in ("", "nan"))
    pair = [planes[int(row[f"region_id_{k}"])] for k in "ab"]
    normals = [np.array([float(p[f"normal_{c}"]) for c in "xyz"])[None] for p in pair]
    face = normal_from_orientation(180.0, 65.0)
    blocks = wedge_blocks(*normals, face, strength["height_m"], normal_from_orientation(195.0, 12.0))
    fs, _ = wedge_factor_of_safety(*normals, 35.0, cohesion_a=20.0, blocks=blocks)
    assert float(row["wedge_fs"]) == pytest.approx(fs[0], rel=1e-6)
    assert float(row["wedge_fs"]) != pytest.approx(
        float(wet_wedges[(row["region_id_a"], row["region_id_b"])]["wedge_fs"])
    )
    assert main([*args, "--upper-slope", "70/180"]) == 2
    assert "--upper-slope" in capsys.readouterr().err
    for option, value in (("--cohesion", "-5"), ("--unit-weight", "0"), ("--height", "nan")):
        assert main(["kinematics", str(out), "--friction", "35", option, value, "-q"]) == 2
        assert option in capsys.readouterr().err


def test_the_figure_draws_a_sample_of_a_million_intersections_and_says_so():
    """An outcrop's 1,500 planes make a million pairs; a quarter of a million crosses drew a
    solid band over the envelopes. The figure draws a seeded sample and its legend says how
    many of how many; a few are all drawn."""
    from geostructure.kinematics.modes import Slope
    from geostructure.report.kinematics_plot import MAX_DRAWN_LINES, kinematics_figure

    rng = np.random.default_rng(0)
    dip, dd = rng.uniform(10, 80, 50), rng.uniform(0, 360, 50)
    many = (rng.uniform(0, 360, 50_000), rng.uniform(0, 90, 50_000))
    few = (rng.uniform(0, 360, 30), rng.uniform(0, 90, 30))
    figure = kinematics_figure(dip, dd, slope=Slope(65.0, 180.0), friction=30.0, lateral_limit=20.0,
                               planar=dd < 0, toppling=dd < 0, wedge_lines=many, toppling_lines=few)  # fmt: skip
    ax = next(a for a in figure.axes if a.get_legend() is not None)
    labels = {text.get_text() for text in ax.get_legend().get_texts()}
    assert f"critical wedges (intersections): {MAX_DRAWN_LINES:,} of 50,000 drawn" in labels
    assert "direct toppling intersections" in labels  # all 30 drawn: no count
    drawn = [line for line in ax.get_lines() if line.get_label().startswith("critical wedges")]
    assert len(drawn) == 1 and len(drawn[0].get_xdata()) == MAX_DRAWN_LINES


def test_kinematics_and_sets_on_a_folder_tell_their_stages(outcrop_folder):
    """``geostructure kinematics`` and ``sets`` took seconds with nothing on screen: both say
    each stage as it starts, as ``measure`` does (the command draws them as progress)."""
    from geostructure.workflows.saving import add_sets

    _, out = outcrop_folder
    stages = []
    add_kinematics(out, 30.0, progress=lambda stage, done, total: stages.append(stage))
    assert stages == ["slope", "kinematics", "write"]  # the slope fitted to the cloud first
    stages.clear()
    add_sets(out, progress=lambda stage, done, total: stages.append(stage))
    assert stages == ["read", "sets", "spacing and persistence", "write"]


def distance_to_polyline(point, vertices) -> float:
    """The least distance from ``point`` (2,) to the segments between ``vertices`` (n, 2)."""
    start, step = vertices[:-1], np.diff(vertices, axis=0)
    along = np.clip(np.einsum("ij,ij->i", point - start, step) / np.einsum("ij,ij->i", step, step), 0.0, 1.0)
    return float(np.linalg.norm(start + along[:, None] * step - point, axis=1).min())


def test_the_figure_draws_the_sets_means_and_the_wedges_they_form(outcrop_folder):
    """The set table on the net, as a geologist reads a kinematic analysis: each set's mean
    plane a great circle in its colour, and a star where two means cut in a critical wedge,
    on the line both great circles share."""
    import io

    import mplstereonet
    from rich.console import Console

    from geostructure.core.projection import great_circle_xy
    from geostructure.io.results import read_planes, read_sets
    from geostructure.kinematics.modes import Slope
    from geostructure.kinematics.summary import kinematics_of
    from geostructure.report.kinematics_net import kinematic_traces
    from geostructure.report.kinematics_plot import kinematics_result_figure
    from geostructure.report.terminal import print_kinematics

    _, out = outcrop_folder
    sets, planes = read_sets(out), read_planes(out)
    tested = kinematics_of(planes, sets, Slope(65.0, 180.0), 30.0)
    summary, figure = tested.summary, kinematics_result_figure(tested)
    # with cohesion, the means' wedges are the same and hold better, as the planes' do
    strength = {"cohesion_kpa": 20.0, "unit_weight_kn_m3": 26.0, "height_m": 6.0}
    strong = kinematics_of(planes, sets, Slope(65.0, 180.0), 30.0, strength=strength).summary["set_mean_wedges"]
    assert [w["sets"] for w in strong] == [w["sets"] for w in summary["set_mean_wedges"]]
    assert all(s["wedge_fs"] > w["wedge_fs"] for s, w in zip(strong, summary["set_mean_wedges"]))
    console = Console(width=120, record=True, file=io.StringIO())
    print_kinematics(summary, console)
    assert console.export_text().count("form a critical wedge: its line plunges") == len(summary["set_mean_wedges"])
    ax = next(a for a in figure.axes if a.get_legend() is not None)
    labels = [line.get_label() for line in ax.get_lines()]
    assert sum(label.startswith("set ") and " mean " in label for label in labels) == len(sets) == 3
    pairs = {(r["set"], s) for r in summary["sets"] for s in r["mean_wedges_with_sets"]}
    stars = [line for line in ax.get_lines() if line.get_label().startswith("wedge of set means")]
    assert pairs and len(stars) == len(pairs) // 2  # each pair named from both sides in the table
    for star in stars:
        a, b = map(int, re.findall(r"means (\d+) and (\d+)", star.get_label())[0])
        means = {r["set"]: r for r in summary["sets"]}
        normals = [normal_from_orientation(means[s]["mean_dip_direction"], means[s]["mean_dip"]) for s in (a, b)]
        line = np.cross(*normals)
        line = -line if line[2] > 0 else line  # downward
        trend = np.degrees(np.arctan2(line[0], line[1])) % 360.0
        plunge = np.degrees(np.arcsin(np.clip(-line[2] / np.linalg.norm(line), -1.0, 1.0)))
        lon, lat = mplstereonet.line(plunge, trend)
        assert np.hypot(star.get_xdata()[0] - lon[0], star.get_ydata()[0] - lat[0]) < 1e-6
    # kinematics.json gives the same wedges, and the report's net draws a star on each, on
    # both means' great circles
    assert len(summary["set_mean_wedges"]) == len(stars)
    report_stars = [t for t in kinematic_traces(summary) if t.name.startswith("wedge of set means")]
    assert len(report_stars) == len(stars)
    means = {r["set"]: r for r in summary["sets"]}
    for wedge, trace in zip(summary["set_mean_wedges"], report_stars):
        for s in wedge["sets"]:
            circle = np.column_stack(great_circle_xy(means[s]["mean_dip_direction"], means[s]["mean_dip"]))
            assert distance_to_polyline(np.array([trace.x[0], trace.y[0]]), circle) < 2e-3  # chords' sag: 2e-4


def test_a_face_of_more_joints_than_the_wedge_test_takes_is_tested_on_its_largest():
    """A 100M-point face held 3,753 joints: the wedges among joints were refused for more
    than MAX_WEDGE_PLANES, and with them the whole command. The largest are tested, as the
    largest planes are."""
    from geostructure.core.planes import Planes
    from geostructure.kinematics.modes import Slope
    from geostructure.kinematics.summary import MAX_WEDGE_PLANES, kinematics_of

    rng = np.random.default_rng(0)
    n = MAX_WEDGE_PLANES + 300
    dip, dd = rng.uniform(20, 85, n), rng.uniform(0, 360, n)
    normals = normal_from_orientation(dd, dip).reshape(-1, 3)
    planes = Planes(normal=normals, area=np.sort(rng.uniform(0.1, 2.0, n))[::-1]).with_columns(
        joint=np.arange(n), set=np.zeros(n, dtype=int)
    )
    summary = kinematics_of(planes, [], Slope(65.0, 180.0), 30.0).summary
    wedge = summary["wedge_sliding"]
    k = MAX_WEDGE_PLANES
    assert 0.9 * k * (k - 1) // 2 < wedge["joint_pairs_tested"] <= k * (k - 1) // 2  # (near-parallel pairs aside)
    assert wedge["critical_joint_pairs"] > 0


def test_every_failure_mode_of_the_catalogue_is_tested_and_written():
    """Issue 54: a failure mode is one entry of ``kinematics/catalog.py``; each of its plane
    columns is in every plane's row, and each summary row's key in the summary."""
    from geostructure.core.planes import Planes
    from geostructure.kinematics.catalog import PLANE_TEST_COLUMNS, SUMMARY_MODES
    from geostructure.kinematics.summary import kinematics_of

    planes = Planes(normal=[[0.0, -0.5, 0.866], [0.0, 0.94, 0.342]], area=[2.0, 3.0])
    tested = kinematics_of(planes, [], Slope(65.0, 180.0), 30.0)
    assert all(set(PLANE_TEST_COLUMNS) <= set(row) for row in tested.rows)
    assert [mode.key for mode in SUMMARY_MODES if mode.key not in tested.summary] == []
    assert [row["planar_sliding"] for row in tested.rows] == [True, False]
