"""Compare found planes with ground truth: matching, the paper's quality score z, angle errors.

The paper's score, exactly as printed (``ORIENTATION.md``)::

    z(P)   = (|P_gt - P_m| - P_min) / (P_max - P_min)     P in strike, dip, dip direction
    z(R_i) = (z(strike) + z(dip) + z(dip direction)) / 3
    z(R)   = sqrt(sum_i z(R_i)^2) / n

with P_min = 0 and P_max = 360 for strike and dip direction, 90 for dip. As printed,
|P_gt - P_m| does not wrap at 360: strike 359 measured as 1 scores 358 degrees of error.
The wrap-aware variant takes the smaller way round (2 degrees) and is otherwise the same.
A surface that no plane matches scores z(R_i) = 1 (the worst), so missing a surface can
never improve a run's score; the count of missed surfaces is reported beside it.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from geostructure.core.orientation import angle_between_normals, azimuth_difference, orientation_from_normals
from geostructure.core.planes import Planes
from geostructure.io.truth import GroundTruth

RANGES = {"strike": 360.0, "dip": 90.0, "dip_direction": 360.0}


def distance_to_rectangles(point, planes: Planes) -> np.ndarray:
    """Distance from a point to each plane's bounding rectangle (0 inside a flat one)."""
    d = np.asarray(point, dtype=np.float64) - planes.rect_center
    a = np.abs(np.einsum("ij,ij->i", d, planes.rect_u)) - planes.rect_width / 2
    b = np.abs(np.einsum("ij,ij->i", d, planes.rect_v)) - planes.rect_height / 2
    c = np.einsum("ij,ij->i", d, planes.normal)
    return np.sqrt(np.maximum(a, 0) ** 2 + np.maximum(b, 0) ** 2 + c**2)


def match_by_location(centroids, truth_centres, radii) -> np.ndarray:
    """For each truth centre, the plane whose centroid is nearest within ``radii``, one-to-one."""
    centroids = np.asarray(centroids, dtype=np.float64).reshape(-1, 3)
    truth_centres = np.asarray(truth_centres, dtype=np.float64).reshape(-1, 3)
    dist = np.linalg.norm(truth_centres[:, None, :] - centroids[None, :, :], axis=2)
    return _assign(dist, np.asarray(radii, dtype=np.float64)[:, None])


def _assign(cost: np.ndarray, limit) -> np.ndarray:
    """One-to-one assignment minimising total cost among entries within ``limit``; -1 unmatched."""
    out = np.full(cost.shape[0], -1, dtype=np.int64)
    if cost.size == 0:
        return out
    allowed = cost <= limit
    from scipy.optimize import linear_sum_assignment  # 0.4 s to import: only when matching

    rows, cols = linear_sum_assignment(np.where(allowed, cost, 1e12))
    ok = allowed[rows, cols]
    out[rows[ok]] = cols[ok]
    return out


def match_planes(
    planes: Planes,
    truth: GroundTruth,
    *,
    max_distance: float = np.inf,
    max_angle: float = 30.0,
    candidates: int | None = None,
) -> np.ndarray:
    """Match each truth surface to one plane, or -1 (missed).

    With a centre: the plane whose rectangle contains or is nearest to it, within
    ``max_distance``. Without: by orientation, among the ``candidates`` largest planes
    (default three per surface, at least 10), within ``max_angle`` degrees.
    """
    matched = np.full(len(truth), -1, dtype=np.int64)
    if not len(planes):
        return matched
    located = truth.has_centres
    if located.any():
        dist = np.array([distance_to_rectangles(c, planes) for c in truth.centres[located]])
        matched[located] = _assign(dist, max_distance)
    free = ~located
    if free.any():
        taken = set(matched[matched >= 0].tolist())
        limit = candidates or max(10, 3 * len(truth))
        pool = np.array([j for j in np.argsort(-planes.n_points, kind="stable")[:limit] if j not in taken], dtype=int)
        if len(pool):
            angle = np.array(
                [
                    angle_between_normals(np.repeat(n[None], len(pool), 0), planes.normal[pool])
                    for n in truth.normals[free]
                ]
            )
            chosen = _assign(angle, max_angle)
            matched[free] = np.where(chosen >= 0, pool[np.maximum(chosen, 0)], -1)
    return matched


