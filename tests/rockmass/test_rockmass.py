"""Spacing, persistence and intensity of joint sets, against the outcrop generator's truth."""

import csv
import json
import re

import numpy as np
import pytest
from conftest import shared_file
from helpers import lidar_outcrop, run_cli

from geostructure import measure
from geostructure.cli import main
from geostructure.core.cloud import Cloud
from geostructure.detect.auto import choose_params
from geostructure.evaluation.groundtruth import match_facets
from geostructure.io.crs import metres_per_unit
from geostructure.io.results import TEXT_SET_COLUMNS
from geostructure.kinematics.slope import fit_slope
from geostructure.rockmass import spacing
from geostructure.rockmass.exposure import Persistence, exposure, plane_persistence
from geostructure.rockmass.face import clutter_points, face_members
from geostructure.rockmass.mass import RockMass
from geostructure.rockmass.notes import (
    FEW_WHOLE_TRACES,
    censored_traces_note,
    jv_scope,
    persistence_note,
    set_notes,
    unmeasured_spacing,
)
from geostructure.rockmass.rqd import block_size_class, rqd_from_jv, rqd_range
from geostructure.rockmass.spacing import Scanlines, nearest_plane_gaps, spacing_class, spacing_statistics
from geostructure.rockmass.tracelengths import persistence_class
from geostructure.synthetic import bushes_on, crest_above, outcrop_scene, road_before
from geostructure.synthetic.rock_outcrop import DEFAULT_SETS, JointSet
from geostructure.synthetic.scanlines import exposed_trace_chords
from geostructure.workflows.sets_and_mass import detected_spacing, plane_rock_mass, plane_sets, sets_and_rock_mass


def measured(scene):
    result = measure(scene.cloud)  # the defaults, nothing set by hand
    sets = plane_sets(result.planes, result.frame)
    rock = plane_rock_mass(result.filtered.local, result.labels, result.planes, sets, result.frame)
    # each measured set against the generated set nearest to it
    truth = [int(np.abs(scene.set_normals @ m).argmax()) for m in sets.mean_normal]
    return result, sets, rock, truth


@pytest.fixture(scope="module", params=[4, 6])
def outcrop(request):
    scene = outcrop_scene(width=12.0, height=6.0, seed=request.param)
    return scene, *measured(scene)


def test_normal_spacing_and_p32_of_each_set_match_the_truth(outcrop):
    scene, _, sets, rock, truth = outcrop
    assert len(sets) == 3 and sorted(truth) == [0, 1, 2]
    # the truth: the generated planes met along scanlines on the face, exposed or not
    np.testing.assert_allclose(rock.spacing, scene.set_spacing[truth], rtol=0.15)
    np.testing.assert_allclose(rock.p32_from_p10, scene.set_p32[truth], rtol=0.20)
    # ... and from P21, the joints' traces on the face, with no scanline (0.71 to 1.12; the
    # facets' traces, a lower bound, read 0.37 to 0.75 on these faces)
    np.testing.assert_allclose(rock.p32_from_p21, scene.set_p32[truth], rtol=0.35)
    assert rock.jv == pytest.approx(np.sum(1.0 / rock.spacing))
    # RQD as the truth's spacings give it (94.0 and 97.9 from Jv; 90.2 to 99.7 along a line)
    assert rqd_from_jv(rock.jv) == pytest.approx(rqd_from_jv(np.sum(1.0 / scene.set_spacing)), abs=2.0)
    truth_range = rqd_range(scene.set_normals, scene.set_spacing)
    np.testing.assert_allclose(rqd_range(sets.mean_normal, rock.spacing), truth_range, atol=2.0)
    # several joints per set are met, each more than once
    assert all(line.joints >= 4 and line.crossings > 2 * line.joints for line in rock.scanlines)
    # planes across the whole face: their traces show over most of it, and no set is read
    # on its traces alone (the two spacings differ by 1.55 times at most on twenty faces)
    assert not rock.traces_only.any()
    assert all(row["spacing_basis"] == "persistent" for row in rock.set_rows())
    # ... and their traces run on past the 12 m face: long, or every one out of sight
    # (10 to 80 m where any ends on the face)
    # (10 to 80 m where any ends on the face), and a mean longer than the face is given as
    # longer than the face (issue 45), never as a figure no face this size measures
    for row in rock.set_rows():
        beyond = "trace_longer_than_exposure" in row["flags"].split(";")
        assert (
            row["joint_trace_mean_m"] >= 8.0
            or (row["joint_traces_censored"] == row["joint_traces"] > 0)
            or (beyond and row["joint_trace_estimate_m"] > row["exposure_span_m"] > 8.0)
        )
        assert np.isnan(row["joint_trace_mean_m"]) or row["joint_trace_mean_m"] <= row["exposure_span_m"]
        assert row["persistence"] not in ("very low", "low", "medium")


