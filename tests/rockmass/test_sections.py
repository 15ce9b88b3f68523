"""A face that turns, cut into sections (`geostructure.rockmass.sections`): a quarry's corner in two,
a curved road cut in stretches that each turn less than a face that turns, a flat face and a
terrain left whole."""

import csv
import json
from dataclasses import replace

import numpy as np
import pytest
from helpers import run_cli, turned_faces, write_xyz

from geostructure.core.orientation import normal_from_orientation
from geostructure.io.results import read_planes
from geostructure.kinematics.modes import Slope, flexural_toppling, planar_sliding
from geostructure.kinematics.slope import fit_face
from geostructure.rockmass.exposure import BENT_FACE, face_bend, trace_turn
from geostructure.rockmass.sections import face_sections
from geostructure.synthetic import outcrop_scene
from geostructure.synthetic.rock_outcrop import DEFAULT_SETS


@pytest.mark.parametrize("turn", [30.0, 40.0, 90.0])
def test_a_corner_is_two_sections_numbered_left_to_right(turn):
    points = turned_faces(turn)  # the first face (x 0 to 12) on the left as one faces the rock
    first = len(outcrop_scene(width=12.0, height=6.0, seed=4, face_dip_direction=180.0).cloud.points)
    sections = face_sections(points)
    assert len(sections) == 2
    assert sections.turns()[0] == pytest.approx(turn, abs=0.1 * turn)
    assert sections.lengths == pytest.approx([12.0, 12.0], abs=1.0)
    labels = sections.of(points)
    assert np.mean(labels[:first] == 0) > 0.95 and np.mean(labels[first:] == 1) > 0.95  # 0.963 at 90


def curved_cut(total: float, width: float = 30.0) -> np.ndarray:
    """A 30 x 6 m face bent about a vertical axis into an arc turning ``total`` degrees."""
    p = outcrop_scene(width=width, height=6.0, seed=3, face_dip_direction=180.0).cloud.points
    radius = width / np.radians(total)
    angle, r = (p[:, 0] - p[:, 0].mean()) / radius, radius - p[:, 1]
    return np.column_stack([r * np.sin(angle), radius - r * np.cos(angle), p[:, 2]])


@pytest.mark.parametrize(("total", "count"), [(60.0, 2), (120.0, 4)])
def test_a_curve_is_cut_into_stretches_that_each_turn_less(total, count):
    points = curved_cut(total)
    sections = face_sections(points)
    assert len(sections) == count
    assert sections.lengths.sum() == pytest.approx(30.0, rel=0.1)
    labels = sections.of(points)
    plan = points @ sections.axes.T
    for k in range(len(sections)):  # no stretch turns as a face that turns does
        assert trace_turn(plan[labels == k]) < BENT_FACE


def test_flat_faces_and_terrains_are_one_section():
    for seed in (3, 5, 11):  # the flat faces whose trace turns most (19.1, 13.9, 15.5 degrees)
        points = outcrop_scene(width=12.0, height=6.0, seed=seed).cloud.points
        sections = face_sections(points)
        assert len(sections) == 1 and np.all(sections.of(points) == 0)
    rng = np.random.default_rng(0)
    ground = np.column_stack([rng.random((5000, 2)) * [400.0, 150.0], rng.normal(0.0, 2.0, 5000)])
    assert len(face_sections(ground)) == 1


