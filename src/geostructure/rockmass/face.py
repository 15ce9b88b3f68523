"""What of an outcrop cloud is its rock face: the ground before it and the clutter on it left out.

A rock cut is scanned from its road, a quarry face from its bench, and bushes grow on ledges
and at the foot. Taken for face, they tilt the fitted face, add to the exposure and run the
scanlines across what is not rock; their planes join the joint sets and, extended across the
face as joints are, add crossings that are not there.

- **Ground** (:data:`GROUND_DIP`, :data:`GROUND_SHARE`, :data:`GROUND_BAND`): the level
  planes large enough to be a road or a bench, and the points near them, when the face
  without them is steep (:data:`STEEP_FACE`).
- **Clutter** (:data:`CLUTTER_CELL`, :data:`~geostructure.detect.cells.SURFACE_VARIATION`): points whose
  neighbourhood is a volume, not a surface (vegetation), and the planes most of whose points
  lie in such neighbourhoods (a bush's shell gives small planes of any orientation); and the
  points the input file classifies as vegetation (a LAS file's classes 3 to 5), with the
  planes most of whose points they are.

Neither is a discontinuity of the rock: their planes keep their orientation in ``planes.csv``
but join no set. The design, with the figures it was measured on, is in ``docs/rockmass.md``
("The ground before a face", "Vegetation before a face").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from geostructure.core.density import point_spacing
from geostructure.core.eigen import smallest_eigenpair
from geostructure.detect.cells import OFFSETS, SURFACE_VARIATION, CellGrid, block_fit
from geostructure.rockmass.exposure import mean_face

#: A plane dipping less than GROUND_DIP degrees that holds GROUND_SHARE of the points or
#: more is ground before or above the face (a road, a bench, a quarry's floor), not the face
#: ...
GROUND_DIP = 20.0
GROUND_SHARE = 0.1
#: ... when the face without it dips STEEP_FACE degrees or more.
STEEP_FACE = 45.0
#: The ground's points: those within this many of its plane's RMS residuals of it.
GROUND_BAND = 4.0
#: A level plane this share of the points or larger is tried as a piece of the ground, with
#: the level planes on it (:func:`_level_ground`).
GROUND_SEED_SHARE = 0.01
#: Clutter is judged on cells this many point spacings wide (some 16 points of a surface),
#: holding at least MIN_CLUTTER_CELL_POINTS points: on three bushes before a face, 3
#: spacings found 61% of their points and 2% of the rock's, 4 found 75% and 3%, 6 found 68%
#: and 4%.
CLUTTER_CELL = 4.0
MIN_CLUTTER_CELL_POINTS = 8
#: ... or, holding no plane's point, when this share of its neighbours or more are clutter.
CLUTTER_NEIGHBOURS = 0.3
#: A volume cell is clutter only where its points are a volume at their own scale too: each
#: point's nearest this many (a cell of a surface's points, 4 x 4), their surface variation.
CLUTTER_NEIGHBOURS_K = 16
#: Fewest points a face may keep once ground and clutter are left out.
MIN_FACE_POINTS = 100
#: Each point's part, as ``regions.laz``'s ``face_part`` dimension holds it.
FACE, GROUND, CLUTTER = 0, 1, 2


@dataclass(frozen=True)
class FaceParts:
    """Each point's part (``point_part``, (N,) uint8: :data:`FACE`, :data:`GROUND` or
    :data:`CLUTTER`; None: all face), and which planes are the ground's (``ground``, (P,))
    and the clutter's (``clutter``, (P,))."""

    point_part: np.ndarray | None
    ground: np.ndarray
    clutter: np.ndarray

    @property
    def members(self) -> np.ndarray | None:
        """Which points make the face (None: all of them)."""
        return None if self.point_part is None else self.point_part == FACE

    @property
    def off_face(self) -> np.ndarray:
        """The planes that are no discontinuity of the rock: ground or clutter."""
        return self.ground | self.clutter


