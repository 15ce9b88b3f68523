"""Each joint's trace on the face: the stretches its facets show, and their lengths.

A joint (:func:`~geostructure.rockmass.joints.joint_planes`, the facets of one plane) meets the mean face along
a line, its trace. The cloud shows the joint only where the face runs along it, as facets;
elsewhere its trace is a crack that the points do not show. :func:`joint_traces` takes the
stretches of the trace its facets cover, bridging short gaps, and
:func:`trace_lengths` measures them: a set's persistence (ISRM 1978) from its joints, not
from its facets, whose median trace is 0.5 to 1 m whatever the joints' size (1.5 m discs to
planes through the rock mass, on the synthetic faces of ``docs/rockmass.md``). A stretch that may run on out of sight (the face ends, or a hole, at either end) is
censored, and a set's mean trace length is the exponential distribution's estimate with
censoring (the sum of all lengths over the number not censored), as for the planes' traces.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from geostructure.rockmass.exposure import Exposure
    from geostructure.rockmass.joints import PlaneMoments

#: A joint's trace on the face runs across a gap of up to this length (m) between its facets
#: (where another set's facet crosses it, or the face is hidden) ...
TRACE_GAP = 3.0
#: ... and this far (m) beyond its outermost facets.
TRACE_MARGIN = 0.35


@dataclass(frozen=True)
class Traces:
    """The joints' traces on the face: each joint's trace ``direction`` (J, 3), and the
    stretches of it that its facets show, ``joint`` (T,), from ``start`` to ``end`` (T,)
    (m, positions along the direction), sorted by joint and start, apart from each other."""

    direction: np.ndarray
    joint: np.ndarray
    start: np.ndarray
    end: np.ndarray

    def reach(self, joint, position) -> np.ndarray:
        """Whether each joint's trace reaches ``position`` along it (m)."""
        if len(self.joint) == 0:
            return np.zeros(len(joint), dtype=bool)
        # One sorted key for all stretches: the joints' positions in disjoint ranges.
        width = 2.0 * max(np.abs(self.start).max(), np.abs(self.end).max(), np.abs(position).max(initial=0)) + 1.0
        lo, hi = self.joint * width + self.start, self.joint * width + self.end
        key = np.asarray(joint) * width + position
        k = np.searchsorted(lo, key, side="right") - 1
        return (k >= 0) & (key <= hi[np.maximum(k, 0)])


def joint_traces(moments: PlaneMoments, joint, joint_normal, face_normal) -> Traces:
    """Each joint's trace on the face and the stretches its facets show
    (:class:`Traces`): a facet covers twice its points' standard deviation either side of its
    centroid along the trace (a disc's edge is 2 sigma out); gaps up to :data:`TRACE_GAP`
    between them are bridged and :data:`TRACE_MARGIN` is added at each end.

    Examples
    --------
    Three facets of one joint (the plane y = 0) on a face normal to z, along x from 0 to 1,
    1.5 to 2.5 and 6 to 7 m: the first two are one stretch of its trace, the third another.

    >>> rng = np.random.default_rng(0)
    >>> patch = lambda x0: np.column_stack([x0 + rng.random(300), np.zeros(300), rng.random(300)])
    >>> points = np.vstack([patch(0.0), patch(1.5), patch(6.0)])
    >>> from geostructure.rockmass.joints import PlaneMoments
    >>> moments = PlaneMoments.of(points, np.repeat([0, 1, 2], 300), 3)
    >>> traces = joint_traces(moments, np.array([0, 0, 0]), np.array([[0.0, 1.0, 0.0]]), [0.0, 0.0, 1.0])
    >>> traces.joint.tolist(), np.round(traces.end - traces.start, 1).tolist()
    ([0, 0], [3.3, 1.9])
    >>> traces.reach(np.zeros(3, dtype=int), np.array([2.0, 4.0, 6.0])).tolist()
    [True, False, True]
    """
    face_normal = np.asarray(face_normal, dtype=np.float64)
    direction = np.cross(joint_normal, face_normal)
    norm = np.linalg.norm(direction, axis=1, keepdims=True)
    # A joint parallel to the face has no trace: any direction in the face will do.
    direction = np.where(norm > 1e-9, direction / np.maximum(norm, 1e-12), _any_in_face(face_normal))
    mine = np.flatnonzero(joint >= 0)
    owner = joint[mine]
    d = direction[owner]
    centre = np.einsum("ij,ij->i", moments.centroid[mine], d)
    spread = np.einsum("ij,ijk,ik->i", d, moments.scatter[mine], d) / np.maximum(moments.count[mine], 1)
    half = 2.0 * np.sqrt(np.maximum(spread, 0.0)) + TRACE_MARGIN
    order = np.lexsort((centre - half, owner))
    owner, start, end = owner[order], (centre - half)[order], (centre + half)[order]
    if len(owner) == 0:
        return Traces(direction, owner, start, end)
    # Each joint's running end so far, by one cumulative maximum over the joints' positions
    # laid in disjoint ranges: a facet starting a gap beyond it starts a new stretch.
    width = 2.0 * max(np.abs(start).max(), np.abs(end).max()) + 1.0
    running = np.maximum.accumulate(end + owner * width) - owner * width
    new = np.ones(len(owner), dtype=bool)
    new[1:] = (owner[1:] != owner[:-1]) | (start[1:] > running[:-1] + TRACE_GAP - 2 * TRACE_MARGIN)
    last = np.append(np.flatnonzero(new)[1:], len(owner)) - 1
    return Traces(direction, owner[new], start[new], running[last])