def corner_faces(turn: float, seed: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """A quarry's corner: two 12 x 6 m faces dipping 75 degrees, the first facing south
    (x 0 to 12), the second (another face, generated facing south) turned ``turn`` degrees
    clockwise about the vertical at (12, 0), so that it dips toward 180 + ``turn``, its joints
    turned with it: both faces show three sets' facets. (Generated facing west, the second
    would show only J3's: the default sets' other two stand end-on to it.)"""
    first = outcrop_scene(width=12.0, height=6.0, seed=seed).cloud.points
    second = outcrop_scene(width=12.0, height=6.0, seed=seed + 50).cloud.points
    t = np.radians(turn)
    x, y = second[:, 0], second[:, 1]
    return first, np.column_stack([12.0 + x * np.cos(t) + y * np.sin(t), y * np.cos(t) - x * np.sin(t), second[:, 2]])


def test_a_corner_is_tested_section_by_section(tmp_path, capsys):
    """Against the mean plane of a right-angled corner (8/225) hardly a plane is critical;
    each plane against the face it lies on: 114 slide and 136 topple by the truth. At UTM
    coordinates, which the measure holds about an offset and the kinematics command reads
    back whole."""
    first, second = corner_faces(90.0)
    utm = np.array([512_000.0, 4_410_000.0, 310.0])
    path = write_xyz(tmp_path / "corner.xyz", np.vstack([first, second]) + utm)
    out = tmp_path / "out"
    code, _, err = run_cli(capsys, "measure", path, "-o", out, "--sets", "--kinematics", "--friction", "30")
    assert code == 0
    assert "tested in 2 sections" in " ".join(err.split()), err
    summary = json.loads((out / "kinematics.json").read_text())
    assert summary["slope"]["dip"] < 15.0 and summary["slope"]["sections"] == 2  # the mean face
    for section, truth in zip(summary["sections"], (180.0, 270.0)):  # 75.5/180.0 and 74.2/271.1
        assert section["slope"]["dip"] == pytest.approx(75.0, abs=2.5)
        assert section["slope"]["dip_direction"] == pytest.approx(truth, abs=2.5)
    planes = read_planes(out)
    rows = list(csv.DictReader((out / "kinematics.csv").open()))
    section = np.array([int(r["section"]) for r in rows])
    arm = ((planes.centroid[:, :2] - utm[:2] - [12.0, 0.0]) @ [0.0, -1.0] > 0).astype(int)  # the second runs south
    assert np.mean(section == arm) > 0.9  # 0.945: the planes at the corner go either way
    planar, toppling = (np.array([r[key] == "true" for r in rows]) for key in ("planar_sliding", "flexural_toppling"))
    true_planar, true_toppling = np.zeros(len(rows), dtype=bool), np.zeros(len(rows), dtype=bool)
    for k, dip_direction in enumerate((180.0, 270.0)):
        on = arm == k
        true_planar[on] = planar_sliding(planes.dip[on], planes.dip_direction[on], Slope(75.0, dip_direction), 30.0)
        true_toppling[on] = flexural_toppling(
            planes.dip[on], planes.dip_direction[on], Slope(75.0, dip_direction), 30.0
        )
    assert true_planar.sum() > 50 and true_toppling.sum() > 50
    assert np.mean(planar == true_planar) > 0.95 and np.mean(toppling == true_toppling) > 0.95  # 0.989, 0.981
    assert summary["planar_sliding"]["planes"] == sum(s["planar_sliding"]["planes"] for s in summary["sections"])
    wedges = list(csv.DictReader((out / "wedges.csv").open()))
    assert {int(w["section"]) for w in wedges} == {0, 1}
    # The kinematics command fits the same sections to the folder's points.
    assert run_cli(capsys, "kinematics", out, "--friction", "30", "-q")[0] == 0
    again = json.loads((out / "kinematics.json").read_text())
    assert [s["slope"]["dip_direction"] for s in again["sections"]] == pytest.approx(
        [s["slope"]["dip_direction"] for s in summary["sections"]], abs=1.0
    )
    # A slope given is one slope for every plane: no sections.
    code, _, _ = run_cli(capsys, "kinematics", out, "--friction", "30", "--slope", "75/180", "-q")
    summary = json.loads((out / "kinematics.json").read_text())
    assert code == 0 and "sections" not in summary and summary["slope"]["source"] == "given"


def bend_of_one_rock_mass(turn: float, seed: int = 4):
    """A road cut that turns ``turn`` degrees half way along, through one rock mass: the
    second 12 x 6 m face is generated with the sets turned back by ``turn`` and then turned
    with the face, so both show the default sets as they lie. Its scenes, and the points."""
    first = outcrop_scene(width=12.0, height=6.0, seed=seed)
    sets = tuple(replace(s, dip_direction=(s.dip_direction - turn) % 360.0) for s in DEFAULT_SETS)
    second = outcrop_scene(width=12.0, height=6.0, seed=seed + 50, sets=sets)
    t = np.radians(turn)
    x, y, z = second.cloud.points.T
    turned = np.column_stack([12.0 + x * np.cos(t) + y * np.sin(t), y * np.cos(t) - x * np.sin(t), z])
    return first, second, first.cloud.points, turned


def _set_rows(folder):
    rows = list(csv.DictReader((folder / "sets.csv").open()))
    return [(normal_from_orientation(float(r["dip_direction"]), float(r["dip"])), r) for r in rows]


def test_the_sets_of_a_bend_are_measured_section_by_section(tmp_path, capsys):
    """Each face of a bend is measured on its own mean face and a set's lines pooled: the
    spacing then reads the two faces' pooled truth within 5% (measured 0.96 to 1.05), where
    the lines on the mean face read 1.08 to 1.66 times it."""
    first, second, a, b = bend_of_one_rock_mass(40.0)
    code, _, err = run_cli(capsys, "measure", write_xyz(tmp_path / "bend.xyz", np.vstack([a, b])), "-o",
                           tmp_path / "bend", "--sets")  # fmt: skip
    assert code == 0 and "measured in 2 sections" in " ".join(err.split()) and "warning" not in err, err
    assert json.loads((tmp_path / "bend" / "run.json").read_text())["sets"]["rock_mass"]["face_sections"] == 2
    arms = []
    for name, points in (("first", a), ("second", b)):  # each face alone: its lines' length and cosine
        assert run_cli(capsys, "measure", write_xyz(tmp_path / f"{name}.xyz", points), "-o", tmp_path / name,
                       "--sets", "-q")[0] == 0  # fmt: skip
        arms.append(_set_rows(tmp_path / name))
    truth = [normal_from_orientation(s.dip_direction, s.dip) for s in DEFAULT_SETS]
    found = _set_rows(tmp_path / "bend")
    assert len(found) == 3
    for normal, row in found:
        j = int(np.argmax([abs(normal @ t) for t in truth]))
        weights, counts = 0.0, 0.0  # the lines' normal length, and the joints they meet by the truth
        for arm, scene in zip(arms, (first, second)):
            line = max(arm, key=lambda r: abs(r[0] @ normal))[1]
            normal_length = float(line["scanline_cosine"]) * float(line["scanline_length_m"])
            weights, counts = weights + normal_length, counts + normal_length / scene.set_spacing[j]
        assert float(row["spacing_m"]) == pytest.approx(weights / counts, rel=0.1)


def bay(widths: tuple[float, float, float], seed: int = 0) -> np.ndarray:
    """A quarry's bay: three walls 6 m high dipping 75 degrees, up the west side (facing
    east), along the back (facing south) and down the east side (facing west), ``widths``
    long; 1 cm of noise."""
    rng = np.random.default_rng(seed)
    a, b, c = widths
    corners = [(0.0, 0.0), (0.0, a), (b, a), (b, a - c)]
    walls = []
    for start, end in zip(corners[:-1], corners[1:]):
        start, end = np.array(start), np.array(end)
        t, v = rng.random(30_000), rng.random(30_000) * 6.0
        along = (end - start) / np.linalg.norm(end - start)
        into = np.array([-along[1], along[0]])  # the rock behind the wall
        plan = start + t[:, None] * (end - start) + into * (v * np.tan(np.radians(15.0)))[:, None]
        walls.append(np.column_stack([plan, v]) + rng.normal(0.0, 0.01, (30_000, 3)))
    return np.vstack(walls)


@pytest.mark.parametrize("widths", [(10.0, 20.0, 10.0), (15.0, 15.0, 15.0), (5.0, 30.0, 5.0), (20.0, 10.0, 20.0)])
def test_a_bay_is_a_section_per_wall(widths):
    """Its side walls lie parallel on the map, so its trace's ends do not turn from each
    other (5 to 15 degrees read); but its walls dip 75 where its mean plane dips 0 to 15: it
    folds back, and reads 180. Each wall is then a section with its own slope: cut where the
    trace turns, or, deeper than wide (20 m walls 10 m apart), by where its walls face."""
    points = bay(widths)
    assert face_bend(points) == 180.0
    face = fit_face(points)
    assert face.slope.dip < 20.0 and len(face.slopes) == 3  # from left to right as one faces the walls
    for slope, dip_direction in zip(face.slopes, (90.0, 180.0, 270.0)):
        assert slope.dip == pytest.approx(75.0, abs=2.0) and slope.dip_direction == pytest.approx(
            dip_direction, abs=2.0
        )
