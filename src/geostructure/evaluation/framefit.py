"""Fix an unreferenced cloud's frame from ground-truth planes (best-fit rotation)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from geostructure.core.alignment import rotation_onto
from geostructure.core.orientation import Frame, angle_between_normals


@dataclass
class FrameFit:
    """A rotation taking truth normals (their frame) onto measured normals (cloud axes)."""

    rotation: np.ndarray
    matched: np.ndarray  # plane index per truth surface
    residuals: np.ndarray  # angle (deg) per surface after the rotation
    rotation_angle: float  # degrees between the fitted frame and the starting one

    @property
    def mean_residual(self) -> float:
        return float(self.residuals.mean())


def fit_frame_to_truth(normals, truth_normals, *, start=None, candidates: int = 30, iterations: int = 20) -> FrameFit:
    """Fix an unreferenced cloud's frame from ground-truth planes.

    Alternates a one-to-one assignment of truth normals to the ``candidates`` largest planes
    (by angle, sign-free) with a least-squares rotation (Kabsch) of the truth normals onto
    their planes' normals, starting from ``start`` (identity: the cloud is roughly in the
    truth's frame). The residuals say how well the planes agree once the frame is known.
    """
    from scipy.optimize import linear_sum_assignment  # 0.4 s to import: only when matching

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
        rotation = rotation_onto(truth, target)
        if np.array_equal(new, matched):
            break
        matched = new
    residuals = angle_between_normals(truth @ rotation.T, normals[matched])
    start_rot = np.eye(3) if start is None else np.asarray(start, dtype=np.float64)
    turn = rotation @ start_rot.T
    angle = float(np.degrees(np.arccos(np.clip((np.trace(turn) - 1) / 2, -1, 1))))
    return FrameFit(rotation, matched, residuals, angle)


def fitted_frame(frame, fit: FrameFit):
    """The frame in which the truth normals land on their planes: east, north, up turned by the fit."""
    matrix = frame.matrix @ fit.rotation.T  # each row (E, N, U in cloud axes) rotated
    return Frame(tuple(map(tuple, matrix.tolist())), frame.declination, f"{frame.name}, fitted to ground truth")


def pairwise_angle_error(normals, truth_normals) -> np.ndarray:
    """|angle between surfaces i and j as measured - as in the truth|, for every pair: needs no frame."""
    n = len(truth_normals)
    iu = np.triu_indices(n, 1)

    def pairs(v):
        return angle_between_normals(np.repeat(v, n, 0), np.tile(v, (n, 1))).reshape(n, n)[iu]

    return np.abs(pairs(np.asarray(normals)) - pairs(np.asarray(truth_normals)))
