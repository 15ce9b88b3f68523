"""Every discontinuity once: the run's joints as a table, each the facets of one plane.

The plane table lists facets, the pieces of a joint the face shows: on a rough outcrop one
joint breaks the face as several facets metres apart, and a geologist mapping by hand counts
it once. The rock mass groups each set's facets into joints (:func:`~geostructure.rockmass.joints.joint_planes`,
their plane fitted to all their points at once) to count spacing and traces; this module
keeps that grouping (:class:`Joints`) and writes it out (:func:`joint_rows`): ``joints.csv``,
a row per joint, and the plane table's ``joint`` column.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from geostructure.core.orientation import Frame, angle_between_normals, orientation_from_normals


@dataclass(frozen=True)
class Joints:
    """A run's joints (J of them) and its planes' (P): each plane's ``plane_joint`` (-1 for
    a plane in no set); each joint's ``set``, face ``section``, unit ``normal`` (J, 3; the
    plane through all its facets' points, in the cloud's axes), ``trace`` (m: the stretches of
    its trace on the face that its facets show, summed; NaN for a set along the face, whose
    planes show whole) and whether any stretch is ``censored`` (runs on out of sight)."""

    plane_joint: np.ndarray
    set: np.ndarray
    section: np.ndarray
    normal: np.ndarray
    trace: np.ndarray
    censored: np.ndarray

    def __len__(self) -> int:
        return len(self.set)

    @classmethod
    def of(cls, n_planes: int, groups: list) -> Joints:
        """From each set's and section's grouping, in order: tuples of (the set's plane
        indices ``members`` (M,), each one's ``joint`` there (M,), ``set``, ``section``, the
        joints' ``normal`` (G, 3), and the stretches' ``joint`` (T,) with their
        :class:`~geostructure.rockmass.tracelengths.TraceLengths`, or None for a set along the face).

        Examples
        --------
        >>> from geostructure.rockmass.tracelengths import TraceLengths
        >>> stretches = TraceLengths(np.array([1.5, 2.0, 0.5]), np.array([False, True, False]))
        >>> group = (np.array([0, 2, 3]), np.array([0, 1, 0]), 0, 0, np.eye(3)[:2], np.array([0, 0, 1]), stretches)
        >>> joints = Joints.of(5, [group])
        >>> joints.plane_joint.tolist(), joints.trace.tolist(), joints.censored.tolist()
        ([0, -1, 1, 0, -1], [3.5, 0.5], [True, False])
        """
        plane_joint = np.full(n_planes, -1, dtype=np.int64)
        sets: list = []
        sections: list = []
        normals: list[np.ndarray] = []
        traces: list = []
        censored: list = []
        for members, joint, set_id, section, normal, stretch_joint, lengths in groups:
            first = sum(len(n) for n in normals)
            grouped = joint >= 0
            plane_joint[members[grouped]] = first + joint[grouped]
            sets.append(np.full(len(normal), set_id, dtype=np.int64))
            sections.append(np.full(len(normal), section, dtype=np.int64))
            normals.append(np.asarray(normal, dtype=np.float64).reshape(-1, 3))
            trace, cut = np.full(len(normal), np.nan), np.zeros(len(normal), dtype=bool)
            if lengths is not None:
                trace[:] = 0.0
                np.add.at(trace, stretch_joint, lengths.length)
                np.logical_or.at(cut, stretch_joint, lengths.censored)
            traces.append(trace)
            censored.append(cut)

        def joined(parts, empty):
            return np.concatenate(parts) if parts else empty

        return cls(
            plane_joint,
            joined(sets, np.zeros(0, dtype=np.int64)),
            joined(sections, np.zeros(0, dtype=np.int64)),
            joined(normals, np.zeros((0, 3))),
            joined(traces, np.zeros(0)),
            joined(censored, np.zeros(0, dtype=bool)),
        )

    def counts(self, n_sets: int) -> np.ndarray:
        """Joints per set."""
        return np.bincount(self.set, minlength=n_sets)

    def members(self) -> list[np.ndarray]:
        """Each joint's planes (indices, ascending), in joint order.

        Examples
        --------
        >>> Joints(np.array([1, -1, 0, 1]), *[np.zeros(2)] * 5).members()
        [array([2]), array([0, 3])]
        """
        order = np.argsort(self.plane_joint, kind="stable")
        order = order[self.plane_joint[order] >= 0]
        return np.split(order, np.cumsum(np.bincount(self.plane_joint[order], minlength=len(self)))[:-1])


#: ``joints.csv``'s columns, in order.
JOINT_COLUMNS = (
    "joint", "set", "section", "n_planes", "n_points", "area_m2", "centroid_x", "centroid_y", "centroid_z",
    "normal_x", "normal_y", "normal_z", "strike", "dip", "dip_direction", "facet_scatter_deg", "trace_m",
    "trace_censored",
)  # fmt: skip


def joint_rows(planes, joints: Joints | None, frame: Frame = Frame(), metres_per_unit: float = 1.0) -> list[dict]:
    """One row per joint (:data:`JOINT_COLUMNS`) from the plane table (:class:`~geostructure.core.planes.Planes`,
    in the cloud's unit) and its :class:`Joints`: its facets' count, points and area (m²),
    their centroid (weighted by points, in the input's coordinates), the joint's normal
    (signed as its largest facet's, so that a vertical joint faces the same way) with its
    strike, dip and dip direction in ``frame``, the RMS angle of its facets' normals from it
    (degrees: how far the joint waves, with the facets' own errors), and its trace.

    Examples
    --------
    Two facets of one horizontal joint, 1 m and 3 m across, and a plane in no set:

    >>> from geostructure.core.planes import Planes
    >>> planes = Planes(normal=[[0, 0, 1.0], [0, 0.01, 1.0], [1.0, 0, 0]], local_centroid=[[0, 0, 0], [4, 0, 0], [9, 9, 9]],
    ...                 n_points=[100, 300, 50], area=[1.0, 3.0, 2.0])
    >>> joints = Joints(np.array([0, 0, -1]), np.array([0]), np.array([0]), np.array([[0, 0, 1.0]]),
    ...                 np.array([4.5]), np.array([False]))
    >>> row = joint_rows(planes, joints)[0]
    >>> row["n_planes"], row["area_m2"], row["centroid_x"], row["dip"], round(row["facet_scatter_deg"], 2)
    (2, 4.0, 3.0, 0.0, 0.41)
    """
    if joints is None or not len(joints):
        return []
    member = joints.plane_joint
    grouped = np.flatnonzero(member >= 0)
    j = member[grouped]
    n = len(joints)
    count = np.asarray(planes.n_points, dtype=np.float64)[grouped]
    points = np.bincount(j, count, n)
    centroid: np.ndarray = np.stack([np.bincount(j, count * planes.centroid[grouped, a], n) for a in range(3)], axis=1)
    centroid /= np.maximum(points, 1.0)[:, None]
    # Each joint's largest facet (most points): its normal signs the joint's.
    order = np.lexsort((-count, j))
    largest = np.full(n, -1)
    first = np.ones(len(order), dtype=bool)
    first[1:] = j[order][1:] != j[order][:-1]
    largest[j[order][first]] = grouped[order][first]
    normal = np.asarray(joints.normal, dtype=np.float64)
    facet = planes.normal[largest]
    normal = np.where((np.einsum("ij,ij->i", normal, facet) < 0)[:, None], -normal, normal)
    orientation = orientation_from_normals(normal, frame, outward=facet)
    scatter = np.sqrt(np.bincount(j, angle_between_normals(planes.normal[grouped], normal[j]) ** 2, n)
                      / np.maximum(np.bincount(j, minlength=n), 1))  # fmt: skip
    area = np.bincount(j, np.asarray(planes.area, dtype=np.float64)[grouped], n) * metres_per_unit**2
    columns = {
        "joint": np.arange(n),
        "set": joints.set,
        "section": joints.section,
        "n_planes": np.bincount(j, minlength=n),
        "n_points": points.astype(np.int64),
        "area_m2": area,
        **{f"centroid_{a}": centroid[:, k] for k, a in enumerate("xyz")},
        **{f"normal_{a}": normal[:, k] for k, a in enumerate("xyz")},
        "strike": orientation.strike,
        "dip": orientation.dip,
        "dip_direction": orientation.dip_direction,
        "facet_scatter_deg": scatter,
        "trace_m": joints.trace,
        "trace_censored": joints.censored.astype(np.int64),
    }
    return [dict(zip(JOINT_COLUMNS, values)) for values in zip(*(columns[c].tolist() for c in JOINT_COLUMNS))]
