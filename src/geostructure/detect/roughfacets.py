"""Facets on rock rough at its own spacing: per-point planes grown where neighbours agree,
the face itself left out.

On a drone SfM cloud of real rock (``../shared/data/dice_lastoni_sw``, 3 cm) the grid's
local planes (:mod:`.facets`) scatter 8 degrees at every scale tried, so no grid facet is
trusted; the fractures a geologist maps show there as steps a few spacings across cut
into a rough, undulating face. DSE (Riquelme et al. 2014) measures such rock from each
point's own plane; this detector does too, without DSE's pole-density peaks (whose number
and place on that cloud moved with every neighbourhood size tried, and with them the
fractures found, 85 to 115 of 432):

1. **Each point's plane** from its :data:`NORMAL_NEIGHBOURS` nearest neighbours; a point
   whose neighbourhood is a volume (surface variation over the clutter test's
   :data:`~geostructure.detect.cells.SURFACE_VARIATION`) joins no facet.
2. **The face** (the exposure's envelope): each point's plane on a grid of cells
   :data:`ENVELOPE_SPACINGS` spacings wide, or an eighth of a small cloud's extent (the
   3 x 3 x 3 block about its cell). A
   point whose own plane lies within :data:`FACE_CONE` degrees of it is on the face, not on
   a discontinuity cut into it: those points join no facet here (the voxel growing
   measures them as the face's planes, which join no set).
3. **Growing**: two points within :data:`JOIN_RADIUS` spacings join when their planes agree
   within the cloud's own neighbour angle (the median angle between the planes of points
   that close, held to 5 to 15 degrees as the grid's threshold is); facets are the
   connected components, as in :mod:`.facets`; those of at least :data:`MIN_FACET_POINTS`
   points are kept when their own plane lies off the face, they are thin, and their
   points stray from it at most :data:`PLANAR_RESIDUALS` times as far as the points'
   neighbourhoods do from theirs.

The pipeline (:func:`~geostructure.detect.pipeline.measure`) then takes the facets' points out of the voxel
growing's regions, except out of its large surfaces.

The figures that chose each constant, on the real outcrop and the synthetic faces, are in
``docs/rockmass.md`` ("Real rock").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from geostructure.core.threads import tree_query
from geostructure.detect.cells import SURFACE_VARIATION, CellGrid, grid_planes, with_sparse_cells_filled

#: Neighbours of each point's plane: the fewest that fit a plane through the noise (on the
#: real outcrop 8 to 15 matched 107 to 143 of the 432 fractures, 20 and 30 fewer: the steps
#: are a few spacings wide, and a wider neighbourhood rounds them into the face).
NORMAL_NEIGHBOURS = 10
#: Neighbours searched for the pairs that may join (those within JOIN_RADIUS): a disc of
#: two spacings holds some 13 points of a surface.
SEARCH_NEIGHBOURS = 16
#: The face's planes: a grid of cells this many point spacings wide (the 3 x 3 x 3 block
#: about a point's cell, about a hundred spacings across, is the face there), or an eighth
#: of the cloud's largest extent where that is less. It was the eighth alone, 32 spacings on
#: the Lastoni SW half; measured inside a survey of 16 copies of itself that grid grew
#: fourfold and the half matched 101 of its 432 mapped fractures instead of 125. The eighth
#: still holds on a cloud under 256 spacings across (jfm_outcrop_test's 1,133 points over
#: 11 m, 45 spacings: at 32 spacings its face was one plane, and its own planes joined the
#: discontinuities).
ENVELOPE_SPACINGS = 32.0
ENVELOPE_DIVISIONS = 8
#: A point whose plane lies within this many degrees of the face's is on the face (DSE's
#: cone about a set's pole).
FACE_CONE = 30.0
#: Points this many spacings apart can join (DSE's DBSCAN radius, 2.5 nearest-neighbour
#: distances, which :func:`~geostructure.core.density.point_spacing` reads 1.25 times longer on SfM clouds).
JOIN_RADIUS = 2.0
#: The join angle's bounds (degrees), as :func:`~geostructure.detect.facets.facet_thresholds` holds its own.
JOIN_ANGLE_RANGE = (5.0, 15.0)
#: The fewest points of a facet (DSE's smallest cluster): a step some 3.5 spacings across.
MIN_FACET_POINTS = 10
#: A facet's points may stray from its plane (RMS) this many times as far as the points'
#: neighbourhoods do from theirs (median); farther, it has drifted round a curve while
#: growing. The roughest 1% of the Lastoni SW facets reach 5.5 times (a step grows rougher
#: with its size on rough rock: twice kept 110 of the 127 fractures matched); facets that
#: grew round the Sceaux Castle's mouldings reach 10 to 24 times.
PLANAR_RESIDUALS = 8.0
#: Points per batch of the per-point planes (bounds memory near 40 MB a batch).
BATCH = 100_000


@dataclass(frozen=True)
class RoughFacets:
    """``labels`` (N,) each point's facet (0, 1, ... by size, -1 for none); ``on_face`` (N,)
    the points whose plane lies along the face; ``envelope`` (N, 3) the face's normal at
    each point; the ``join_angle`` (degrees) the cloud gave."""

    labels: np.ndarray
    on_face: np.ndarray
    envelope: np.ndarray
    join_angle: float

    def record(self) -> dict:
        """What ``run.json`` says of it."""
        return {
            "rough_facets": int(self.labels.max(initial=-1)) + 1,
            "rough_join_angle_deg": self.join_angle,
            "face_points": int(self.on_face.sum()),
        }


def point_normals(
    points: np.ndarray, k: int = NORMAL_NEIGHBOURS, search: int = SEARCH_NEIGHBOURS
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Each point's unit normal (N, 3), of the least-squares plane through its ``k``
    nearest neighbours, with its surface variation lambda_0 / (lambda_0 + lambda_1 +
    lambda_2) (N,; Pauly et al. 2002) and the RMS distance of those neighbours to it (N,), and its ``search`` nearest neighbours (N, search; the
    first the point itself) with their distances (N, search).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> flat = np.c_[rng.random((500, 2)), 0.001 * rng.standard_normal(500)]
    >>> normal, variation, residual, _, _ = point_normals(flat)
    >>> bool(np.all(np.abs(normal[:, 2]) > 0.95))
    True
    """
    points = np.asarray(points, dtype=np.float64)
    k, search = min(k, len(points)), min(max(k, search), len(points))
    distances, neighbours = tree_query(cKDTree(points), points, search)
    distances, neighbours = distances.reshape(len(points), -1), neighbours.reshape(len(points), -1)  # k = 1: (N,)
    normal, variation, residual = np.empty((len(points), 3)), np.empty(len(points)), np.empty(len(points))
    for start in range(0, len(points), BATCH):
        rel = points[neighbours[start : start + BATCH, :k]] - points[start : start + BATCH, None, :]
        rel -= rel.mean(axis=1, keepdims=True)
        values, vectors = np.linalg.eigh(np.einsum("nki,nkj->nij", rel, rel))
        normal[start : start + BATCH] = vectors[:, :, 0]
        values = np.maximum(values, 0.0)
        variation[start : start + BATCH] = values[:, 0] / np.maximum(values.sum(axis=1), 1e-300)
        residual[start : start + BATCH] = np.sqrt(values[:, 0] / k)
    return normal, variation, residual, neighbours, distances


