"""A set's joints: its facets grouped by the plane they lie on.

A facet joins a joint when it lies on the joint's plane, fitted to all the joint's points
at once (their moments pooled by the parallel-axis rule, :class:`PlaneMoments`), within a
tolerance that grows with its distance from the joint's nearest facet (:func:`joint_planes`).
Spacing (:mod:`.spacing`), traces (:mod:`.tracelengths`) and the sets' joint count (:mod:`.sets`)
all count these joints.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: A facet joins a joint when its centroid lies within this distance (m) of the joint's
#: plane, plus EXTRAPOLATION_ANGLE times its distance from the joint's nearest facet ...
SAME_JOINT_TOLERANCE = 0.02
#: ... degrees: the error of the joint plane's normal, extended; or the angle between the
#: facet's normal and the joint's when that is less, but at least MIN_EXTRAPOLATION_ANGLE:
#: a facet parallel to a joint and 12 cm off it, 6 m away, is another joint (the clean test
#: face), while facets of one waving joint with agreeing normals may lie a few cm apart.
EXTRAPOLATION_ANGLE = 1.0
MIN_EXTRAPOLATION_ANGLE = 0.75
#: ... and when its normal is within this angle (degrees) of the joint's: the normal of a
#: facet of 30 points can be a few degrees off.
SAME_JOINT_ANGLE = 8.0
#: A facet whose points lie on a joint's plane joins it when its normal is within this
#: angle (degrees) of the joint's, however far the angle of its own fit.
ON_PLANE_ANGLE = 20.0


@dataclass(frozen=True)
class PlaneMoments:
    """Each plane's point count, centroid (P, 3) and scatter about it (P, 3, 3); pooled by the
    parallel-axis rule, they give the plane through several facets' points at once."""

    count: np.ndarray
    centroid: np.ndarray
    scatter: np.ndarray

    @classmethod
    def of(cls, points, labels, n: int) -> "PlaneMoments":
        mine = labels >= 0
        lab, x = labels[mine], points[mine]
        count = np.bincount(lab, minlength=n).astype(np.float64)
        centroid = np.stack([np.bincount(lab, x[:, a], n) for a in range(3)], axis=1) / np.maximum(count, 1)[:, None]
        d = x - centroid[lab]  # about each plane's own centroid: no cancellation
        scatter = np.stack(
            [np.bincount(lab, d[:, a] * d[:, b], n) for a in range(3) for b in range(3)], axis=1
        ).reshape(n, 3, 3)
        return cls(count, centroid, scatter)

    def subset(self, index) -> "PlaneMoments":
        return PlaneMoments(self.count[index], self.centroid[index], self.scatter[index])


