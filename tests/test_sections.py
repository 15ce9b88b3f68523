"""A face that turns, cut into sections (`geostructure.sections`): a quarry's corner in two,
a curved road cut in stretches that each turn less than a face that turns, a flat face and a
terrain left whole."""

import numpy as np
import pytest
from test_face_bend import turned_faces

from geostructure.exposure import BENT_FACE, trace_turn
from geostructure.sections import face_sections
from geostructure.synthetic import outcrop_scene


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