def test_joints_a_few_metres_long_are_counted_only_where_their_traces_show():
    """Joints as discs 3 m across (lognormal, Baecher), not planes through the rock mass:
    each measured joint extended across the 12 m face crossed the scanlines where it is not,
    and the spacing read 0.22 to 0.43 of the truth (Jv two to five times too high). Counted
    where their traces show: 1.04, 1.06 and 1.09 of it (seed 4)."""
    sets = tuple(JointSet(**{**vars(s), "persistence": 3.0}) for s in DEFAULT_SETS)
    scene = outcrop_scene(width=12.0, height=6.0, seed=4, sets=sets)
    _, found, rock, _, truth = as_the_command_line_finds(scene, scene.cloud.points)
    assert sorted(truth) == [0, 1, 2]
    assert rock.traces_only.all()
    persistent = np.array([line.spacing for line in rock.scanlines])
    assert np.all(persistent < 0.5 * scene.set_spacing[truth])  # what the persistent planes read
    np.testing.assert_allclose(rock.spacing, scene.set_spacing[truth], rtol=0.15)
    np.testing.assert_allclose(rock.p32_from_p10, scene.set_p32[truth], rtol=0.25)
    np.testing.assert_allclose(rock.p32_from_p21, scene.set_p32[truth], rtol=0.25)  # 1.21, 1.17, 1.01
    rows = rock.set_rows()
    assert [row["spacing_m"] for row in rows] == [row["spacing_traces_m"] for row in rows]
    note = persistence_note(0, rows[0])
    assert (
        note.startswith("Set 0's joints show over short stretches of the face")
        and f"{rows[0]['spacing_m']:.2f} m" in note
    )
    # Their persistence from their traces, not from their facets: the joints' mean trace
    # with censoring 0.96 to 2.0 times the discs' true chords on the face (3.3 to 3.8 m;
    # fifteen sets of 3 m joints read 0.96 to 2.01), ISRM's "medium" as the truth is; the
    # facets' own traces under half of it.
    chords = np.array([exposed_trace_chords(scene, t).mean() for t in truth])
    joint_trace = np.array([row["joint_trace_mean_m"] for row in rows])
    assert np.all((joint_trace > 0.8 * chords) & (joint_trace < 2.2 * chords))
    assert [row["persistence"] for row in rows] == ["medium"] * 3 == [persistence_class(c) for c in chords]
    assert all(row["trace_strike_mean_m"] < 0.5 * c for row, c in zip(rows, chords))


def as_the_command_line_finds(scene, points):
    """The run, sets, rock mass and fitted slope that ``measure --sets --kinematics`` gives
    (the automatic parameters), with each set's generated set."""
    cloud = Cloud(points)
    choice = choose_params(cloud.local)
    result = measure(cloud, choice.params, moments=choice.moments)
    local, spacing, up = result.filtered.local, detected_spacing(result.detection), result.frame.matrix[2]
    sets, rock = sets_and_rock_mass(local, result.labels, result.planes, result.frame, spacing=spacing)
    slope = fit_slope(
        local, result.frame, face_members(local, result.labels, result.planes.normal, up, spacing=spacing)
    )
    truth = [int(np.abs(scene.set_normals @ m).argmax()) for m in sets.mean_normal]
    return result, sets, rock, slope, truth


def test_the_road_before_a_face_is_not_part_of_its_exposure_nor_of_its_slope_nor_of_its_sets():
    """A rock cut scanned from its road: the road, 3 m deep along the foot of a 6 m face,
    tilts the least-squares face, adds its area to the exposure, runs the scanlines on across
    it, and its level planes had made a fourth set. Measured without and with the road
    (seed 4): exposure 73.2 and 71.3 m2, slope 75.44 and 75.24, spacing / truth 1.11, 1.01,
    1.00 and 1.10, 1.01, 0.99; three sets both, the road's planes in none."""
    scene = outcrop_scene(width=12.0, height=6.0, seed=4)
    road = road_before(scene, depth=3.0, seed=4)
    (_, _, rock, slope, truth), (result, sets, road_rock, road_slope, road_truth) = (
        as_the_command_line_finds(scene, points)
        for points in (scene.cloud.points, np.vstack([scene.cloud.points, road]))
    )
    assert sorted(truth) == sorted(road_truth) == [0, 1, 2]
    assert rock.ground is None or not rock.ground.any()
    assert road_rock.exposure_area == pytest.approx(rock.exposure_area, rel=0.05)
    assert road_slope.dip == pytest.approx(slope.dip, abs=1.0)
    np.testing.assert_allclose(road_rock.spacing / scene.set_spacing[road_truth], 1.0, atol=0.15)
    # the ground planes are the road's: level, in no set, and most of the road's points are in them
    ground = np.flatnonzero(road_rock.ground)
    assert len(ground) and np.all(np.abs(result.planes.normal[ground] @ result.frame.matrix[2]) > 0.95)
    assert np.all(sets.labels[ground] == -1)
    on_road = result.labels[np.flatnonzero(result.filter_result.keep) >= len(scene.cloud.points)]
    assert np.isin(on_road, ground).mean() > 0.8