def envelope_normals(points: np.ndarray, spacing: float) -> np.ndarray:
    """The face's normal at each point (N, 3): the plane of the 3 x 3 x 3 block of cells
    about its cell, on a grid of :func:`envelope_edge`."""
    points = np.asarray(points, dtype=np.float64)
    extent = float(np.ptp(points, axis=0).max()) if len(points) else 0.0
    return envelope_table(CellGrid.of(points, envelope_edge(spacing, extent))).at(points)


def envelope_edge(spacing: float, extent: float) -> float:
    """The envelope grid's edge for a cloud of point ``spacing`` and largest ``extent``:
    :data:`ENVELOPE_SPACINGS` spacings, so that an outcrop measured inside a larger survey
    reads the same face as alone, or an eighth of a small cloud's extent."""
    return max(min(ENVELOPE_SPACINGS * float(spacing), float(extent) / ENVELOPE_DIVISIONS), 1e-12)


@dataclass(frozen=True)
class EnvelopeTable:
    """The face's planes on the envelope's grid (``edge`` from ``lower``, codes packed with
    ``dims``): each occupied cell's ``normal``, all in one sense (along their principal
    axis, each cell weighted by its points), so that they can be averaged."""

    edge: float
    lower: np.ndarray
    dims: np.ndarray
    codes: np.ndarray
    normal: np.ndarray

    def at(self, points: np.ndarray) -> np.ndarray:
        """The face's normal (N, 3) at each of ``points`` (each in a cell of the grid)."""
        key = np.floor((np.asarray(points, dtype=np.float64) - self.lower) / self.edge).astype(np.int64) + 1
        code = (key[:, 0] * self.dims[1] + key[:, 1]) * self.dims[2] + key[:, 2]
        return self.normal[np.minimum(np.searchsorted(self.codes, code), len(self.codes) - 1)]


