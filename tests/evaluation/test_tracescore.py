"""The trace rule of ../shared/data/dice_lastoni_sw/README.md on hand-made cases: a trace along
a disc's trace line, one across it, one off its plane, one past its rim; the null model's
segments; the per-set figures."""

import numpy as np
import pytest
from scipy.spatial import cKDTree

from geostructure.evaluation.tracescore import null_segments, score_traces, set_trace_figures, trace_lines

# A disc of radius 0.3 m in the vertical plane x = 0, centred at the origin, on a level surface:
# its trace line runs along y.
CENTRE, NORMAL, RADIUS, LINE = np.zeros((1, 3)), np.array([[1.0, 0, 0]]), np.array([0.3]), np.array([[0.0, 1, 0]])


def traced(*polylines):
    return score_traces([np.asarray(p, dtype=float) for p in polylines], CENTRE, NORMAL, RADIUS, LINE)


def test_a_trace_along_the_disc_line_traces_it_and_one_across_does_not():
    assert traced([[0, -0.25, 0], [0, 0.25, 0]]).traced.tolist() == [True]
    assert traced([[-0.25, 0, 0], [0.25, 0, 0]]).traced.tolist() == [False]


@pytest.mark.parametrize(("angle", "hit"), [(14.0, True), (16.0, False)])
def test_the_chord_must_run_within_15_degrees_of_the_disc_line(angle, hit):
    # turned about the disc's centre in the level surface; its samples stay near the plane
    # only over a short chord: 0.1 m either side moves at most 2.8 cm off it
    t = np.radians(angle)
    half = 0.1 * np.array([np.sin(t), np.cos(t), 0.0])
    assert traced([-half, half]).traced.tolist() == [hit]


def test_60_percent_of_the_samples_within_5_cm_of_the_plane_and_the_rim():
    # 0.049 m off the plane: in; 0.051: out
    assert traced([[0.049, -0.2, 0], [0.049, 0.2, 0]]).traced[0]
    assert not traced([[0.051, -0.2, 0], [0.051, 0.2, 0]]).traced[0]
    # 7 of the 11 samples inside the radius + 5 cm (0.35): in; 6 of 11: out
    assert traced([[0, -0.35, 0], [0, 0.65, 0]]).traced[0]  # samples at -0.35 .. 0.65 by 0.1: 7 inside
    assert not traced([[0, -0.25, 0], [0, 0.75, 0]]).traced[0]  # -0.25 .. 0.75: 6 inside


def test_precision_counts_the_traces_that_trace_something():
    score = traced([[0, -0.25, 0], [0, 0.25, 0]], [[2, -0.25, 0], [2, 0.25, 0]], [[-0.2, 0, 0], [0.2, 0, 0]])
    assert score.useful.tolist() == [True, False, False] and score.precision == pytest.approx(1 / 3)


def test_the_null_models_segments_have_the_chords_and_lie_along_the_surface():
    rng = np.random.default_rng(0)
    points = np.column_stack([rng.uniform(0, 5, (5000, 2)), 0.001 * rng.standard_normal(5000)])
    tree = cKDTree(points)
    chords = rng.uniform(0.1, 1.0, 200)
    segments = null_segments(points, tree, chords, seed=3)
    assert np.allclose([np.linalg.norm(s[1] - s[0]) for s in segments], chords)
    assert max(abs((s[1] - s[0])[2]) / np.linalg.norm(s[1] - s[0]) for s in segments) < 0.01
    again = null_segments(points, tree, chords, seed=3)
    assert all(np.array_equal(a, b) for a, b in zip(segments, again))  # seeded
    # the disc line from the cloud: a vertical disc facing x on a level face runs along y
    assert abs(trace_lines(points, tree, np.array([[2.5, 2.5, 0]]), NORMAL)[0] @ [0, 1, 0]) == pytest.approx(1.0)


def test_the_per_set_figures_take_the_measured_set_nearest_each_published_one():
    published = {"1": np.array([1.0, 0, 0]), "2": np.array([0, 0, 1.0])}
    measured = np.array([[0.0, 0.0, 1.0], [np.cos(0.1), np.sin(0.1), 0.0]])  # set 1 is published 1, 5.7 deg off
    figures = set_trace_figures(np.array([1, 1, 0, -1]), np.array([0.4, 0.6, 2.0, 9.0]), measured, published,
                                np.array(["1", "1", "1", "2"]), np.array([0.5, 0.7, 0.9, 0.3]))  # fmt: skip
    one = figures["1"]
    assert (one["measured_set"], one["found_traces"], one["found_chord_sum"]) == (1, 2, pytest.approx(1.0))
    assert one["mapped_traces"] == 3 and one["mapped_chord_median"] == pytest.approx(0.7)
    assert figures["2"]["measured_set"] == 0 and figures["2"]["found_chord_median"] == pytest.approx(2.0)