def test_the_ground_above_the_crest_is_not_part_of_the_face_either():
    """Level ground 3 m deep behind the crest of the 6 m face (seed 4): measured, slope 75.35
    for 75.44, exposure 71.1 m2 for 73.2, spacing / truth 1.00, 0.99, 1.08 (J1, J2, J3), three
    sets, the crest's 49 level planes in none."""
    scene = outcrop_scene(width=12.0, height=6.0, seed=4)
    crest = crest_above(scene, depth=3.0, seed=1)
    (_, _, rock, slope, _), (result, sets, crest_rock, crest_slope, truth) = (
        as_the_command_line_finds(scene, points)
        for points in (scene.cloud.points, np.vstack([scene.cloud.points, crest]))
    )
    assert sorted(truth) == [0, 1, 2]
    assert crest_slope.dip == pytest.approx(slope.dip, abs=0.5)
    assert crest_rock.exposure_area == pytest.approx(rock.exposure_area, rel=0.05)
    np.testing.assert_allclose(crest_rock.spacing / scene.set_spacing[truth], 1.0, atol=0.15)
    ground = np.flatnonzero(crest_rock.ground)
    assert len(ground) and np.all(sets.labels[ground] == -1)
    on_crest = result.labels[np.flatnonzero(result.filter_result.keep) >= len(scene.cloud.points)]
    assert np.isin(on_crest, ground).mean() > 0.8


def test_bushes_on_the_face_are_no_part_of_its_exposure_nor_of_its_slope_nor_of_its_sets():
    """Vegetation: three bushes (noisy half-shells, 28,573 points) hiding 12% of a 12 x 6 m
    face. Taken for face, they had added their outline to the exposure, tilted the fitted
    face and given planes (100% bush points) that joined the sets and, extended across the
    face as joints are, made spacings short. Measured without and with the bushes (seed 4):
    exposure 73.2 and 62.6 m2 (the face less what the bushes hide: 64.2), slope 75.44 and
    74.47, spacing / truth 1.11, 1.01, 1.00 and 1.17, 0.90, 0.76 (the 45-degree set, 30
    degrees from the face, meets a scanline 1.7 times as far along it as its spacing: a few
    joints decide it); 93% of the bushes' points and 3% of the rock's are clutter."""
    scene = outcrop_scene(width=12.0, height=6.0, seed=4)
    bushes, hidden = bushes_on(scene, 3, seed=4)
    (_, _, rock, slope, truth), (result, sets, bush_rock, bush_slope, bush_truth) = (
        as_the_command_line_finds(scene, points)
        for points in (scene.cloud.points, np.vstack([scene.cloud.points[~hidden], bushes]))
    )
    assert sorted(truth) == sorted(bush_truth) == [0, 1, 2]
    assert bush_rock.exposure_area == pytest.approx(rock.exposure_area * (1 - hidden.mean()), rel=0.05)
    assert bush_slope.dip == pytest.approx(slope.dip, abs=1.5)
    np.testing.assert_allclose(bush_rock.spacing / scene.set_spacing[bush_truth], 1.0, atol=0.3)
    from_bush = np.flatnonzero(result.filter_result.keep) >= (~hidden).sum()
    clutter = clutter_points(result.filtered.local, result.labels, detected_spacing(result.detection))
    assert clutter[from_bush].mean() > 0.85 and clutter[~from_bush].mean() < 0.05
    # no plane of bush points is in a set
    mine = result.labels >= 0
    in_bush = np.bincount(result.labels[mine], weights=from_bush[mine], minlength=len(result.planes))
    assert np.all(sets.labels[in_bush > 0.5 * result.planes.n_points] == -1)


@pytest.mark.slow
def test_spacing_on_a_lidar_like_face_at_utm_offset():
    scene = lidar_outcrop(8.0, 5.0)
    _, sets, rock, truth = measured(scene)
    assert len(sets) == 3 and sorted(truth) == [0, 1, 2]
    # Each set's joints match its generated planes one to one (a facet ten degrees off its
    # joint, or one near where two joints of a set cross, once split a joint: 0.68 of the truth)
    np.testing.assert_allclose(rock.spacing, scene.set_spacing[truth], rtol=0.15)
    np.testing.assert_allclose(rock.p32_from_p10, scene.set_p32[truth], rtol=0.20)


