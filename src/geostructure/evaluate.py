"""Compare found planes with ground truth: one-to-one matching and angle errors."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from .orientation import angle_between_normals, orientation_from_normals


@dataclass
class MatchRow:
    name: str
    region: int | None
    true_dip: float
    true_dip_direction: float
    dip: float = float("nan")
    dip_direction: float = float("nan")
    error: float = float("nan")


@dataclass
class Match:
    rows: list[MatchRow]

    @property
    def errors(self) -> np.ndarray:
        return np.array([r.error for r in self.rows if r.region is not None])

    @property
    def n_found(self) -> int:
        return sum(r.region is not None for r in self.rows)

    @property
    def all_found(self) -> bool:
        return self.n_found == len(self.rows)

    @property
    def mean_error(self) -> float:
        return float(self.errors.mean()) if len(self.errors) else float("nan")

    @property
    def max_error(self) -> float:
        return float(self.errors.max()) if len(self.errors) else float("nan")


def match_by_location(centroids, truth_centres, radii) -> np.ndarray:
    """For each truth surface, the index of the plane matched to it one-to-one, or -1.

    A plane can match a surface only if its centroid lies within that surface's ``radius``
    of the surface's centre; among those, the assignment minimises total distance.
    """
    centroids = np.asarray(centroids, dtype=np.float64).reshape(-1, 3)
    truth_centres = np.asarray(truth_centres, dtype=np.float64).reshape(-1, 3)
    out = np.full(len(truth_centres), -1, dtype=np.int64)
    if not len(centroids) or not len(truth_centres):
        return out
    dist = np.linalg.norm(truth_centres[:, None, :] - centroids[None, :, :], axis=2)
    allowed = dist <= np.asarray(radii, dtype=np.float64)[:, None]
    cost = np.where(allowed, dist, 1e12)
    rows, cols = linear_sum_assignment(cost)
    ok = allowed[rows, cols]
    out[rows[ok]] = cols[ok]
    return out


def match_scene(result, scene) -> Match:
    """Match a result to a synthetic scene's surfaces and measure each normal's error."""
    truth_normals = scene.normals
    truth = orientation_from_normals(truth_normals, result.frame)
    centres = np.array([s.center for s in scene.surfaces])
    radii = np.array([0.5 * np.hypot(s.width, s.height) for s in scene.surfaces])
    matched = match_by_location(result.centroids, centres, radii)
    rows = []
    for i, surface in enumerate(scene.surfaces):
        row = MatchRow(surface.name, None, float(truth.dip[i]), float(truth.dip_direction[i]))
        j = int(matched[i])
        if j >= 0:
            row.region = j
            row.dip = float(result.orientation.dip[j])
            row.dip_direction = float(result.orientation.dip_direction[j])
            row.error = float(angle_between_normals(result.normals[j], truth_normals[i])[0])
        rows.append(row)
    return Match(rows)


@dataclass
class FrameFit:
    """A rotation taking truth normals (their frame) onto measured normals (cloud axes)."""

    rotation: np.ndarray
    matched: np.ndarray      # plane index per truth surface
    residuals: np.ndarray    # angle (deg) per surface after the rotation
    rotation_angle: float    # degrees between the fitted frame and the starting one

    @property
    def mean_residual(self) -> float:
        return float(self.residuals.mean())


def kabsch(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rotation R minimising sum |R a_i - b_i|^2 (rows are vectors)."""
    h = a.T @ b
    u, _, vt = np.linalg.svd(h)
    d = np.sign(np.linalg.det(vt.T @ u.T))
    return vt.T @ np.diag([1.0, 1.0, d]) @ u.T


def fit_frame_to_truth(normals, truth_normals, *, start=None, candidates: int = 30, iterations: int = 20) -> FrameFit:
    """Fix an unreferenced cloud's frame from ground-truth planes.

    Alternates a one-to-one assignment of truth normals to the ``candidates`` largest planes
    (by angle, sign-free) with a least-squares rotation (Kabsch) of the truth normals onto
    their planes' normals, starting from ``start`` (identity: the cloud is roughly in the
    truth's frame). The residuals say how well the planes agree once the frame is known.
    """
    normals = np.asarray(normals, dtype=np.float64)[:candidates]
    truth = np.asarray(truth_normals, dtype=np.float64)
    truth = truth / np.linalg.norm(truth, axis=1, keepdims=True)
    rotation = np.eye(3) if start is None else np.asarray(start, dtype=np.float64)
    matched = np.full(len(truth), -1)
    for _ in range(iterations):
        rotated = truth @ rotation.T
        cost = np.degrees(np.arccos(np.clip(np.abs(rotated @ normals.T), 0, 1)))
        rows, cols = linear_sum_assignment(cost)
        new = np.full(len(truth), -1)
        new[rows] = cols
        target = normals[new] * np.sign(np.einsum("ij,ij->i", normals[new], rotated))[:, None]
        rotation = kabsch(truth, target)
        if np.array_equal(new, matched):
            break
        matched = new
    residuals = angle_between_normals(truth @ rotation.T, normals[matched])
    start_rot = np.eye(3) if start is None else np.asarray(start, dtype=np.float64)
    turn = rotation @ start_rot.T
    angle = float(np.degrees(np.arccos(np.clip((np.trace(turn) - 1) / 2, -1, 1))))
    return FrameFit(rotation, matched, residuals, angle)
