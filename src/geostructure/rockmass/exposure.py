"""The exposure of an outcrop cloud and the persistence of the planes measured on it.

- **The exposure** (:func:`exposure`): the mean face is the least-squares plane of all the
  points; its occupancy, cells of a few point spacings projected on the face, gives the
  exposed area and its edge: the cloud's border and its holes (where the cameras saw
  nothing), but not gaps of :data:`SMALL_HOLE_CELLS` cells or fewer, which are sampling.
- **Persistence** per plane (:func:`plane_persistence`): the trace length along strike and
  along dip (the extent of the plane's points along those directions in its plane), the
  trace on the face (along the line where the plane meets the mean face), and ``censored``
  when the plane's points reach the exposure's edge, so that the joint may run on beyond
  what the cloud shows (ISRM 1978; Priest & Hudson 1981). A plane beside a hole is flagged
  whether it was hidden or did the hiding: from the surface alone the two look alike.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from geostructure.core.sampling import order_free_sample
from geostructure.core.threads import tree_query

#: Empty patches of the occupancy grid up to this many cells are gaps in the sampling, not
#: holes in the exposure.
SMALL_HOLE_CELLS = 2
#: Points per occupancy cell, on average.
CELL_POINTS = 8
#: A face whose ends (its first and last thirds along its strike, on the map) face this
#: many degrees apart or more is not one face but several, or a curve: a road cut that turns,
#: a quarry's corner. One mean face stands for none of its parts (:func:`face_bend`): such a face
#: is measured in sections (:mod:`.sections`).
BENT_FACE = 25.0
#: A face whose parts dip this many degrees more than its mean plane folds back on the map
#: (:func:`face_bend`): a bay, whose walls face each other.
FOLDED_FACE = 20.0


@dataclass(frozen=True)
class Exposure:
    """The mean face of a cloud and its occupancy.

    ``origin`` and ``normal`` give the least-squares plane; ``axes`` (2, 3) its strike and
    up-dip directions; ``cell`` (m) the occupancy grid's size, ``occupied`` the grid (True
    where points are), ``lower`` the grid's lower corner in face coordinates; ``area`` the
    occupied area (m^2); ``members`` the points that make the face (None: all of them);
    ``bend`` (degrees) how far its ends turn from one another (:func:`face_bend`).
    """

    origin: np.ndarray
    normal: np.ndarray
    axes: np.ndarray
    cell: float
    occupied: np.ndarray
    lower: np.ndarray
    area: float
    members: np.ndarray | None = None
    bend: float = 0.0

    def project(self, points) -> np.ndarray:
        """(N, 2) face coordinates of points."""
        return (np.asarray(points, dtype=np.float64) - self.origin) @ self.axes.T

    def edge(self) -> np.ndarray:
        """Cells at the exposure's edge: occupied cells with an empty neighbour (outside or hole)."""
        from scipy import ndimage  # 0.3 s to import: only with sets

        padded = np.pad(self.occupied, 1)
        inner = ndimage.binary_erosion(padded, structure=np.ones((3, 3), dtype=bool))[1:-1, 1:-1]
        return self.occupied & ~inner

    def exposed_at(self, uv) -> np.ndarray:
        """Whether the face is exposed at face coordinates ``uv`` (M, 2): False off the grid."""
        ij = np.floor((np.asarray(uv, dtype=np.float64) - self.lower) / self.cell).astype(np.int64)
        inside = ((ij >= 0) & (ij < self.occupied.shape)).all(axis=1)
        exposed = np.zeros(len(ij), dtype=bool)
        exposed[inside] = self.occupied[ij[inside, 0], ij[inside, 1]]
        return exposed

    def cell_of(self, points) -> tuple[np.ndarray, np.ndarray]:
        ij = np.floor((self.project(points) - self.lower) / self.cell).astype(np.int64)
        return np.clip(ij[:, 0], 0, self.occupied.shape[0] - 1), np.clip(ij[:, 1], 0, self.occupied.shape[1] - 1)