def test_spacing_of_parallel_joints_on_a_clean_face():
    sets = tuple(JointSet(s.name, s.dip, s.dip_direction, 1e6, s.spacing) for s in DEFAULT_SETS)
    scene = outcrop_scene(
        width=10.0,
        height=5.0,
        seed=3,
        sets=sets,
        roughness=0.0,
        correlated_noise=0.0,
        noise=0.001,
        outlier_fraction=0.0,
    )
    _, _, rock, truth = measured(scene)
    # what is left is two joints of a set nearer than the 2 cm that tells joints apart
    np.testing.assert_allclose(rock.spacing, scene.exposed_set_spacing[truth], rtol=0.12)
    # Planes through the rock mass run edge to edge of a 10 m face: persistent, or where every
    # trace runs out of sight (one set here), a lower bound that says so under the table.
    rows = rock.set_rows()
    assert {row["persistence"] for row in rows} <= {"very high", "high or more"}
    hidden = [s for s, row in enumerate(rows) if row["joint_traces"] == row["joint_traces_censored"] > 0]
    assert hidden, "no set whose traces all run off the face: the case below is not tested"
    for s, row in enumerate(rows):
        note = censored_traces_note(s, row)
        if s in hidden:
            assert np.isnan(row["joint_trace_mean_m"]) and note in set_notes(s, row)
            assert note.startswith(f"All {row['joint_traces']} of set {s}'s joint traces run out of sight")
            assert f"{row['joint_trace_median_m']:.2f} m median seen is a lower bound" in note
        elif "trace_longer_than_exposure" in row["flags"].split(";"):  # a bound: the face's span
            assert np.isnan(row["joint_trace_mean_m"]) and note is None
            assert "so the mean is given as longer than" in " ".join(set_notes(s, row))
        else:
            assert np.isfinite(row["joint_trace_mean_m"])
            whole = row["joint_traces"] - row["joint_traces_censored"]
            if whole > FEW_WHOLE_TRACES:
                assert note is None
            else:  # the mean rests on a few whole traces: the note gives its standard error
                assert f"rests on the {whole if whole > 1 else 'one'} seen end to end" in note


def test_joints_are_the_generated_planes_each_once(outcrop):
    # Each measured plane's facet in the truth (its centroid on the facet, its normal within
    # 5 degrees), and so the generated plane it lies on; each joint against those planes.
    scene, result, sets, rock, _ = outcrop
    joints = rock.joints
    facet = match_facets(result.planes, scene).plane_facet
    ok = (facet >= 0) & (joints.plane_joint >= 0)
    plane = scene.facet_set[facet[ok]] * 1000 + scene.facet_plane[facet[ok]]
    joint, points = joints.plane_joint[ok], result.planes.n_points[ok]
    # purity: the share of a joint's facets' points on its commonest generated plane (0.988
    # and 0.997 on these faces)
    on_commonest = sum(np.bincount(np.unique(plane[joint == j], return_inverse=True)[1], points[joint == j]).max()
                       for j in np.unique(joint))  # fmt: skip
    assert on_commonest / points.sum() > 0.97
    # every generated plane seen is one joint, or nearly every one (94 and 100%)
    split = np.array([len(np.unique(joint[plane == p])) for p in np.unique(plane)])
    assert np.mean(split == 1) >= 0.9
    assert len(joints) == pytest.approx(len(np.unique(plane)), rel=0.1)
    # planes in no set are in no joint; every set plane is in one
    assert np.array_equal(joints.plane_joint >= 0, sets.labels >= 0)
    assert np.array_equal(joints.set[joints.plane_joint[sets.labels >= 0]], sets.labels[sets.labels >= 0])


def test_persistence_traces_and_censoring_at_the_cloud_edge(outcrop):
    scene, result, _, rock, _ = outcrop
    facet = scene.facet_index[result.filter_result.keep]  # each filtered point's facet
    clean = scene.clean - scene.offset
    ratios, flagged, cut = [], [], []
    for p in range(len(result.planes)):
        own = facet[result.labels == p]
        own = own[own >= 0]
        f = np.bincount(own).argmax() if len(own) >= 30 else -1
        if f < 0 or (own == f).mean() < 0.9:
            continue  # a plane that is not mostly one facet
        strike = np.cross([0.0, 0.0, 1.0], scene.facet_normal[f])
        strike /= np.linalg.norm(strike)
        ratios.append(rock.persistence.trace_strike[p] / np.ptp(clean[scene.facet_index == f] @ strike))
        flagged.append(rock.persistence.censored[p])
        cut.append(scene.facet_censored[f])
    ratios, flagged, cut = map(np.asarray, (ratios, flagged, cut))
    assert len(ratios) > 100
    assert 0.85 < np.median(ratios) < 1.05  # a plane's points stop a little short of its facet's edge
    # facets cut by the border or a hole are flagged: 0.78 and 0.84 of some 50 on seeds 4 and
    # 6 (0.83 and 0.83 before sparse cells took their coarser block's plane, 2026-12-02)
    assert flagged[cut].mean() > 0.75
    assert (~flagged[~cut]).mean() > 0.8  # and those inside mostly not