def face_parts(
    points, labels, normals, up=(0.0, 0.0, 1.0), *, spacing: float | None = None, vegetation=None
) -> FaceParts:
    """The face of an outcrop cloud, its ground and its clutter (see the module's description).

    The ground: the level planes large enough (:data:`GROUND_DIP`, :data:`GROUND_SHARE`) and
    the points within :data:`GROUND_BAND` RMS residuals of such a plane (its ragged edges,
    which the plane did not take: on a 12 x 6 m face, 5,000 of them left the fitted face 6
    degrees off), when the face without them dips :data:`STEEP_FACE` degrees or more (a gentle
    slope's level planes are its face). A ground plane has more than half its points among
    them. The clutter: :func:`clutter_points`. Left with fewer than :data:`MIN_FACE_POINTS`
    points, the face is all of them.

    Parameters
    ----------
    points : (N, 3) array
    labels : (N,) int array
        Each point's plane (its row in ``normals``), -1 for none.
    normals : (P, 3) array
    up : (3,) array
    spacing : float, optional
        The points' spacing (:func:`~geostructure.core.density.point_spacing`), read when not given.
    vegetation : (N,) bool array, optional
        The points the input classifies as vegetation (``Cloud.vegetation``): clutter
        whatever their shape (a canopy seen from above is a surface).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> ground = np.column_stack([rng.random((300, 2)), 0.01 * rng.standard_normal(300)])
    >>> wall = np.column_stack([rng.random(100), np.zeros(100), 0.5 + rng.random(100)])
    >>> labels = np.r_[np.zeros(290, int), -np.ones(10, int), np.ones(100, int)]
    >>> parts = face_parts(np.vstack([ground, wall]), labels, [[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]])
    >>> int(parts.members[:300].sum()), int(parts.members[300:].sum()), parts.ground.tolist()
    (0, 100, [True, False])
    >>> np.bincount(parts.point_part).tolist()  # FACE, GROUND
    [100, 300]
    """
    points = np.asarray(points, dtype=np.float64)
    labels = np.asarray(labels)
    normals = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    up = np.asarray(up, dtype=np.float64)
    clutter, clutter_planes = _clutter(points, labels, len(normals), spacing)
    if vegetation is not None:
        vegetation = np.asarray(vegetation, dtype=bool)
        clutter = clutter | vegetation
        clutter_planes = clutter_planes | _most_in(labels, vegetation, len(normals))
    near = _level_ground(points, labels, normals, up)
    rest = ~clutter & ~near
    steep = rest.any() and abs(mean_face(points[rest])[1][2] @ up) <= np.cos(np.radians(STEEP_FACE))
    if not (near.any() and steep):
        near[:] = False
    on_face = np.count_nonzero(~clutter & ~near)
    if on_face == len(points) or on_face < MIN_FACE_POINTS:  # a cloud all clutter has no face to tell it from
        return FaceParts(None, np.zeros(len(normals), dtype=bool), np.zeros(len(normals), dtype=bool))
    part = np.full(len(points), FACE, dtype=np.uint8)
    part[near] = GROUND
    part[clutter] = CLUTTER
    return FaceParts(part, _most_in(labels, near, len(normals)) & ~clutter_planes, clutter_planes)