def exposure(points, up=(0.0, 0.0, 1.0), *, seed: int = 0, spacing: float | None = None, members=None) -> Exposure:
    """The mean face of ``points`` and its occupancy on a grid of cells of :data:`CELL_POINTS`
    points each on average; holes of :data:`SMALL_HOLE_CELLS` or fewer are filled.
    ``spacing``, the points' spacing as :func:`~geostructure.core.density.point_spacing` reads it, saves
    reading their density again (a kd-tree over all of them). ``members``
    (:func:`~geostructure.rockmass.face.face_parts`) leaves the ground and the clutter out of the face: taken for
    face, 3 m of road along the foot of a 6 m face fits it at 59.45 degrees for 75.44, and
    adds 12 m2 to its 73.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> xy = rng.random((40_000, 2)) * [4.0, 2.0]
    >>> face = exposure(np.column_stack([xy, np.zeros(len(xy))]), up=[0, 1, 0])
    >>> round(face.area), bool(face.edge().sum() < face.occupied.sum() / 5)  # a 4 x 2 m face
    (8, True)
    """
    points = np.asarray(points, dtype=np.float64)
    others = None
    if members is not None:
        points, others = points[members], points[~members]
    origin, normal, axes = face_plane(points, up, seed)
    # The cell holds CELL_POINTS points on average, from the density the 8th neighbours give
    # (pi r8^2 holds 8 points): few cells of a sampled surface are then empty by chance,
    # whether its points lie on a grid (SfM) or at random (a scan's overlap).
    if spacing is None:
        probe = points[order_free_sample(points, min(len(points), 2000), seed + 1)]
        tree = cKDTree(points, balanced_tree=False, compact_nodes=False)  # half the build time; queried once
        r8 = float(np.median(tree_query(tree, probe, 9)[0][:, 8]))
    else:  # the spacing is r8 sqrt(pi / 8): 8 points in pi r8^2
        r8 = float(spacing) / np.sqrt(np.pi / 8.0)
    cell = np.sqrt(CELL_POINTS * np.pi * max(r8, 1e-6) ** 2 / 8.0)
    uv = (points - origin) @ axes.T
    lower = uv.min(axis=0)
    ij = np.floor((uv - lower) / cell).astype(np.int64)
    occupied = np.zeros(tuple(ij.max(axis=0) + 1), dtype=bool)
    occupied[ij[:, 0], ij[:, 1]] = True
    if others is not None and len(others):
        # A cell where more of the points are the ground's or clutter's than the face's shows
        # no rock: a quarter of a bush's points are not told from the rock, and would
        # otherwise spread its outline over the exposure.
        shape = occupied.shape
        theirs = np.floor(((others - origin) @ axes.T - lower) / cell).astype(np.int64)
        inside = np.all((theirs >= 0) & (theirs < shape), axis=1)
        face_count = np.bincount(np.ravel_multi_index(ij.T, shape), minlength=occupied.size)
        other_count = np.bincount(np.ravel_multi_index(theirs[inside].T, shape), minlength=occupied.size)
        occupied &= (face_count >= other_count).reshape(shape)
    from scipy import ndimage  # 0.3 s to import: only with sets

    holes, n = ndimage.label(~occupied)
    sizes = np.bincount(holes.ravel(), minlength=n + 1)
    occupied |= (sizes[holes] <= SMALL_HOLE_CELLS) & (holes > 0)
    area = float(occupied.sum() * cell**2)
    return Exposure(origin, normal, axes, cell, occupied, lower, area, members, face_bend(points, up, seed))