def joint_planes(
    moments: PlaneMoments,
    normals,
    *,
    angle: float | None = None,
    offset: float | None = None,
    enough: int | None = None,
):
    """Group the facets of one set into joints, largest facet first.

    Each facet, in order of decreasing size, joins the joint whose plane passes
    within ``offset`` plus tan(tilt) times its distance from the joint's nearest facet of
    its centroid, tilt being the angle between the joint's normal and the facet's, within
    :data:`MIN_EXTRAPOLATION_ANGLE` to :data:`EXTRAPOLATION_ANGLE`, and whose normal is
    within ``angle`` (degrees) of its own, the one whose normal agrees best when several
    do. Failing that, it joins a joint whose plane its points lie on (RMS distance at most
    ``offset``, normal within :data:`ON_PLANE_ANGLE`): a small facet's fit on rough rock
    can be ten degrees off. Otherwise it starts a joint. A joint's plane is fitted to all its facets' points
    at once (their moments pooled): several facets metres apart fix a plane far better than
    any one of them, whose normal may be a degree off. Grouping by growing joints rather than
    by linkage keeps two joints of a set apart where they cross. Returns each facet's joint
    and each joint's normal and centroid. With ``enough``, the grouping stops when that many
    joints are found (joints never merge, so a count that need only reach it is then
    known), its facets not yet grouped left at -1.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> patch = lambda x, y, z: np.column_stack([x + rng.random(200), y + rng.random(200), np.full(200, z)])
    >>> points = np.vstack([patch(0, 0, 0.0), patch(3, 0, 0.0), patch(1, 1, 0.6)])
    >>> labels = np.repeat([0, 1, 2], 200)
    >>> joint, normal, centre = joint_planes(PlaneMoments.of(points, labels, 3), [[0, 0, 1.0]] * 3)
    >>> joint.tolist(), np.round(centre[:, 2], 3).tolist()  # two patches of one joint, one 0.6 m above
    ([0, 0, 1], [0.0, 0.6])
    >>> joint_planes(PlaneMoments.of(points, labels, 3), [[0, 0, 1.0]] * 3, enough=1)[0].tolist()  # one is enough
    [0, 0, -1]
    """
    angle = SAME_JOINT_ANGLE if angle is None else angle
    offset = SAME_JOINT_TOLERANCE if offset is None else offset
    normals = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    centroids = moments.centroid
    joint = np.full(len(normals), -1, dtype=np.int64)
    members: list[list[int]] = []
    # Each joint's plane, a row per joint so far (``n`` at most): one facet's tests are a few
    # operations over these rows, and its angles are Python's on scalars (numpy's cost more).
    plane_normal, plane_point = np.empty((len(normals), 3)), np.empty((len(normals), 3))
    # And its members' moments pooled so far, about its first facet's centroid (``ref``, no
    # cancellation): weight, first and second moments, a facet's added as it joins (the
    # parallel-axis rule), where summing all the members again made joining cost their number.
    weight = np.empty(len(normals))
    first_moment, ref = np.empty((len(normals), 3)), np.empty((len(normals), 3))
    second_moment = np.empty((len(normals), 3, 3))
    count, scatter = moments.count, moments.scatter
    cos_angle, max_tilt = math.cos(math.radians(angle)), math.radians(EXTRAPOLATION_ANGLE)
    min_tilt = math.radians(MIN_EXTRAPOLATION_ANGLE)
    slope = math.tan(max_tilt)
    cos_on_plane = math.cos(math.radians(ON_PLANE_ANGLE))
    for i in np.argsort(-count, kind="stable"):
        best, n_joints = -1, len(members)
        if n_joints:
            jn, jp = plane_normal[:n_joints], plane_point[:n_joints]
            off_plane = np.abs(((centroids[i] - jp) * jn).sum(axis=1))
            agree = np.abs(jn @ normals[i])
            candidates = np.flatnonzero((agree >= cos_angle) & (off_plane <= offset + slope * 50.0))
            best_tilt = math.inf
            for k in candidates.tolist():
                gap = centroids[members[k]] - centroids[i]
                reach = math.sqrt(float((gap * gap).sum(axis=1).min()))
                # Extrapolating over ``reach`` allows for the tilt the two planes can be off
                # by, no more than they are: a facet parallel to a joint and 12 cm off it
                # is another joint however far away it lies.
                tilt = math.acos(min(float(agree[k]), 1.0))
                # Where two joints of a set cross, a facet near the line lies on both
                # planes: it belongs to the one its normal agrees with (the first on a tie).
                if off_plane[k] <= offset + math.tan(min(max(tilt, min_tilt), max_tilt)) * reach and tilt < best_tilt:
                    best, best_tilt = k, tilt
            if best < 0:
                # A small facet on rough rock can be ten degrees off its joint: when its
                # points lie on a joint's plane (their RMS distance from it within
                # ``offset``), it is on that joint whatever its own normal says.
                spread = ((jn @ scatter[i]) * jn).sum(axis=1) / max(count[i], 1e-12)
                rms = np.sqrt(off_plane**2 + spread)
                on = np.flatnonzero((agree >= cos_on_plane) & (rms <= offset))
                if len(on):
                    best = int(on[np.argmin(rms[on])])
        if best < 0:
            if n_joints == enough:
                break
            members.append([int(i)])
            plane_normal[n_joints], plane_point[n_joints] = normals[i], centroids[i]
            weight[n_joints], first_moment[n_joints] = count[i], 0.0
            second_moment[n_joints], ref[n_joints] = scatter[i], centroids[i]
            joint[i] = n_joints
            continue
        joint[i] = best
        members[best].append(int(i))
        # The plane through all the joint's points (:func:`_refit`).
        w = count[i]
        d = centroids[i] - ref[best]
        wd = w * d
        weight[best] += w
        first_moment[best] += wd
        second_moment[best] += scatter[i] + wd[:, None] * d
        _refit(best, weight, first_moment, second_moment, ref, plane_normal, plane_point)
    n = len(members)
    if enough is None and n > 1:
        pooled = (weight[:n], first_moment[:n], second_moment[:n], ref[:n], plane_normal[:n], plane_point[:n])
        owner = _absorb_lone_facets([len(m) == 1 for m in members], pooled, offset, cos_on_plane)
        survivors = np.flatnonzero(owner == np.arange(n))
        return np.searchsorted(survivors, owner[joint]), plane_normal[survivors].copy(), plane_point[survivors].copy()
    return joint, plane_normal[:n].copy(), plane_point[:n].copy()