def _level_ground(points, labels, normals, up) -> np.ndarray:
    """The points within :data:`GROUND_BAND` RMS residuals of a level surface holding
    :data:`GROUND_SHARE` of the points or more: a level plane with the level planes most of
    whose points lie on it. A noisy road the facets cut into pieces is one surface: its
    pieces, none a tenth of the points alone, had made a set of their own (352 level planes
    on a 40 x 16 m face with 4 m of road and 3 m of ground behind its crest)."""
    level = np.abs(normals @ up) > np.cos(np.radians(GROUND_DIP))
    sizes = np.bincount(labels[labels >= 0], minlength=len(normals))
    near = np.zeros(len(points), dtype=bool)
    left = [int(g) for g in np.argsort(-sizes) if level[g] and sizes[g] > 0]
    while left and sizes[left[0]] >= GROUND_SEED_SHARE * len(labels):
        g = left[0]
        own = points[labels == g]
        centre = own.mean(axis=0)
        rms = np.sqrt(np.mean(((own - centre) @ normals[g]) ** 2))
        band = np.abs((points - centre) @ normals[g]) <= GROUND_BAND * rms
        on = set(np.flatnonzero(_most_in(labels, band, len(normals)) & level).tolist()) | {g}
        if sizes[list(on)].sum() >= GROUND_SHARE * len(labels):
            near |= band
        left = [j for j in left if j not in on]
    return near


def face_members(
    points, labels, normals, up=(0.0, 0.0, 1.0), *, spacing: float | None = None, vegetation=None
) -> np.ndarray | None:
    """The points that make an outcrop's face (:func:`face_parts`), None when all do.

    Examples
    --------
    >>> wall = np.column_stack([np.random.default_rng(0).random((400, 2)), np.zeros(400)])
    >>> face_members(wall, np.zeros(400, int), [[0.0, 0.0, 1.0]], up=[0, 1, 0]) is None
    True
    """
    return face_parts(points, labels, normals, up, spacing=spacing, vegetation=vegetation).members


def clutter_points(points, labels, spacing: float | None = None) -> np.ndarray:
    """The clutter of a cloud: points whose neighbourhood is a volume, not a surface
    (vegetation before a face). A neighbourhood is a cell :data:`CLUTTER_CELL` point spacings
    wide, a volume when its smallest eigenvalue is over :data:`~geostructure.detect.cells.SURFACE_VARIATION` of
    their sum, as the facet grid's scatter is read; a cell :data:`CLUTTER_NEIGHBOURS` of whose
    neighbours are such cells is clutter too (a bush's thinner patches read as surface at
    this scale). A point of no plane is clutter in a clutter cell (one that holds a plane's
    point, only if it is a volume itself); a plane's points are clutter when most of them
    lie in clutter cells (a bush's shell gives small planes of any orientation). On three bushes before a 12 x 6 m face, 92% of their points
    are clutter, and 3% of the rock's (where its facets meet).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> rock = np.column_stack([rng.random((4000, 2)) * 2, np.zeros(4000)])  # 2 x 2 m, 3 cm
    >>> bush = rng.normal(size=(4000, 3)) * 0.3 + [1.0, 1.0, 0.5]  # a fuzzy ball before it
    >>> labels = np.r_[np.zeros(4000, int), -np.ones(4000, int)]
    >>> found = clutter_points(np.vstack([rock, bush]), labels)
    >>> bool(found[:4000].any()), bool(found[4000:].mean() > 0.5)
    (False, True)
    """
    labels = np.asarray(labels)
    return _clutter(np.asarray(points, dtype=np.float64), labels, int(labels.max(initial=-1)) + 1, spacing)[0]