@dataclass
class SurfaceScore:
    surface: str
    region: int  # -1: missed
    true_strike: float
    true_dip: float
    true_dip_direction: float
    strike: float = float("nan")
    dip: float = float("nan")
    dip_direction: float = float("nan")
    z_strike: float = 1.0
    z_dip: float = 1.0
    z_dip_direction: float = 1.0
    z_region: float = 1.0  # the paper's z(R_i), as printed
    z_region_wrapped: float = 1.0
    normal_error_deg: float = float("nan")

    @property
    def found(self) -> bool:
        return self.region >= 0


@dataclass
class Evaluation:
    surfaces: list[SurfaceScore]

    @property
    def n_found(self) -> int:
        return sum(s.found for s in self.surfaces)

    @property
    def n_missed(self) -> int:
        return len(self.surfaces) - self.n_found

    @property
    def all_found(self) -> bool:
        return self.n_missed == 0

    @property
    def z(self) -> float:
        """The paper's z(R) as printed (missed surfaces count as z(R_i) = 1)."""
        return run_score([s.z_region for s in self.surfaces])

    @property
    def z_wrapped(self) -> float:
        return run_score([s.z_region_wrapped for s in self.surfaces])

    @property
    def errors(self) -> np.ndarray:
        return np.array([s.normal_error_deg for s in self.surfaces if s.found])

    @property
    def mean_error(self) -> float:
        return float(self.errors.mean()) if self.n_found else float("nan")

    @property
    def max_error(self) -> float:
        return float(self.errors.max()) if self.n_found else float("nan")

    def summary(self) -> dict:
        return {
            "z": self.z,
            "z_wrapped": self.z_wrapped,
            "mean_normal_error_deg": self.mean_error,
            "max_normal_error_deg": self.max_error,
            "found": self.n_found,
            "missed": self.n_missed,
            "surfaces": [asdict(s) for s in self.surfaces],
        }


def z_score(truth, measured, quantity: str, *, wrap: bool = False) -> np.ndarray:
    """The paper's z(P) for one quantity; ``wrap=True`` takes azimuths the short way round."""
    span = RANGES[quantity]
    if wrap and quantity != "dip":
        diff = azimuth_difference(truth, measured)
    else:
        diff = np.abs(np.asarray(truth, dtype=np.float64) - np.asarray(measured, dtype=np.float64))
    return diff / span


def run_score(region_scores) -> float:
    """The paper's z(R) = sqrt(sum z(R_i)^2) / n."""
    z = np.asarray(region_scores, dtype=np.float64)
    return float(np.sqrt(np.sum(z**2)) / len(z)) if len(z) else float("nan")