def face_plane(points, up=(0.0, 0.0, 1.0), seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The least-squares face of ``points``: its centroid, its normal (on the side of ``up``)
    and its axes (2, 3), strike and up-dip, as :func:`exposure` takes them, without the
    occupancy grid (a fitted slope needs the plane alone).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> origin, normal, axes = face_plane(np.column_stack([rng.random((500, 2)), np.zeros(500)]), up=[0, 1, 0])
    >>> np.round(normal, 6).tolist(), np.round(axes, 6).tolist()
    ([0.0, 0.0, 1.0], [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    """
    up = np.asarray(up, dtype=np.float64)
    origin, vt = mean_face(points, seed)
    normal = vt[2] if vt[2] @ up >= 0 else -vt[2]
    strike = np.cross(up, normal)
    strike = strike / np.linalg.norm(strike) if np.linalg.norm(strike) > 1e-6 else vt[0]
    return origin, normal, np.array([strike, np.cross(normal, strike)])


def face_bend(points, up=(0.0, 0.0, 1.0), seed: int = 0) -> float:
    """How far a face turns along its strike (degrees): a road cut that bends, a quarry's
    corner. Seen from above, the face is a line (its trace on the map) that a bend turns:
    the angle between the directions of its first and last thirds along its length, each
    the slope of a straight-line fit of the points' map offsets across the face on their
    position along it.

    On the map, not on the face's least-squares plane, which a corner makes meaningless (two
    12 x 6 m faces at 90 degrees fit a plane dipping 8 degrees); and a line fitted along
    each third, not a plane: a rock face is stepped by its joints (the synthetic faces by
    about 0.3 m RMS), and a plane fitted to a few metres of steps tilts with them. On 29
    synthetic faces, flat but stepped (12 x 6 to 40 x 16 m), it read at most 15.4 degrees
    (on the smallest); on two 12 x 6 m faces side by side turned by 20, 30, 40 and 90
    degrees, 20, 31, 39 and 76. A terrain (lying within 30 degrees of level, its relief
    under a tenth of its breadth) has no such trace: 0. A face that folds back on the map,
    a bay of three walls, reads 180: its first and last thirds are its side walls, parallel
    on the map, and its parts dip far more than its mean plane (:data:`FOLDED_FACE`).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> u, v = rng.random((2, 40_000)) * [[24.0], [6.0]]
    >>> turn = np.radians(40.0) * (u > 12)  # a vertical cut, turned 40 degrees half way along
    >>> x = np.where(u > 12, 12 + (u - 12) * np.cos(turn), u)
    >>> y = np.where(u > 12, (u - 12) * np.sin(turn), 0.0)
    >>> round(face_bend(np.column_stack([x, y, v])))
    40
    """
    points = np.asarray(points, dtype=np.float64)
    if len(points) < 30:
        return 0.0
    sample = points[order_free_sample(points, min(len(points), 60_000), seed + 2)]
    sample = sample - sample.mean(axis=0)
    up = np.asarray(up, dtype=np.float64) / np.linalg.norm(up)
    spread, axes = np.linalg.svd(sample, full_matrices=False)[1:]
    if abs(axes[2] @ up) > np.cos(np.radians(30.0)) and spread[2] <= 0.1 * spread[0]:
        return 0.0  # a terrain (an airborne survey, a quarry floor): it has no trace on the map
    plan = sample @ plan_axes(up).T
    turn = trace_turn(plan)
    if turn < BENT_FACE and _folds_back(sample, plan, up):
        return 180.0  # a bay: its trace turns twice, and its side walls' thirds lie parallel
    return turn


def _folds_back(sample, plan, up) -> bool:
    """Whether a face folds back on the map (a quarry's bay: three walls, the trace turning
    twice): its parts, four blocks along its trace, dip :data:`FOLDED_FACE` degrees more
    than its mean plane, for the walls facing each other cancel in it (three walls dipping
    75 fit a plane dipping 0 to 15). On 30 flat, stepped synthetic faces the median block
    dipped at most 8.2 degrees more than the face; on four bays, 24 to 48."""
    along = plan @ np.linalg.svd(plan - plan.mean(axis=0), full_matrices=False)[2][0]
    edges = np.quantile(along, np.linspace(0.0, 1.0, 5))
    dips = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        block = sample[(along >= lo) & (along <= hi)]
        dips.append(_dip(np.linalg.svd(block - block.mean(axis=0), full_matrices=False)[2][2], up))
    return float(np.median(dips)) - _dip(np.linalg.svd(sample, full_matrices=False)[2][2], up) >= FOLDED_FACE


def _dip(normal, up) -> float:
    return float(np.degrees(np.arccos(min(1.0, abs(float(normal @ up))))))


def trace_turn(plan) -> float:
    """How far a face's trace on the map turns (degrees): the angle between the straight-line
    fits of its first and last thirds along its length (see :func:`face_bend`). ``plan``:
    (N, 2) map coordinates.

    Examples
    --------
    >>> t = np.linspace(0.0, 1.0, 300)
    >>> round(trace_turn(np.column_stack([np.cos(t), np.sin(t)])))  # an arc of 57 degrees
    38
    """
    plan = np.asarray(plan, dtype=np.float64)
    plan = plan - plan.mean(axis=0)
    length, across = np.linalg.svd(plan, full_matrices=False)[2]  # the trace's direction first
    along, offset = plan @ length, plan @ across
    first, last = np.quantile(along, [1.0 / 3.0, 2.0 / 3.0])
    turns = []
    for end in (along <= first, along >= last):
        t, h = along[end] - along[end].mean(), offset[end] - offset[end].mean()
        turns.append(np.degrees(np.arctan2(float(t @ h), float(t @ t))))
    return abs(turns[1] - turns[0])


def plan_axes(up) -> np.ndarray:
    """The map's two axes (2, 3), east and north, square to ``up`` (a unit vector): the
    frame a face's trace is read in (:func:`face_bend`, :mod:`.sections`).

    Examples
    --------
    >>> plan_axes(np.array([0.0, 0.0, 1.0])).tolist()
    [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
    """
    east = np.cross([1.0, 0.0, 0.0] if abs(up[1]) > 0.9 else [0.0, 1.0, 0.0], up)
    east /= np.linalg.norm(east)
    return np.array([east, np.cross(up, east)])


def mean_face(points, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Centroid and principal axes (rows, the normal last) of (a sample of) ``points``."""
    sample = points[order_free_sample(points, min(len(points), 50_000), seed)]
    origin = sample.mean(axis=0)
    return origin, np.linalg.svd(sample - origin, full_matrices=False)[2]


@dataclass
class Persistence:
    """Per plane: trace lengths (m) along strike, along dip and on the face, and ``censored``."""

    trace_strike: np.ndarray
    trace_dip: np.ndarray
    trace_face: np.ndarray
    censored: np.ndarray


def plane_persistence(points, labels, normals, face: Exposure, up=(0.0, 0.0, 1.0)) -> Persistence:
    """Each plane's extents along its strike, its dip and its trace on the face, and whether
    its points reach the exposure's edge (:class:`Persistence`).

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> xy = rng.random((40_000, 2)) * [4.0, 2.0]
    >>> points = np.column_stack([xy, np.zeros(len(xy))])
    >>> labels = np.where((xy[:, 0] > 1) & (xy[:, 0] < 2) & (xy[:, 1] < 0.5), 0, -1)
    >>> p = plane_persistence(points, labels, [[0.0, 0.0, 1.0]], exposure(points, up=[0, 1, 0]), up=[0, 1, 0])
    >>> np.round(p.trace_strike, 1).tolist(), p.censored.tolist()  # a 1 x 0.5 m patch on the edge
    ([1.0], [True])
    """
    points = np.asarray(points, dtype=np.float64)
    labels = np.asarray(labels)
    normals = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    n = len(normals)
    up = np.asarray(up, dtype=np.float64)
    strike = np.cross(up, normals)
    flat = np.linalg.norm(strike, axis=1) < 1e-6
    strike[flat] = face.axes[0]
    strike /= np.linalg.norm(strike, axis=1, keepdims=True)
    dip = np.cross(normals, strike)
    trace = np.cross(normals, face.normal)
    parallel = np.linalg.norm(trace, axis=1) < 1e-6
    trace[parallel] = face.axes[0]
    trace /= np.linalg.norm(trace, axis=1, keepdims=True)
    mine = labels >= 0
    lab, pts = labels[mine], points[mine]
    extents = []
    for direction in (strike, dip, trace):
        x = np.einsum("ij,ij->i", pts, direction[lab])
        hi, lo = np.full(n, -np.inf), np.full(n, np.inf)
        np.maximum.at(hi, lab, x)
        np.minimum.at(lo, lab, x)
        extents.append(np.where(hi >= lo, hi - lo, 0.0))
    i, j = face.cell_of(pts)
    censored = np.zeros(n, dtype=bool)
    censored[lab[face.edge()[i, j]]] = True
    along_strike, along_dip, on_face = extents
    return Persistence(along_strike, along_dip, on_face, censored)