def test_a_patch_at_the_border_is_censored_and_one_inside_is_not():
    rng = np.random.default_rng(2)
    xy = rng.random((60_000, 2)) * [6.0, 3.0]
    points = np.column_stack([xy, 0.001 * rng.standard_normal(len(xy))])
    inside = (xy[:, 0] > 2) & (xy[:, 0] < 3) & (xy[:, 1] > 1) & (xy[:, 1] < 1.5)
    border = (xy[:, 0] < 1) & (xy[:, 1] < 0.5)
    labels = np.select([inside, border], [0, 1], -1)
    face = exposure(points, up=[0, 1, 0])
    p = plane_persistence(points, labels, [[0.0, 0.0, 1.0]] * 2, face, up=[0, 1, 0])
    assert p.censored.tolist() == [False, True]
    np.testing.assert_allclose(p.trace_strike, [1.0, 1.0], atol=0.02)  # strike is x here (up is y)
    np.testing.assert_allclose(p.trace_dip, [0.5, 0.5], atol=0.02)
    assert face.area == pytest.approx(18.0, rel=0.02)


def test_nearest_plane_gaps_of_stacked_discs_in_blocks_of_rows(monkeypatch):
    # Columns of discs 1 m across, 0.3 m apart along z, side by side 2 m apart (no overlap
    # between columns): each disc's nearest overlapping neighbour is 0.3 m away.
    rng = np.random.default_rng(4)
    columns, per_column = 40, 25
    centres = np.array([[2.0 * c, 0.0, 0.3 * k] for c in range(columns) for k in range(per_column)])
    centres[:, :2] += rng.uniform(-0.05, 0.05, (len(centres), 2))  # still overlapping in a column
    n = len(centres)
    persistence = Persistence(np.ones(n), np.full(n, 0.5), np.ones(n), np.zeros(n, bool))
    members, mean = rng.permutation(n), np.array([0.0, 0.0, 1.0])
    whole = nearest_plane_gaps(np.tile(mean, (n, 1)), centres, members, mean, persistence)
    assert len(whole) == n and np.allclose(whole, 0.3)
    monkeypatch.setattr(spacing, "PAIRS_AT_ONCE", 3 * n)  # 3 rows at a time
    np.testing.assert_array_equal(nearest_plane_gaps(np.tile(mean, (n, 1)), centres, members, mean, persistence), whole)


def test_jv_and_block_volume_of_three_orthogonal_sets():
    lines = [Scanlines(np.zeros(0), 10.0, int(10 / s), 5, 1.0, None) for s in (0.5, 1.0, 2.0)]
    rock = RockMass(None, 1.0, np.zeros(0), lines)
    assert rock.spacing.tolist() == [0.5, 1.0, 2.0]
    assert rock.jv == pytest.approx(3.5)  # 1/0.5 + 1/1 + 1/2
    assert rock.block_volume == pytest.approx(36.0 / 3.5**3)  # Palmstrom
    assert rock.block_volume_three_sets(np.eye(3)) == pytest.approx(1.0)  # 0.5 x 1 x 2


def test_spacing_distribution_fits():
    rng = np.random.default_rng(4)
    lognormal = spacing_statistics(rng.lognormal(np.log(0.5), 0.4, 5000))
    assert lognormal["best_fit"] == "lognormal"
    assert lognormal["median"] == pytest.approx(0.5, rel=0.05)
    assert lognormal["mode"] == pytest.approx(0.5 * np.exp(-(0.4**2)), rel=0.2)
    assert lognormal["lognorm_sigma"] == pytest.approx(0.4, rel=0.05)
    exponential = spacing_statistics(rng.exponential(0.3, 5000))
    assert exponential["best_fit"] == "exponential" and exponential["exp_ks"] < 0.03
    assert np.isnan(spacing_statistics([0.2, 0.3])["median"])  # too few gaps to fit


def test_the_fits_agree_with_scipy_stats():
    from scipy import stats

    gaps = np.random.default_rng(5).lognormal(np.log(0.4), 0.6, 300)
    fit = spacing_statistics(gaps)
    sigma, scale = fit["lognorm_sigma"], np.exp(fit["lognorm_mu"])
    log_likelihood = stats.lognorm.logpdf(gaps, sigma, scale=scale).sum()
    assert fit["lognorm_aic"] == pytest.approx(4 - 2 * log_likelihood, rel=1e-9)
    assert fit["lognorm_ks"] == pytest.approx(stats.kstest(gaps, "lognorm", args=(sigma, 0, scale)).statistic, rel=1e-9)
    assert fit["exp_ks"] == pytest.approx(stats.kstest(gaps, "expon", args=(0, fit["exp_mean"])).statistic, rel=1e-9)