def evaluate(planes: Planes, truth: GroundTruth, *, matched=None, **match_options) -> Evaluation:
    """Match planes to the ground truth and score every surface (a missed one scores 1).

    Parameters
    ----------
    planes : Planes
        The measured planes.
    truth : GroundTruth
        The surfaces (:func:`~geostructure.io.truth.read_truth`), in the planes' frame.
    matched : (S,) int array, optional
        The plane matched to each surface (-1 for none); matched here when not given.
    **match_options
        For :func:`match_planes` (the largest angle and distance a match may have).

    Returns
    -------
    Evaluation
        Per surface its score: the plane matched, the angle between normals, the paper's
        z(R); ``n_found`` and ``n_missed``.

    Examples
    --------
    >>> from geostructure import measure
    >>> from geostructure.synthetic import observatory_scene
    >>> scene = observatory_scene(40_000, seed=1)
    >>> result = measure(scene.cloud)
    >>> evaluation = evaluate(result.planes, scene_truth(scene, result.frame))
    >>> evaluation.n_found, evaluation.n_missed
    (6, 0)
    """
    matched = match_planes(planes, truth, **match_options) if matched is None else np.asarray(matched)
    scores = []
    for i, name in enumerate(truth.names):
        s = SurfaceScore(
            name, int(matched[i]), float(truth.strike[i]), float(truth.dip[i]), float(truth.dip_direction[i])
        )
        j = int(matched[i])
        if j >= 0:
            s.strike, s.dip, s.dip_direction = (
                float(planes.strike[j]),
                float(planes.dip[j]),
                float(planes.dip_direction[j]),
            )
            parts = [float(z_score(getattr(s, f"true_{q}"), getattr(s, q), q)) for q in RANGES]
            wrapped = [float(z_score(getattr(s, f"true_{q}"), getattr(s, q), q, wrap=True)) for q in RANGES]
            s.z_strike, s.z_dip, s.z_dip_direction = parts
            s.z_region = sum(parts) / 3
            s.z_region_wrapped = sum(wrapped) / 3
            s.normal_error_deg = float(angle_between_normals(truth.normals[i], planes.normal[j])[0])
        scores.append(s)
    return Evaluation(scores)


def scene_truth(scene, frame) -> GroundTruth:
    """A synthetic scene's six surfaces as ground truth with centres (for the demo and tests)."""
    o = orientation_from_normals(scene.normals, frame)
    return GroundTruth(
        [s.name for s in scene.surfaces],
        o.dip,
        o.dip_direction,
        np.array([s.normal for s in scene.surfaces]),
        np.array([s.center for s in scene.surfaces]),
    )


def match_scene(result, scene) -> Evaluation:
    """Evaluate a result against its synthetic scene, matching by location."""
    return evaluate(result.planes, scene_truth(scene, result.frame), max_distance=0.5 * result.voxels.edge * 10)


@dataclass
class FacetMatch:
    """How many of an outcrop's facets a run found (see :func:`match_facets`)."""

    found: np.ndarray  # (F,) bool, per truth facet
    plane_facet: np.ndarray  # (P,) the facet each plane's centroid lies on, -1 for none
    eligible: np.ndarray  # (F,) bool: large enough to count
    errors: np.ndarray  # (F,) normal error (deg) of the best plane on the facet, NaN for none

    @property
    def recall(self) -> float:
        """Share of the eligible facets found."""
        return float(self.found[self.eligible].mean()) if self.eligible.any() else float("nan")


def match_facets(planes: Planes, scene, *, max_angle: float = 5.0, min_diameter: float = 0.3) -> FacetMatch:
    """Which facets of a synthetic outcrop (:func:`~geostructure.synthetic.outcrop_scene`)
    the planes found: a facet is found when a plane's centroid lies on it (its nearest
    noise-free point belongs to the facet, within a few point spacings) and the plane's
    normal is within ``max_angle`` degrees of the facet's. Facets under ``min_diameter``
    metres across do not count."""
    from scipy.spatial import cKDTree

    n_facets = len(scene.facet_set)
    on_facet = scene.facet_index >= 0
    distance, nearest = cKDTree(scene.clean[on_facet]).query(planes.centroid) if len(planes) else ([], [])
    plane_facet = np.full(len(planes), -1, dtype=np.int64)
    if len(planes):
        close = np.asarray(distance) <= 3.0 * scene.point_spacing + 3.0 * np.asarray(planes.fit_residual)
        plane_facet[close] = scene.facet_index[on_facet][np.asarray(nearest)[close]]
    errors = np.full(n_facets, np.nan)
    hit = plane_facet >= 0
    if hit.any():
        angle = angle_between_normals(planes.normal[hit], scene.facet_normal[plane_facet[hit]])
        best = np.full(n_facets, np.inf)
        np.minimum.at(best, plane_facet[hit], angle)
        errors = np.where(np.isfinite(best), best, np.nan)
    found = np.nan_to_num(errors, nan=np.inf) <= max_angle
    return FacetMatch(found, plane_facet, scene.facet_diameter >= min_diameter, errors)