def _absorb_lone_facets(lone, pooled, offset: float, cos_on_plane: float) -> np.ndarray:
    """Each joint's joint once the lone facets are absorbed: a joint of one facet whose
    points lie on a larger joint's final plane (RMS distance within ``offset``, normals
    within :data:`ON_PLANE_ANGLE`) joins it, as a facet found after that joint would have.
    Joints grow largest facet first, so a facet a few degrees off its joint that came first
    stays a joint of its own, and extended across the face it crosses the scanlines again
    (J2 on a 12 x 6 m cut with a road and a crest: 0.89 of the truth, 0.95 after).
    ``pooled`` (weight, first and second moments about ``ref``, ``ref``, normal and point,
    one row per joint) is updated in place."""
    weight, first, second, ref, normal, point = pooled
    n = len(weight)
    owner = np.arange(n)
    centre = ref + first / weight[:, None]
    for j in np.flatnonzero(lone)[np.argsort(weight[np.flatnonzero(lone)])]:
        spread = second[j] - np.outer(first[j], first[j]) / weight[j]  # about its centroid
        others = np.flatnonzero((owner == np.arange(n)) & (np.arange(n) != j) & (weight >= weight[j]))
        if not len(others):
            continue
        nk = normal[others]
        rms = np.sqrt(
            np.einsum("ki,ij,kj->k", nk, spread, nk) / weight[j] + ((centre[j] - point[others]) * nk).sum(1) ** 2
        )
        fits = (np.abs(nk @ normal[j]) >= cos_on_plane) & (rms <= offset)
        if not fits.any():
            continue
        k = int(others[fits][np.argmin(rms[fits])])
        d = ref[j] - ref[k]
        second[k] += second[j] + np.outer(first[j], d) + np.outer(d, first[j]) + weight[j] * np.outer(d, d)
        first[k] += first[j] + weight[j] * d
        weight[k] += weight[j]
        owner[owner == j] = k
        _refit(k, weight, first, second, ref, normal, point)
        centre[k] = point[k]
    return owner


def _refit(k: int, weight, first, second, ref, normal, point) -> None:
    """Joint ``k``'s plane from its pooled moments (about ``ref[k]``), in place: through its
    points' centroid, normal to their least spread, on the side of the normal it had. Their
    scatter about the centroid is the second moment less weight x shift shift^T."""
    shift = first[k] / weight[k]
    fitted = np.linalg.eigh(second[k] - shift[:, None] * first[k])[1][:, 0]
    normal[k] = fitted if fitted @ normal[k] >= 0 else -fitted
    point[k] = ref[k] + shift


def joint_counter(normals, centroids, area, enough: int):
    """A function of (labels, k): the number of distinct joints in each of ``k`` sets of
    planes (``labels``, -1 for none), counted up to ``enough`` (joints never merge, so a
    count that need only reach it can stop there). Each plane is a disc of its ``area`` at
    its centroid, so the sets' choice (:func:`~geostructure.rockmass.sets.find_sets`) needs no points.

    Examples
    --------
    >>> normals = np.tile([0.0, 0.0, 1.0], (4, 1))
    >>> centroids = np.array([[0, 0, 0.0], [3, 0, 0.0], [0, 0, 0.5], [0, 0, 1.0]])  # 3 joints
    >>> count = joint_counter(normals, centroids, np.ones(4), enough=3)
    >>> count(np.zeros(4, dtype=int), 1), count(np.array([0, 0, 1, 1]), 2)
    ([3], [1, 2])
    """
    x = np.asarray(normals, dtype=np.float64)
    area = np.asarray(area, dtype=np.float64)
    # Each facet as a disc of its area: count, centroid and in-plane scatter (r^2 / 4 per axis).
    count = np.maximum(area, 1e-9)
    scatter = (count * area / (4.0 * np.pi))[:, None, None] * (np.eye(3) - np.einsum("pi,pj->pij", x, x))
    moments = PlaneMoments(count, np.asarray(centroids, dtype=np.float64), scatter)

    def joints(labels, k):
        return [
            int(joint_planes(moments.subset(m), x[m], enough=enough)[0].max(initial=-1)) + 1
            for m in (np.flatnonzero(labels == j) for j in range(k))
        ]

    return joints