def _clutter(points, labels, n_planes: int, spacing) -> tuple[np.ndarray, np.ndarray]:
    """Clutter points (N,) and planes (P,), as :func:`clutter_points` describes them."""
    free = labels < 0
    none = np.zeros(len(points), dtype=bool), np.zeros(n_planes, dtype=bool)
    if len(points) < MIN_CLUTTER_CELL_POINTS:
        return none
    spacing = point_spacing(points) if spacing is None else float(spacing)
    if not spacing > 0:
        return none
    grid = CellGrid.of(points, CLUTTER_CELL * spacing)
    count = grid.moments[:-1, 0]
    values = block_fit(grid.moments[:-1])[0]  # each cell's own eigenvalues, ascending
    volume = (count >= MIN_CLUTTER_CELL_POINTS) & (values[:, 0] > SURFACE_VARIATION * values.sum(axis=1))
    # each cell's 26 neighbours (-1 where none), read once for both rules below
    around = np.stack([grid.find(grid.codes + step) for step in grid.steps()[np.any(OFFSETS != 0, axis=1)]])
    volume &= _volume_at_point_scale(points, grid.point_cell, around, volume)
    # A bush's thinner patches read as surface at this scale: a cell is clutter too when
    # enough of its neighbours are a volume.
    neighbours, volumes = np.zeros(len(count)), np.zeros(len(count))
    for found in around:
        there = found >= 0
        neighbours[there] += 1
        volumes[there] += volume[found[there]]
    among = volume | (volumes >= CLUTTER_NEIGHBOURS * np.maximum(neighbours, 1))
    clutter_planes = _most_in(labels, among[grid.point_cell], n_planes)
    # A point of no plane in a cell that holds a plane's point is clutter only if the cell
    # itself is a volume: where two of the rock's facets meet, such cells lie beside a clutter
    # cell or two, but the facets are rock.
    planed = np.bincount(grid.point_cell[~free], minlength=len(count)) > 0
    clutter_cells = volume | (among & ~planed)
    in_plane = np.zeros(len(points), dtype=bool)
    in_plane[~free] = clutter_planes[labels[~free]]
    return (free & clutter_cells[grid.point_cell]) | in_plane, clutter_planes


def _volume_at_point_scale(
    points: np.ndarray, point_cell: np.ndarray, around: np.ndarray, volume: np.ndarray
) -> np.ndarray:
    """Which of the cells (``volume``: those a volume at the cell's scale) are a volume at
    the points' scale too: the median of their points' surface variation over each one's
    :data:`CLUTTER_NEIGHBOURS_K` nearest (as many as a cell of a surface holds) is over
    :data:`~geostructure.detect.cells.SURFACE_VARIATION`. Rough rock is a surface bent
    within a cell (where facets meet, a corner); a bush is noise at every scale. On the
    Lastoni SW half (bare rock, drone SfM) the cells alone took 16% of the rock's points for
    clutter; their points' median variation is 0.048 there, 0.136 on the synthetic bushes."""
    out = np.zeros(len(volume), dtype=bool)
    members = np.flatnonzero(volume[point_cell])
    if not len(members):
        return out
    from scipy.spatial import cKDTree  # lazy: only where a cell is a volume

    # A point's 16 nearest lie within a cell of it (a cell is four spacings): the tree holds
    # the volume cells and the cells around them, not the whole cloud.
    reach = volume.copy()
    for found in around:  # each cell's neighbour in one direction (``around``: (26, C))
        reach[found[(found >= 0) & volume]] = True
    nearby = np.flatnonzero(reach[point_cell])
    k = min(CLUTTER_NEIGHBOURS_K, len(nearby))
    _, near = cKDTree(points[nearby]).query(points[members], k)
    neighbourhood = points[nearby[near.reshape(len(members), -1)]]
    neighbourhood = neighbourhood - neighbourhood.mean(axis=1, keepdims=True)
    values, _ = smallest_eigenpair(np.einsum("nki,nkj->nij", neighbourhood, neighbourhood))
    variation = values[:, 0] / np.maximum(values.sum(axis=1), 1e-300)
    cells = point_cell[members]
    order = np.lexsort((variation, cells))  # by cell, each cell's variations ascending
    cells, variation = cells[order], variation[order]
    starts = np.flatnonzero(np.r_[True, cells[1:] != cells[:-1]])
    size = np.diff(np.r_[starts, len(cells)])
    median = (variation[starts + (size - 1) // 2] + variation[starts + size // 2]) / 2
    out[cells[starts]] = median > SURFACE_VARIATION
    return out


def _most_in(labels, marked, n_planes: int) -> np.ndarray:
    """Which of ``n_planes`` planes have more than half their points ``marked``."""
    mine = labels >= 0
    total = np.bincount(labels[mine], minlength=n_planes)
    return np.bincount(labels[mine & marked], minlength=n_planes) > total / 2
