"""What a real outcrop cloud holds besides its rock, to add to an :func:`outcrop_scene`.

A rock cut is scanned from its road and has ground behind its crest; bushes grow on its
ledges. Each function here returns the points to add (absolute, as the scene's cloud), so
that a test or a benchmark measures the face as a survey sees it. The scene's ``offset`` is
the face's lower corner; ``face_axes`` its strike and up-dip directions.
"""

from __future__ import annotations

import numpy as np


def road_before(scene, depth: float, noise: float = 0.01, seed: int = 0) -> np.ndarray:
    """Level ground ``depth`` m deep along the foot of an outcrop scene's face, as wide as the
    face, at its point spacing on average (drawn at random) and ``noise`` m of white noise:
    the road a rock cut is scanned from, noisier than the rock.

    Parameters
    ----------
    scene : OutcropScene
        The scene (:func:`outcrop_scene`).
    depth : float
        How far (m) the road runs out from the face's foot.
    noise : float
        White noise (m) about the level.
    seed : int
        The road is a pure function of its arguments.

    Returns
    -------
    ndarray
        (M, 3) points, absolute.

    Examples
    --------
    >>> from geostructure.synthetic import outcrop_scene
    >>> scene = outcrop_scene(width=4.0, height=3.0, seed=1)
    >>> road = road_before(scene, depth=2.0)
    >>> len(road) == int(4.0 * 2.0 / scene.point_spacing**2), bool(abs(road[:, 2] - scene.offset[2]).max() < 0.1)
    (True, True)
    """
    strike, _ = scene.face_axes
    width, _ = scene.face_size
    out = _level(scene.face_normal)
    rng = np.random.default_rng(seed)
    n = int(width * depth / scene.point_spacing**2)
    ab = rng.random((n, 2)) * [width, depth]
    return scene.offset + ab[:, :1] * strike + ab[:, 1:] * out + noise * rng.standard_normal((n, 3))


def crest_above(scene, depth: float, noise: float = 0.01, seed: int = 0) -> np.ndarray:
    """Level ground ``depth`` m deep behind the crest of an outcrop scene's face (its top
    edge), as :func:`road_before` lays the road along its foot.

    Parameters
    ----------
    scene : OutcropScene
        The scene (:func:`outcrop_scene`).
    depth : float
        How far (m) the ground runs back from the crest.
    noise : float
        White noise (m) about the level.
    seed : int
        The ground is a pure function of its arguments.

    Returns
    -------
    ndarray
        (M, 3) points, absolute.

    Examples
    --------
    >>> from geostructure.synthetic import outcrop_scene
    >>> scene = outcrop_scene(width=4.0, height=3.0, seed=1)
    >>> top = crest_above(scene, depth=2.0)
    >>> round(float(top[:, 2].mean()), 1), round(3.0 * float(scene.face_axes[1][2]), 1)  # the face's top edge
    (2.9, 2.9)
    """
    strike, up_dip = scene.face_axes
    width, height = scene.face_size
    back = -_level(scene.face_normal)
    rng = np.random.default_rng(seed)
    n = int(width * depth / scene.point_spacing**2)
    ab = rng.random((n, 2)) * [width, depth]
    crest = scene.offset + height * up_dip
    return crest + ab[:, :1] * strike + ab[:, 1:] * back + noise * rng.standard_normal((n, 3))


def bushes_on(scene, n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """``n`` bushes on an outcrop scene's face: half-shells 0.5 to 1.5 m in radius standing
    out of it, at the face's point spacing, each blurred by 1.5 to 5 cm of noise (leaves
    that SfM matches badly): clutter that is a volume, not a surface. Their centres lie on
    the face's mean plane. Returns the bushes' points and which of the scene's points they
    hide (within a radius of a centre, seen along the face's normal), for the rock behind a
    bush is not seen: measure ``np.vstack([scene.cloud.points[~hidden], bushes])``.

    Parameters
    ----------
    scene : OutcropScene
        The scene (:func:`outcrop_scene`).
    n : int
        How many bushes.
    seed : int
        The bushes are a pure function of their arguments.

    Returns
    -------
    bushes : ndarray
        (M, 3) points, absolute.
    hidden : ndarray of bool
        Per point of the scene, whether a bush hides it.

    Examples
    --------
    >>> from geostructure.synthetic import outcrop_scene
    >>> scene = outcrop_scene(width=6.0, height=4.0, seed=1)
    >>> bushes, hidden = bushes_on(scene, 2)
    >>> bushes.shape[1], hidden.shape == (len(scene.cloud),), bool(0 < hidden.mean() < 0.5)
    (3, True, True)
    """
    strike, up_dip = scene.face_axes
    width, height = scene.face_size
    normal = scene.face_normal
    rng = np.random.default_rng(seed)
    shells, hidden = [], np.zeros(len(scene.cloud.points), dtype=bool)
    across = (scene.cloud.points - scene.offset) @ np.array([strike, up_dip]).T
    for _ in range(n):
        at = rng.uniform(0, 1, 2) * [width, height]
        radius = rng.uniform(0.5, 1.5)
        m = int(2 * np.pi * radius**2 / scene.point_spacing**2)
        d = rng.normal(size=(m, 3))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        behind = d @ normal < 0
        d[behind] -= 2 * np.outer(d[behind] @ normal, normal)  # the half before the face
        centre = scene.offset + at[0] * strike + at[1] * up_dip
        shells.append(centre + radius * d + rng.uniform(0.015, 0.05) * rng.standard_normal((m, 3)))
        hidden |= np.linalg.norm(across - at, axis=1) < radius
    return np.vstack(shells), hidden


def _level(normal) -> np.ndarray:
    """The horizontal unit direction of a face's outward normal."""
    out = np.array([normal[0], normal[1], 0.0])
    return out / np.linalg.norm(out)