def test_the_outputs_of_measure_sets_and_of_the_sets_command(tmp_path, capsys):
    scene = outcrop_scene(width=8.0, height=5.0, seed=6, offset=(500_000.0, 4_600_000.0, 200.0))
    cloud = tmp_path / "outcrop.xyz"
    np.savetxt(cloud, scene.cloud.points, fmt="%.4f")
    out = tmp_path / "out"
    code, printed, _ = run_cli(capsys, "measure", cloud, "-o", out, "--sets", "--report")
    assert code == 0

    def read(name):
        with open(out / name, newline="") as fh:
            return list(csv.DictReader(fh))

    sets, spacing, planes = read("sets.csv"), read("spacing.csv"), read("planes.csv")
    assert len(sets) == 3
    for row in sets:
        assert float(row["spacing_m"]) > 0.1 and float(row["p32_per_m"]) > 0.3
        assert row["spacing_best_fit"] in ("exponential", "lognormal")
        gaps = [float(r["spacing_m"]) for r in spacing if r["set"] == row["set"] and r["method"] == "scanline"]
        assert len(gaps) == int(row["spacing_n_gaps"]) and np.mean(gaps) == pytest.approx(
            float(row["spacing_mean_gap_m"])
        )
    assert {"trace_strike_m", "trace_dip_m", "censored"} <= set(planes[0])
    assert {int(p["censored"]) for p in planes} == {0, 1}
    record = json.load(open(out / "run.json"))["sets"]["rock_mass"]
    # the terminal's plane table prints the standard errors planes.csv holds, the joints'
    # correlated tilt included (it printed them as measured: 0.18 degrees for 0.63 on autzen)
    first = next(line for line in printed.splitlines() if re.match(r"│\s+0 │", line))  # the plane table's
    assert record["correlated_tilt_deg"] > 0.3 and f"│  {float(planes[0]['normal_uncertainty_deg']):.2f} │" in first
    assert record["jv_per_m3"] == pytest.approx(sum(1 / float(r["spacing_m"]) for r in sets))
    assert record["rqd_from_jv"] == pytest.approx(rqd_from_jv(record["jv_per_m3"]))
    assert record["block_size_class"] == block_size_class(record["jv_per_m3"])
    # every discontinuity once: joints.csv, a row per joint; planes.csv's joint column
    joints = read("joints.csv")
    in_sets = [p for p in planes if int(p["set"]) >= 0]
    assert sum(int(j["n_planes"]) for j in joints) == len(in_sets) > len(joints) > 0
    assert sorted({int(p["joint"]) for p in in_sets}) == [int(j["joint"]) for j in joints]
    import laspy  # each point's joint in regions.laz, through its region, for CloudCompare

    regions = laspy.read(str(out / "regions.laz"))
    joint_of = {int(p["region_id"]): int(p["joint"]) for p in planes}
    region, joint = np.asarray(regions.region_id), np.asarray(regions.joint)
    assert np.array_equal(joint, [joint_of.get(r, -1) for r in region.tolist()]) and (joint >= 0).mean() > 0.5
    dips = read("planes_dips.csv")  # Dips' extra column: blank for a plane in no joint
    assert [d["Joint"] for d in dips] == ["" if int(p["joint"]) < 0 else p["joint"] for p in planes]
    # no joint reads as one in no set: each plane says what it is (issue 52)
    flags = [(int(p["ground"]), int(p["clutter"]), int(p.get("face_surface") or 0)) for p in planes]
    expected = ["ground" if g else "clutter" if c else "face surface" if f else "discontinuity" for g, c, f in flags]
    assert [d["Kind"] for d in dips] == expected
    assert [sum(int(j["set"]) == int(r["set"]) for j in joints) for r in sets] == [int(r["n_joints"]) for r in sets]
    for j in joints[:5]:
        members = [p for p in in_sets if p["joint"] == j["joint"]]
        assert float(j["area_m2"]) == pytest.approx(sum(float(p["area_m2"]) for p in members))
        assert abs(float(j["dip"]) - float(members[0]["dip"])) < 10  # the joint's plane and its facets'
        assert float(j["centroid_x"]) > 499_000  # in the input's UTM coordinates
    assert all(row["spacing_class"] == spacing_class(float(row["spacing_m"])) != "" for row in sets)
    assert record["rqd_min_by_direction"] <= record["rqd_max_by_direction"] <= 100.0
    html = (out / "report.html").read_text()
    assert "Normal spacing per set" in html and "Spacing (m)" in html and "Jv" in html
    assert f"RQD {record['rqd_from_jv']:.0f} ({record['rqd_min_by_direction']:.0f} to" in html
    # From the folder's files, the same figures: to the last bits the points read back from
    # regions.ply (in the input's UTM coordinates) differ from the measure's local ones.
    assert main(["sets", str(out), "-q"]) == 0
    again = read("sets.csv")
    assert np.array_equal(np.asarray(laspy.read(str(out / "regions.laz")).joint), joint)  # written again
    joints_again, whole = read("joints.csv"), ("joint", "set", "section", "n_planes", "n_points", "trace_censored")
    assert [[j[k] for k in whole] for j in joints_again] == [[j[k] for k in whole] for j in joints]
    numbers = [k for k in joints[0] if k not in whole]
    np.testing.assert_allclose([[float(j[k]) for k in numbers] for j in joints_again],
                               [[float(j[k]) for k in numbers] for j in joints], rtol=1e-4, atol=1e-6)  # fmt: skip
    for a, b in zip(sets, again):
        text = TEXT_SET_COLUMNS
        assert [a[k] for k in text] == [b[k] for k in text]
        keys = [k for k in a if k not in text]
        np.testing.assert_allclose([float(a[k]) for k in keys], [float(b[k]) for k in keys], rtol=1e-4)


