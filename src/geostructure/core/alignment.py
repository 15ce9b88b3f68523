"""Least-squares alignment of point or vector sets: the one SVD solver (Kabsch, Umeyama)
that fitting a frame to ground truth and georeferencing by control points share."""

from __future__ import annotations

import numpy as np


def _procrustes(cross: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rotation R maximising trace(R^T cross), the reflection guard and the singular values."""
    u, d, vt = np.linalg.svd(cross)
    sign = np.eye(3)
    if np.linalg.det(u) * np.linalg.det(vt) < 0:  # the best orthogonal matrix is a reflection
        sign[2, 2] = -1
    return u @ sign @ vt, sign, d


def rotation_onto(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rotation R minimising sum |R a_i - b_i|^2 (rows are vectors, no translation; Kabsch).

    Examples
    --------
    >>> turn = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    >>> a = np.eye(3)
    >>> bool(np.allclose(rotation_onto(a, a @ turn.T), turn))
    True
    """
    a, b = np.asarray(a, float), np.asarray(b, float)
    return _procrustes(b.T @ a)[0]


def similarity(source: np.ndarray, target: np.ndarray, with_scale: bool = True):
    """Least-squares similarity (s, R, t) with target ~ s R source + t (Umeyama 1991).

    Examples
    --------
    >>> src = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    >>> s, r, t = similarity(src, 2 * src + [10.0, 0, 0])
    >>> round(s, 6), bool(np.allclose(r, np.eye(3))), t.round(6).tolist()
    (2.0, True, [10.0, 0.0, 0.0])
    """
    source, target = np.asarray(source, float), np.asarray(target, float)
    mu_s, mu_t = source.mean(axis=0), target.mean(axis=0)
    a, b = source - mu_s, target - mu_t
    rotation, sign, d = _procrustes(b.T @ a / len(source))
    variance = (a**2).sum() / len(source)
    scale = float(np.trace(np.diag(d) @ sign) / variance) if with_scale else 1.0
    return scale, rotation, mu_t - scale * rotation @ mu_s
