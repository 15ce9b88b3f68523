"""A run checked against a field map, as a geologist checks a digital outcrop against the
fractures mapped on it and the compass readings taken there.

The rule (the one ``../shared/data/dice_lastoni_sw/README.md`` states, and the project is
judged by):

- a mapped plane is **matched** when some measured plane has its centroid within
  ``max_distance`` of the mapped centre and its normal within ``max_angle`` degrees of the
  mapped normal (axially: n and -n are one plane);
- **precision**: the share of measured planes that match at least one mapped plane, so a
  spray of tiny planes scores low;
- **sets**: each mapped set's mean (or a published mean) against the nearest measured
  set's mean, in degrees.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from geostructure.core.orientation import normal_from_orientation

#: The rule's defaults: 0.6 m and 10 degrees.
MAX_DISTANCE = 0.6
MAX_ANGLE = 10.0


@dataclass(frozen=True)
class Validation:
    """Per mapped plane: ``matched`` (M,), the best matching measured ``plane`` (M,; -1 for
    none, else the nearest in angle among those close enough), its ``distance`` and
    ``angle`` (NaN for none); per measured plane ``useful`` (P,), whether it matches any."""

    matched: np.ndarray
    plane: np.ndarray
    distance: np.ndarray
    angle: np.ndarray
    useful: np.ndarray
    max_distance: float
    max_angle: float

    @property
    def n_matched(self) -> int:
        return int(self.matched.sum())

    @property
    def precision(self) -> float:
        return float(self.useful.mean()) if len(self.useful) else float("nan")


def axial_angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angle (degrees) between the unit normals ``a`` and ``b`` (row by row), n and -n alike."""
    cos = np.abs(np.einsum("...i,...i->...", a, b))
    return np.degrees(np.arccos(np.clip(cos, 0.0, 1.0)))


def validate(
    centroids, normals, map_centres, map_normals, *, max_distance: float = MAX_DISTANCE, max_angle: float = MAX_ANGLE
) -> Validation:
    """Score measured planes (``centroids`` (P, 3), unit ``normals`` (P, 3)) against mapped
    ones (``map_centres`` (M, 3), ``map_normals`` (M, 3)), all in one frame.

    Parameters
    ----------
    centroids, normals : (P, 3) arrays
        The measured planes' centroids and unit normals.
    map_centres, map_normals : (M, 3) arrays
        The mapped planes' centres and unit normals.
    max_distance : float
        The farthest a measured plane's centroid may lie from a mapped centre (the cloud's unit).
    max_angle : float
        The largest angle between their normals (degrees).

    Returns
    -------
    Validation
        Per mapped plane whether it is matched and by which plane, at what distance and
        angle; per measured plane whether it matches any (``precision``).

    Examples
    --------
    >>> up, east = np.array([[0.0, 0, 1]]), np.array([[1.0, 0, 0]])
    >>> v = validate(np.zeros((2, 3)), np.vstack([up, east]), np.array([[0.5, 0, 0], [3.0, 0, 0]]), np.vstack([up, up]))
    >>> v.matched.tolist(), v.useful.tolist(), v.n_matched, v.precision
    ([True, False], [True, False], 1, 0.5)
    """
    centroids = np.asarray(centroids, dtype=np.float64).reshape(-1, 3)
    normals = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    map_centres = np.asarray(map_centres, dtype=np.float64).reshape(-1, 3)
    map_normals = np.asarray(map_normals, dtype=np.float64).reshape(-1, 3)
    m = len(map_centres)
    plane, distance, angle = np.full(m, -1), np.full(m, np.nan), np.full(m, np.nan)
    useful = np.zeros(len(centroids), dtype=bool)
    if len(centroids) and m:
        near = cKDTree(centroids).query_ball_point(map_centres, max_distance)
        counts = np.fromiter(map(len, near), dtype=np.int64, count=m)
        row = np.repeat(np.arange(m), counts)
        col = np.fromiter((j for js in near for j in js), dtype=np.int64, count=int(counts.sum()))
        a = axial_angle(map_normals[row], normals[col])
        ok = a <= max_angle
        useful[col[ok]] = True
        row, col, a = row[ok], col[ok], a[ok]
        order = np.lexsort((a, row))  # per mapped plane, the closest in angle first
        first = order[np.r_[True, row[order][1:] != row[order][:-1]]] if len(order) else order
        plane[row[first]] = col[first]
        angle[row[first]] = a[first]
        distance[row[first]] = np.linalg.norm(map_centres[row[first]] - centroids[col[first]], axis=1)
    return Validation(plane >= 0, plane, distance, angle, useful, float(max_distance), float(max_angle))


def axial_mean(normals) -> np.ndarray:
    """The mean of unit normals taken as axes (n and -n alike): the principal eigenvector
    of their summed outer products, pointing up."""
    normals = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    mean = np.linalg.eigh(normals.T @ normals)[1][:, 2]
    return mean if mean[2] >= 0 else -mean


def set_errors(mapped: dict[str, np.ndarray], measured_means) -> dict[str, float]:
    """For each mapped set (label -> its mean unit normal), the angle (degrees) to the
    nearest measured set mean (``measured_means`` (S, 3)); NaN with no measured set.

    Examples
    --------
    >>> errors = set_errors({"1": np.array([0.0, 0, 1])}, np.array([[0.0, np.sin(0.1), np.cos(0.1)]]))
    >>> round(errors["1"], 3)
    5.73
    """
    means = np.asarray(measured_means, dtype=np.float64).reshape(-1, 3)
    if not len(means):
        return {label: float("nan") for label in mapped}
    return {label: float(axial_angle(means, normal).min()) for label, normal in mapped.items()}


def mapped_set_means(dip, dip_direction, labels) -> dict[str, np.ndarray]:
    """Each labelled set's axial mean normal (ENU), from its planes' dip and dip direction;
    unlabelled planes ("") belong to none."""
    normals = normal_from_orientation(np.asarray(dip_direction), np.asarray(dip))
    labels = np.asarray(labels, dtype=object)
    return {label: axial_mean(normals[labels == label]) for label in sorted(set(labels.tolist()) - {""})}