def test_the_measured_standard_errors_are_the_ones_the_rock_mass_would_compute(outcrop):
    """measure --sets hands the rock mass the table's own standard errors instead of
    computing them again (0.7 s at 8M points): they must be the very same, tilt and all."""
    _, result, sets, rock, _ = outcrop
    given = plane_rock_mass(
        result.filtered.local, result.labels, result.planes, sets, result.frame, errors=result.planes.standard_errors()
    )
    for name, values in rock.plane_errors.items():
        assert np.array_equal(given.plane_errors[name], values, equal_nan=True), name
    assert given.correlated_tilt == rock.correlated_tilt


def test_a_cloud_in_feet_gives_its_rock_mass_in_metres():
    """A State Plane survey in feet (EPSG:2992): sets.csv's spacing, areas, traces and
    intensities are metres, as for the same face in metres, and the joints' metric
    tolerances (2 cm, 1 m between scanlines) are metres too, not feet."""
    scene = outcrop_scene(width=8.0, height=5.0, seed=5)
    found = {}
    for crs, unit in (("EPSG:32633", 1.0), ("EPSG:2992", 0.3048)):
        result = measure(Cloud(scene.cloud.local / unit, crs=crs))
        found[unit] = sets_and_rock_mass(result.filtered.local, result.labels, result.planes, result.frame,
                                         spacing=detected_spacing(result.detection),
                                         metres_per_unit=metres_per_unit(crs))  # fmt: skip
    (m_sets, m_rock), (ft_sets, ft_rock) = found[1.0], found[0.3048]
    assert len(m_sets) == len(ft_sets) == 3
    np.testing.assert_allclose(ft_rock.spacing, m_rock.spacing, rtol=0.05)
    np.testing.assert_allclose(ft_sets.area, m_sets.area, rtol=0.05)
    np.testing.assert_allclose(ft_rock.p21, m_rock.p21, rtol=0.05)
    # the joints' traces in metres too (their margins and the censoring's reach are metres)
    trace = {unit: [row["joint_trace_mean_m"] for row in found[unit][1].set_rows()] for unit in found}
    np.testing.assert_allclose(trace[0.3048], trace[1.0], rtol=0.05)
    assert ft_rock.exposure_area == pytest.approx(m_rock.exposure_area, rel=0.02)
    assert ft_rock.summary(ft_sets.mean_normal)["metres_per_cloud_unit"] == 0.3048


def test_a_cloud_in_millimetres_without_a_crs_is_given_its_unit(tmp_path, capsys):
    """A text cloud in millimetres has no CRS to say so: taken as metres, its sets' areas
    came out a million times too large, with exit 0. ``--unit mm`` gives the rock mass in
    metres, as for the same face in metres; without it, a note says what the spacing
    suggests; and a unit the CRS contradicts is refused before any work."""
    scene = outcrop_scene(width=8.0, height=5.0, seed=5)
    clouds = {"m": tmp_path / "face_m.xyz", "mm": tmp_path / "face_mm.xyz"}
    np.savetxt(clouds["m"], scene.cloud.points, fmt="%.5f")
    np.savetxt(clouds["mm"], scene.cloud.points * 1000.0, fmt="%.2f")
    runs = {}
    for name, cloud, options in (("m", "m", []), ("mm", "mm", ["--unit", "mm"]), ("mm_unstated", "mm", [])):
        out = tmp_path / name
        code, _, err = run_cli(capsys, "measure", clouds[cloud], "-o", out, "--sets", *options)
        assert code == 0
        runs[name] = (list(csv.DictReader(open(out / "sets.csv"))), json.loads((out / "run.json").read_text()), err)
    (m_sets, m_run, m_err), (mm_sets, mm_run, mm_err) = runs["m"], runs["mm"]
    assert len(m_sets) == len(mm_sets) == 3 and "--unit mm" not in m_err + mm_err
    assert mm_run["unit"] == {"symbol": "mm", "metres": 0.001} and "unit" not in m_run
    area = {name: sorted(float(r["area_m2"]) for r in rows[0]) for name, rows in runs.items()}
    np.testing.assert_allclose(area["mm"], area["m"], rtol=0.1)
    np.testing.assert_allclose(area["mm_unstated"], 1e6 * np.array(area["mm"]), rtol=1e-9)
    assert "taken to be the metre; if the cloud is in millimetres" in runs["mm_unstated"][2]
    code, _, err = run_cli(
        capsys, "measure", clouds["mm"], "-o", tmp_path / "no", "--unit", "ft", "--crs", "EPSG:32633"
    )
    assert code == 2 and "--crs EPSG:32633: its CRS is in m, not ft" in err and not (tmp_path / "no").exists()
    assert main(["report", str(tmp_path / "mm"), "-q"]) == 0
    page = (tmp_path / "mm" / "report.html").read_text()  # areas in m² on every table; sizes in the cloud's unit
    assert "Area (m²)" in page and "Roughness (mm)" in page
    # planes.csv's area_m2 is square metres whatever the cloud's unit (it held mm^2 under
    # that name), and a command that reads the folder back and writes it again keeps it so
    planes_area = {name: np.array([float(r["area_m2"]) for r in csv.DictReader(open(tmp_path / name / "planes.csv"))])
                   for name in ("m", "mm")}  # fmt: skip
    assert planes_area["mm"].sum() == pytest.approx(planes_area["m"].sum(), rel=0.05)
    assert json.loads((tmp_path / "mm" / "run.json").read_text())["plane_area"] == "m2"
    assert main(["sets", str(tmp_path / "mm"), "-q"]) == 0
    again = np.array([float(r["area_m2"]) for r in csv.DictReader(open(tmp_path / "mm" / "planes.csv"))])
    np.testing.assert_allclose(again, planes_area["mm"], rtol=1e-12)


