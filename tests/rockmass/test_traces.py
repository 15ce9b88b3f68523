"""Joint traces on the face: their stretches, their censoring and ISRM's persistence classes."""

import numpy as np
import pytest

from geostructure.rockmass.exposure import exposure
from geostructure.rockmass.joints import PlaneMoments
from geostructure.rockmass.tracelengths import TRACE_MARGIN, Traces, joint_traces, persistence_class, trace_lengths


def face_with_a_hole():
    """An 8 x 4 m face in the plane z = 0 (up along y), sampled every 2 cm, with a hole 1 m
    square about (5, 2)."""
    g = np.mgrid[0:8:0.02, 0:4:0.02].reshape(2, -1).T
    kept = ~((np.abs(g[:, 0] - 5.0) < 0.5) & (np.abs(g[:, 1] - 2.0) < 0.5))
    points = np.column_stack([g[kept], np.zeros(int(kept.sum()))])
    return exposure(points, up=[0.0, 1.0, 0.0])


def test_a_trace_is_censored_where_the_face_ends_or_a_hole_hides_it_and_nowhere_else():
    face = face_with_a_hole()
    along_x = np.array([[1.0, 0.0, 0.0]])
    # One joint along y = 2 (through the hole) and one along y = 3 (clear of it): stretches
    # ending inside the face, at the hole's edge, and at the face's end.
    traces = Traces(
        np.repeat(along_x, 2, axis=0),
        np.array([0, 0, 1, 1]),
        np.array([1.0, 5.6, 1.0, 6.0]),
        np.array([3.0, 7.0, 3.0, 8.2]),
    )
    found = trace_lengths(traces, np.array([[0.0, 2.0, 0.0], [0.0, 3.0, 0.0]]), face)
    np.testing.assert_allclose(found.length, [2.0, 1.4, 2.0, 2.2])
    assert found.censored.tolist() == [False, True, False, True]
    # Exponential lengths with censoring: the sum over the two that end on the face.
    assert found.mean == pytest.approx(7.6 / 2)
    assert found.std_error == pytest.approx(7.6 / 2 / np.sqrt(2))  # two stretches end on the face
    assert found.median == pytest.approx(2.0)
    assert found.persistence == "medium"


def test_every_trace_out_of_sight_gives_a_lower_bound():
    face = face_with_a_hole()
    traces = Traces(np.array([[1.0, 0.0, 0.0]]), np.array([0]), np.array([-0.2]), np.array([8.2]))
    found = trace_lengths(traces, np.array([[0.0, 3.0, 0.0]]), face)
    assert found.censored.tolist() == [True] and np.isnan(found.mean)
    assert found.persistence == "medium or more"  # the mean length seen, 8.4 m, is a lower bound


def test_stretches_of_a_joint_join_across_short_gaps_and_reach_past_their_facets():
    rng = np.random.default_rng(3)
    patch = lambda x0: np.column_stack([x0 + rng.random(400), np.zeros(400), rng.random(400)])  # noqa: E731
    points = np.vstack([patch(0.0), patch(2.0), patch(7.0)])
    moments = PlaneMoments.of(points, np.repeat([0, 1, 2], 400), 3)
    traces = joint_traces(moments, np.zeros(3, dtype=int), np.array([[0.0, 1.0, 0.0]]), [0.0, 0.0, 1.0])
    # facets from 0 to 1 and 2 to 3 m (a 1 m gap): one stretch; 7 to 8 m (4 m on): another.
    # Each facet reaches two standard deviations from its centre (a uniform metre: 0.577 m).
    assert traces.joint.tolist() == [0, 0]
    reach = 2.0 / np.sqrt(12.0) + TRACE_MARGIN
    np.testing.assert_allclose(traces.start, [0.5 - reach, 7.5 - reach], atol=0.06)  # 400 points a facet
    np.testing.assert_allclose(traces.end, [2.5 + reach, 7.5 + reach], atol=0.06)


@pytest.mark.parametrize(
    ("length", "name"),
    [
        (0.99, "very low"),
        (1.0, "low"),
        (2.99, "low"),
        (3.0, "medium"),
        (10.0, "high"),
        (19.9, "high"),
        (20.0, "very high"),
    ],
)
def test_isrm_persistence_classes(length, name):
    assert persistence_class(length) == name