def _any_in_face(face_normal) -> np.ndarray:
    """A unit vector in the plane normal to ``face_normal``."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(face_normal[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    v = np.cross(face_normal, helper)
    return v / np.linalg.norm(v)


@dataclass(frozen=True)
class TraceLengths:
    """One set's joint traces: each stretch's ``length`` (m, the margins included) and
    whether it is ``censored`` (it may run on out of sight)."""

    length: np.ndarray
    censored: np.ndarray

    @classmethod
    def none(cls) -> "TraceLengths":
        return cls(np.zeros(0), np.zeros(0, dtype=bool))

    @classmethod
    def pooled(cls, parts: list) -> "TraceLengths":
        """The stretches of several sections' traces as one set's."""
        if len(parts) == 1:
            return parts[0]
        return cls(np.concatenate([p.length for p in parts]), np.concatenate([p.censored for p in parts]))

    @property
    def mean(self) -> float:
        """Mean trace length (m) with censoring: exponential lengths right-censored by the
        exposure have the maximum-likelihood mean sum of all lengths over those not
        censored (NaN when every stretch is censored)."""
        ended = int((~self.censored).sum())
        return float(self.length.sum() / ended) if ended else float("nan")

    @property
    def std_error(self) -> float:
        """Standard error (m) of :attr:`mean`: the exponential's, the mean over the square
        root of the stretches not censored (NaN when none is)."""
        ended = int((~self.censored).sum())
        return float(self.mean / np.sqrt(ended)) if ended else float("nan")

    @property
    def median(self) -> float:
        """The stretches' median length (m) as seen, censored ones short."""
        return float(np.median(self.length)) if len(self.length) else float("nan")

    @property
    def persistence(self) -> str:
        """ISRM (1978)'s class of :attr:`mean`; where every stretch is censored, of the mean
        length seen, as a lower bound ("high or more")."""
        if np.isfinite(self.mean) or not len(self.length):
            return persistence_class(self.mean)
        return persistence_class(float(self.length.mean()), at_least=True)


def trace_lengths(traces: Traces, joint_centre, face: Exposure) -> TraceLengths:
    """The lengths of the stretches of ``traces`` (:func:`joint_traces`), each censored when
    the face is not exposed (beyond its edge, or in a hole the cameras left) somewhere
    within :data:`TRACE_MARGIN` of either of its ends: the joint may run on there unseen.
    ``joint_centre`` (J, 3) is a point on each joint, as :func:`~geostructure.rockmass.joints.joint_planes`
    gives, in the coordinates of the face (:class:`~geostructure.rockmass.exposure.Exposure`).

    Examples
    --------
    A 4 x 2 m face in the plane z = 0 and two joint stretches along x, at y = 1: one from
    1 to 2 m, inside the face, and one from 3 to 5 m, running off its end.

    >>> from geostructure.rockmass.exposure import exposure
    >>> rng = np.random.default_rng(0)
    >>> xy = rng.random((40_000, 2)) * [4.0, 2.0]
    >>> face = exposure(np.column_stack([xy, np.zeros(len(xy))]), up=[0, 1, 0])
    >>> traces = Traces(np.array([[1.0, 0.0, 0.0]]), np.array([0, 0]), np.array([1.0, 3.0]), np.array([2.0, 5.0]))
    >>> found = trace_lengths(traces, np.array([[0.0, 1.0, 0.0]]), face)
    >>> found.length.tolist(), found.censored.tolist(), found.mean, found.std_error
    ([1.0, 2.0], [False, True], 3.0, 3.0)
    """
    joint = traces.joint
    if len(joint) == 0:
        return TraceLengths.none()
    d = traces.direction[joint]
    centre = np.asarray(joint_centre, dtype=np.float64)[joint]
    on_trace = centre - np.einsum("ij,ij->i", centre, d)[:, None] * d  # the trace's position 0
    censored = np.zeros(len(joint), dtype=bool)
    for end in (traces.start, traces.end):
        for shift in np.linspace(-TRACE_MARGIN, TRACE_MARGIN, 5):  # from the facets' reach to the margin's end
            censored |= ~face.exposed_at(face.project(on_trace + (end + shift)[:, None] * d))
    return TraceLengths(traces.end - traces.start, censored)


#: ISRM (1978)'s persistence classes: the longest trace length (m) of each.
PERSISTENCE_CLASSES = ((1.0, "very low"), (3.0, "low"), (10.0, "medium"), (20.0, "high"), (np.inf, "very high"))


def persistence_class(trace_length: float, *, at_least: bool = False) -> str:
    """ISRM (1978)'s description of a joint set's persistence from its trace length (m);
    ``at_least`` when that length is a lower bound (every trace runs out of sight), and an
    empty string for none.

    Examples
    --------
    >>> persistence_class(0.6), persistence_class(4.2), persistence_class(25.0), persistence_class(float("nan"))
    ('very low', 'medium', 'very high', '')
    >>> persistence_class(12.0, at_least=True)
    'high or more'
    """
    if np.isnan(trace_length):
        return ""
    name = next(name for bound, name in PERSISTENCE_CLASSES if trace_length < bound)
    return f"{name} or more" if at_least and name != PERSISTENCE_CLASSES[-1][1] else name