def test_a_set_along_the_exposed_face_says_why_it_has_no_spacing():
    """Bedding on a level exposure: no scanline on the face crosses it (the blind zone).
    Its spacing is NaN in sets.csv; the table shows a dash and says why, and Jv names the
    sets it leaves out rather than passing for the whole rock mass."""
    along = {"spacing_m": np.nan, "scanline_cosine": 0.0229, "spacing_nearest_m": 0.963,
             "p32_per_m": np.nan, "n_censored": 8}  # fmt: skip
    crossed = {"spacing_m": 0.4, "scanline_cosine": 0.9, "spacing_nearest_m": 0.5, "p32_per_m": 2.5, "n_censored": 1}
    note = unmeasured_spacing(0, along)
    assert note.startswith("Set 0 lies along the exposed face (its mean normal 1° from the face's)")
    assert "0.96 m" in note and unmeasured_spacing(1, crossed) is None
    assert "no joint" in unmeasured_spacing(2, {**along, "scanline_cosine": 0.8})
    assert jv_scope([along, crossed]) == " (without set 0)" and jv_scope([crossed]) == ""


@pytest.mark.real_data
def test_airborne_lidar_in_feet_its_level_roofs_and_the_metric_rock_mass(tmp_path, capsys):
    """autzen (Oregon Lambert, feet): the roofs and ground form one near-level set on a level
    exposure. Its traces come out in metres, the plane table's sizes are labelled in feet,
    and the tables say why the set has no spacing instead of printing NaN."""
    out = tmp_path / "autzen"
    code, printed, err = run_cli(
        capsys, "measure", shared_file("pdal_autzen/autzen_trim.laz"), "-o", out, "--sets", "--report"
    )  # the report once failed on run.json's null Jv
    assert code == 0 and "nan" not in printed.lower()
    # its one set lies along the face: its joints are the terrain's pieces, and their
    # scatter is the terrain's shape, not a correlated error every plane should carry
    assert "lie in sets along the face, which follow the face's shape" in " ".join(err.split())
    assert "lies along the exposed face" in " ".join(printed.split())
    # the face shows that set's planes whole: no trace, nor a persistence class from one
    # (its joints' traces along an arbitrary line of the face read 54 m, "very high")
    with open(out / "sets.csv", newline="") as fh:
        (row,) = list(csv.DictReader(fh))
    assert row["joint_trace_mean_m"] == "nan" and row["persistence"] == "" and row["joint_traces"] == "0"
    page = (out / "report.html").read_text()
    assert "lies along the exposed face" in page and "Area (m²)" in page and "Roughness (ft)" in page
    # a terrain: the 3D view opens from the south and above, north up the screen as on a map
    eye = [float(v) for v in re.search(r'"eye":\{"x":([-\d.e]+),"y":([-\d.e]+),"z":([-\d.e]+)\}', page).groups()]
    assert eye[1] < 0 < eye[2] and abs(eye[0]) < 0.1 * abs(eye[1])
    run = json.loads((out / "run.json").read_text())
    assert run["sets"]["rock_mass"]["metres_per_cloud_unit"] == 0.3048
    assert run["unit"] == {"symbol": "ft", "metres": 0.3048}  # what planes.csv's sizes but area_m2 are in
    with open(out / "planes.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    in_set = [r for r in rows if r["set"] == "0"]
    assert run["sets"]["rock_mass"]["correlated_tilt_deg"] == 0.0
    assert float(rows[0]["normal_uncertainty_deg"]) < 0.3  # its fit's 0.18; 0.63 with the terrain's "tilt"
    # a plane's rectangle is in the cloud's feet; its trace along strike, in metres, spans
    # no more than the rectangle's diagonal in metres
    diagonal_m = [0.3048 * np.hypot(float(r["rect_width"]), float(r["rect_height"])) for r in in_set]
    assert in_set and all(float(r["trace_strike_m"]) <= 1.001 * d for r, d in zip(in_set, diagonal_m))