def envelope_table(grid: CellGrid) -> EnvelopeTable:
    """:class:`EnvelopeTable` of the envelope's grid (its moments: the points' own, or a
    survey's summed chunk by chunk)."""
    cells = with_sparse_cells_filled(grid_planes(grid), grid)
    count = grid.moments[: len(grid), 0]
    axis = np.linalg.eigh((cells.normal * count[:, None]).T @ cells.normal)[1][:, 2]
    normal = cells.normal * np.where(cells.normal @ axis < 0, -1.0, 1.0)[:, None]
    return EnvelopeTable(grid.edge, grid.lower, grid.dims, grid.codes, normal)


def join_angle(normal: np.ndarray, neighbours: np.ndarray) -> float:
    """The median angle (degrees) between each point's plane and its ``neighbours``' (N, k,
    the first the point itself), held to :data:`JOIN_ANGLE_RANGE`: how much the cloud's own
    planes differ within one neighbourhood."""
    if neighbours.shape[1] < 2:
        return JOIN_ANGLE_RANGE[1]
    cos = np.abs(np.einsum("ij,ikj->ik", normal, normal[neighbours[:, 1:]]))
    angle = float(np.degrees(np.arccos(np.clip(np.median(cos), 0.0, 1.0))))
    return float(np.clip(angle, *JOIN_ANGLE_RANGE))


def mean_directions(labels: np.ndarray, vectors: np.ndarray, n: int) -> np.ndarray:
    """The unit mean (n, 3) of each label's ``vectors`` (N, 3; -1 labels none), all in one
    sense (as :func:`envelope_normals` gives them); zero for a label with no vector."""
    on = labels >= 0
    total = np.stack([np.bincount(labels[on], vectors[on, a], minlength=n) for a in range(3)], axis=1).astype(float)
    return total / np.maximum(np.linalg.norm(total, axis=1, keepdims=True), 1e-300)


def numbered_by_size(labels: np.ndarray, kept: np.ndarray, size: np.ndarray) -> np.ndarray:
    """``labels`` with the groups ``kept`` numbered 0, 1, ... from the largest (``size`` per
    group) and every other point -1, as the grid's facets are numbered."""
    kept = kept[np.argsort(-size[kept], kind="stable")]
    renumber = np.full(len(size) + 1, -1)  # the last entry: -1 stays -1
    renumber[kept] = np.arange(len(kept))
    return renumber[labels]


