"""The observatory scene: the bundled default dataset, for the demo, tests and benchmarks.

:func:`observatory_scene` builds the paper's six measured surfaces (``ORIENTATION.md``,
normals converted from the paper's x=N, y=W frame to ENU) as textured rectangular faces,
with a ground plane, clutter (boulders and shrubs), photogrammetric noise (Gaussian along
the normal plus a few percent of heavy-tailed points) and floating outlier clusters.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from geostructure.core.cloud import Cloud
from geostructure.core.orientation import Frame, orientation_from_normals

#: The paper's ground-truth normals (x=North, y=West, z=Up), surfaces 1..6.
PAPER_NORMALS = np.array(
    [
        [-0.9985, -0.0523, 0.0175],
        [-0.0697, -0.9974, 0.0175],
        [0.3579, -0.9323, 0.0523],
        [-0.9970, 0.0348, 0.0698],
        [0.1736, -0.9847, 0.0175],
        [0.0112, -0.6427, 0.7660],
    ]
)

#: The paper's table of strike, dip and dip direction (surface 4 disagrees with its normal).
PAPER_TABLE = np.array([[87, 89, 177], [4, 89, 94], [339, 87, 69], [102, 86, 192], [350, 89, 80], [359, 40, 89]], float)


def paper_to_enu(vectors: np.ndarray) -> np.ndarray:
    """Vectors in the paper's frame (x=N, y=W, z=Up) written in ENU.

    Parameters
    ----------
    vectors : (N, 3) array_like
        In the paper's frame.

    Returns
    -------
    ndarray
        (N, 3), east-north-up.

    Examples
    --------
    >>> paper_to_enu(np.array([[1.0, 0.0, 0.0]])).round(6).tolist()  # north
    [[0.0, 1.0, 0.0]]
    """
    return Frame.named("paper").to_enu(vectors)


@dataclass
class Surface:
    """One ground-truth face: a rectangle with a centre, unit normal (ENU) and size (m).

    Parameters
    ----------
    name : str
        Its name (``surface 1``).
    center, normal : (3,) ndarray
        Its centre and unit normal, east-north-up.
    width, height : float
        Its size (m).

    Examples
    --------
    >>> paper_surfaces()[0].name, len(paper_surfaces())
    ('surface 1', 6)
    """

    name: str
    center: np.ndarray
    normal: np.ndarray
    width: float
    height: float


@dataclass
class Scene:
    """A synthetic cloud with its ground truth. ``truth_index`` marks each point's surface
    (0..5 the paper's six, -1 anything else); ``offset`` was added to every coordinate.

    Parameters
    ----------
    cloud : Cloud
        The points.
    surfaces : list of Surface
        The six faces.
    truth_index : ndarray
        Each point's face (-1: none).

    Examples
    --------
    >>> scene = observatory_scene(20_000, seed=1)
    >>> len(scene.surfaces), len(scene.truth_index) == len(scene.cloud)
    (6, True)"""

    cloud: Cloud
    surfaces: list[Surface]
    truth_index: np.ndarray

    @property
    def normals(self) -> np.ndarray:
        return np.array([s.normal for s in self.surfaces])

    def truth_table(self) -> dict:
        o = orientation_from_normals(self.normals)
        return {
            "surface": [s.name for s in self.surfaces],
            "strike": o.strike,
            "dip": o.dip,
            "dip_direction": o.dip_direction,
        }


# Centre (E, N, Up) and size (width, height) in metres of the six faces: a building about
# 40 x 30 m seen from around, walls standing on the ground, the roof above them.
_LAYOUT = [
    ((0.0, -12.0, 4.0), (16.0, 7.0)),  # 1: south wall
    ((16.0, 0.0, 4.0), (14.0, 7.0)),  # 2: east wall
    ((13.0, 11.0, 3.5), (8.0, 6.5)),  # 3: north-east buttress
    ((-8.0, 12.5, 3.5), (9.0, 6.5)),  # 4: north wing, facing south
    ((-17.0, 2.0, 3.5), (10.0, 6.5)),  # 5: west annex, facing east
    ((2.0, 1.0, 11.0), (14.0, 9.0)),  # 6: the 40-degree roof
]


def paper_surfaces() -> list[Surface]:
    """The paper's six surfaces: their centres and sizes as the scene lays them out, their
    normals the paper's (:data:`PAPER_NORMALS`), in east-north-up.

    Returns
    -------
    list of Surface

    Examples
    --------
    >>> all(abs(float(np.linalg.norm(s.normal)) - 1.0) < 1e-9 for s in paper_surfaces())
    True
    """
    normals = paper_to_enu(PAPER_NORMALS)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    return [
        Surface(f"surface {i + 1}", np.array(c), n, w, h) for i, ((c, (w, h)), n) in enumerate(zip(_LAYOUT, normals))
    ]


def sample_rectangle(surface: Surface, n: int, rng, noise: float) -> np.ndarray:
    """``n`` points on a rectangle, with Gaussian noise along its normal and a rough texture.

    Parameters
    ----------
    surface : Surface
        The rectangle.
    n : int
        How many points.
    rng : numpy.random.Generator
        The seeded generator drawing them.
    noise : float
        Standard deviation (m) along the normal.

    Returns
    -------
    ndarray
        (n, 3) points.

    Examples
    --------
    >>> surface = Surface("s", np.zeros(3), np.array([0.0, 0.0, 1.0]), 2.0, 1.0)
    >>> points = sample_rectangle(surface, 1000, np.random.default_rng(0), 0.0)
    >>> points.shape, bool(np.abs(points[:, 0]).max() <= 1.0)
    ((1000, 3), True)
    """
    normal = surface.normal
    helper = np.array([0.0, 0.0, 1.0]) if abs(normal[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    u = np.cross(helper, normal)
    u /= np.linalg.norm(u)
    v = np.cross(normal, u)
    a = (rng.random(n) - 0.5) * surface.width
    b = (rng.random(n) - 0.5) * surface.height
    texture = 0.3 * noise * np.sin(a * 3.1) * np.cos(b * 2.3)  # a gentle, real-looking roughness
    offset = rng.normal(0.0, noise, n) + texture
    return surface.center + a[:, None] * u + b[:, None] * v + offset[:, None] * normal


def observatory_scene(
    n_points: int = 300_000,
    *,
    seed: int = 0,
    noise: float = 0.02,
    outlier_fraction: float = 0.01,
    scale: float = 1.0,
    offset=(0.0, 0.0, 0.0),
) -> Scene:
    """The bundled default dataset: the paper's six surfaces in an outdoor scene.

    Parameters
    ----------
    n_points : int
        Points in all (about 60% on the six faces, 25% ground, the rest clutter and noise).
    seed : int
        The scene is a pure function of its arguments.
    noise : float
        Standard deviation (m, before ``scale``) of the points about their surfaces.
    outlier_fraction : float
        Share of points in floating clusters and scattered far outliers.
    scale : float
        Multiplies every coordinate (a model in other units, or an SfM model's arbitrary scale).
    offset : (3,) float
        Added to every coordinate (e.g. UTM-sized, to test precision).

    Returns
    -------
    Scene

    Examples
    --------
    >>> scene = observatory_scene(20_000, seed=1)
    >>> len(scene.cloud), sorted(set(scene.truth_index.tolist()))[:3]
    (20000, [-1, 0, 1])
    """
    rng = np.random.default_rng(seed)
    surfaces = paper_surfaces()
    areas = np.array([s.width * s.height for s in surfaces])
    n_faces = int(0.6 * n_points)
    per_face = np.floor(n_faces * areas / areas.sum()).astype(int)
    parts, index = [], []
    for i, (s, m) in enumerate(zip(surfaces, per_face)):
        parts.append(sample_rectangle(s, m, rng, noise))
        index.append(np.full(m, i))

    n_ground = int(0.25 * n_points)
    ground = Surface("ground", np.array([0.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0]), 56.0, 44.0)
    parts.append(sample_rectangle(ground, n_ground, rng, noise))
    index.append(np.full(n_ground, -1))

    n_outliers = int(outlier_fraction * n_points)
    n_clutter = max(n_points - sum(len(p) for p in parts) - n_outliers, 0)
    parts.append(_clutter(n_clutter, rng))
    index.append(np.full(n_clutter, -1))
    parts.append(_outliers(n_outliers, rng))
    index.append(np.full(n_outliers, -1))

    points = np.vstack(parts) * scale + np.asarray(offset, dtype=np.float64)
    for s in surfaces:
        s.center = s.center * scale + np.asarray(offset, dtype=np.float64)
        s.width, s.height = s.width * scale, s.height * scale
    order = rng.permutation(len(points))  # readers never see points grouped by surface
    return Scene(
        Cloud.from_points(points[order], source="synthetic observatory"), surfaces, np.concatenate(index)[order]
    )


def _clutter(n: int, rng) -> np.ndarray:
    """Boulders and shrubs: rough blobs standing on the ground away from the faces."""
    if n <= 0:
        return np.empty((0, 3))
    centres = np.array([[-24, -18, 0.8], [24, -16, 1.0], [-22, 16, 0.6], [22, 18, 1.2], [0, -19, 0.7], [-26, 0, 0.9]])
    which = rng.integers(0, len(centres), n)
    direction = rng.normal(size=(n, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    radius = centres[which, 2] * (1 + 0.25 * rng.standard_normal(n))
    pts = centres[which] + direction * radius[:, None]
    pts[:, 2] = np.abs(pts[:, 2])
    return pts


def _outliers(n: int, rng) -> np.ndarray:
    """Floating clusters (SfM mismatches near the faces) and scattered far outliers."""
    if n <= 0:
        return np.empty((0, 3))
    n_clusters = max(1, n // 40)
    centres = np.column_stack(
        [rng.uniform(-25, 25, n_clusters), rng.uniform(-18, 18, n_clusters), rng.uniform(2, 16, n_clusters)]
    )
    n_clustered = int(0.7 * n)
    pts = centres[rng.integers(0, n_clusters, n_clustered)] + rng.normal(0, 0.3, (n_clustered, 3))
    far = np.column_stack(
        [
            rng.uniform(-30, 30, n - n_clustered),
            rng.uniform(-25, 25, n - n_clustered),
            rng.uniform(-5, 25, n - n_clustered),
        ]
    )
    return np.vstack([pts, far])