def component_planes(points, component, envelope, which) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The least-squares plane's normal of each component in ``which`` (W, 3), the mean face
    normal over its points (W, 3), whether it is thin (its surface variation at most
    :data:`~geostructure.detect.cells.SURFACE_VARIATION`) and its points' RMS distance to its plane (W,), from
    moments summed per component."""
    on = component >= 0
    index, rel = component[on], points[on] - points[on].mean(axis=0)
    n = len(component) + 1
    count = np.bincount(index, minlength=n)[which].astype(np.float64)
    mean = np.stack([np.bincount(index, rel[:, a], minlength=n)[which] for a in range(3)], axis=1) / count[:, None]
    cov = np.empty((len(which), 3, 3))
    for a in range(3):
        for b in range(a, 3):
            m = np.bincount(index, rel[:, a] * rel[:, b], minlength=n)[which] / count
            cov[:, a, b] = cov[:, b, a] = m - mean[:, a] * mean[:, b]
    values, vectors = np.linalg.eigh(cov) if len(which) else (np.zeros((0, 3)), np.zeros((0, 3, 3)))
    plane = vectors[:, :, 0]
    thin = values[:, 0] <= SURFACE_VARIATION * np.maximum(values.sum(axis=1), 1e-300)
    rms = np.sqrt(np.maximum(values[:, 0], 0.0))
    return plane, mean_directions(component, envelope, n)[which], thin, rms


def detect_rough_facets(points: np.ndarray, spacing: float) -> RoughFacets:
    """Facets of rock rough at the cloud's spacing (see the module's description).

    Parameters
    ----------
    points : (N, 3) array
        The cloud, local coordinates.
    spacing : float
        Its point spacing (:func:`~geostructure.core.density.point_spacing`).

    Examples
    --------
    A level face with two upright steps cut into it: the steps are facets, the face is not.

    >>> rng = np.random.default_rng(1)
    >>> ground = np.c_[rng.random((6000, 2)) * 4, 0.003 * rng.standard_normal(6000)]
    >>> step = lambda x: np.c_[np.full(300, x), rng.random(300), rng.random(300) * 0.3]
    >>> found = detect_rough_facets(np.vstack([ground, step(1.0), step(3.0)]), 0.05)
    >>> int(found.labels.max() + 1), bool(found.on_face[:6000].mean() > 0.9)
    (2, True)
    """
    points = np.asarray(points, dtype=np.float64)
    normal, variation, residual, neighbours, distances = point_normals(points)
    envelope = envelope_normals(points, spacing)
    on_face = np.abs(np.einsum("ij,ij->i", normal, envelope)) >= np.cos(np.radians(FACE_CONE))
    # A point whose neighbourhood is a volume (vegetation, noise) lies on no facet.
    off = on_face | (variation > SURFACE_VARIATION)
    # The pairs: each point with those of its plane's neighbours within the join radius
    # (a radius search of its own cost twice the time and memory on a million points).
    close = distances[:, 1:] <= JOIN_RADIUS * spacing
    pairs = np.column_stack([np.nonzero(close)[0], neighbours[:, 1:][close]])
    angle = join_angle(normal, neighbours[:, :NORMAL_NEIGHBOURS])
    pairs = pairs[~off[pairs[:, 0]] & ~off[pairs[:, 1]]]
    agree = np.abs(np.einsum("ij,ij->i", normal[pairs[:, 0]], normal[pairs[:, 1]])) >= np.cos(np.radians(angle))
    pairs = pairs[agree]
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(points),) * 2)
    _, component = connected_components(graph, directed=False)
    component[off] = -1
    size = np.bincount(component[component >= 0], minlength=int(component.max(initial=-1)) + 1)
    kept = np.flatnonzero(size >= MIN_FACET_POINTS)
    # A group whose own plane lies along the face is a rough patch of it, not a step; one
    # as thick as it is wide is no plane (points of a volume whose planes agree by chance).
    # One whose points stray from its plane more than the cloud's own neighbourhoods do
    # from theirs has drifted round a curve while growing (a noisy wall's corner).
    plane, face, thin, rms = component_planes(points, component, envelope, kept)
    kept = kept[steps_off_the_face(plane, face, thin, rms, float(np.median(residual)))]
    return RoughFacets(numbered_by_size(component, kept, size), on_face, envelope, angle)


def steps_off_the_face(plane, face, thin, rms, typical_residual: float) -> np.ndarray:
    """Which grown groups (their ``plane`` normal, mean ``face`` normal, whether ``thin``, and
    their points' ``rms`` off their plane) are steps cut into the face: their plane off the
    face's by :data:`FACE_CONE`, thin, and their points within :data:`PLANAR_RESIDUALS`
    times the ``typical_residual`` (the median of the points' neighbourhoods') of it."""
    flat = rms <= PLANAR_RESIDUALS * typical_residual
    return (np.abs(np.einsum("ij,ij->i", plane, face)) < np.cos(np.radians(FACE_CONE))) & thin & flat
