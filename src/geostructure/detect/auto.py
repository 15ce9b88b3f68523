"""Choose zeta, theta and psi from the cloud alone (no ground truth).

1. **zeta from density and noise.** A voxel needs enough points for a stable plane, and
   no more than that, or it straddles edges. The density zeta is the smallest value whose
   typical voxel (the voxel of the median point) holds ``TARGET_POINTS`` points; occupancy
   is counted on a subsample and scaled up. A voxel must also be large against the noise,
   or its normal is mostly noise: the median voxel-plane residual sigma, measured at the
   density zeta, must be at most ``MAX_NOISE_RATIO`` of the edge, so zeta is raised to
   sigma / (MAX_NOISE_RATIO x extent) where needed. Above twice ``NOISE_SAMPLE_POINTS``
   points, sigma is read on a sample of whole voxels drawn by the hash of their keys
   (:func:`noise_sample`): each drawn voxel is the whole cloud's voxel, so their median
   residual is a sample of the same values, and the cloud is fitted whole only once, at
   the zeta chosen.
2. **Noise from local plane fits.** At that zeta, each planar voxel's neighbours (its 6
   nearest voxel planes) give two noise measures. One is the angle between their normals:
   on a surface it is noise and roughness, at an edge it is the edge. The other is the
   offset of a neighbour's centroid from the voxel's plane, in voxel edges. Their medians
   describe the surfaces, because edges are a minority of voxel pairs.
3. **theta** is 1.5 x the median neighbour angle, clipped to the paper's optimum 3 to 8
   degrees; **psi** is 3 x the median offset, clipped to 0.02 to 0.6 voxel edges. Above
   the noise, neighbours on one surface join; at a real edge the angle is far larger than
   the noise, so regions stop there. The synthetic scenes accept any theta from 3 to 30;
   the paper's own cloud does not: with theta 18 (3 x its noise) its frame-fitted residual
   was 7.8 degrees, with 6 to 9 it is about 4, so theta is held to the paper's range.
4. **k** stays at 8: the paper's optimum is 3 to 11, and the sweeps here show a plateau
   from 3 upward.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.spatial import cKDTree

from geostructure.core.bounds import column_max, column_min
from geostructure.core.params import ParameterWarning, Params
from geostructure.core.sampling import order_free_sample, sampled_blocks
from geostructure.core.threads import tree_query
from geostructure.detect.voxel import (
    CloudMoments,
    accumulate_moments,
    fit_voxels,
    voxel_counts,
    voxel_planes_from_moments,
)

#: Points wanted in the typical voxel.
TARGET_POINTS = 30
#: Points of the order-free subsample the occupancy is counted on.
SAMPLE_POINTS = 400_000
#: Largest noise (median voxel-plane residual) as a fraction of the voxel edge.
MAX_NOISE_RATIO = 0.05
ZETA_RANGE = (0.004, 0.1)
#: The least zeta chosen, for a survey so large and dense that ZETA_RANGE's least voxel
#: holds far more than TARGET_POINTS (a road cut a kilometre long): a thousand voxels along
#: the longest extent, which keeps the voxel tables of any survey to about a million (a
#: finer voxel is the user's to give, with --zeta).
ZETA_FLOOR = 1e-3
#: Above twice this many points, the noise sigma is read on whole voxels drawn by hash that
#: hold about this many points (:func:`noise_sample`): at 8M points, a fit of the whole
#: cloud at a zeta that the noise then made coarser took 2.3 s, the drawn voxels 0.7 s.
NOISE_SAMPLE_POINTS = 1_000_000
THETA_RANGE = (3.0, 8.0)  # the paper's optimum; wider merged too much on its own cloud
PSI_RANGE = (0.02, 0.6)


@dataclass
class AutoChoice:
    """The chosen parameters and the measurements behind them."""

    params: Params
    points_per_voxel: float
    normal_noise_deg: float
    offset_noise: float  # voxel edges
    #: the whole cloud's voxel moments at the chosen zeta (in memory; None when streamed)
    moments: CloudMoments | None = field(default=None, repr=False, compare=False)

    def to_dict(self, overridden=()) -> dict:
        """The choice as ``run.json`` records it; ``overridden`` names factors the user gave.

        Examples
        --------
        >>> AutoChoice(Params(), 32.0, 3.5, 0.03).to_dict(["k"])["overridden_by_user"]
        ['k']
        """
        p = self.params
        return {
            "zeta": p.zeta,
            "theta": p.theta,
            "psi": p.psi,
            "k": p.k,
            "points_per_voxel": self.points_per_voxel,
            "normal_noise_deg": self.normal_noise_deg,
            "offset_noise_voxel_edges": self.offset_noise,
            "overridden_by_user": sorted(overridden),
        }

    def describe(self) -> str:
        p = self.params
        per_voxel = f"{self.points_per_voxel:.0f} point" + ("" if round(self.points_per_voxel) == 1 else "s")
        return (
            f"auto: zeta {p.zeta:.4g} ({per_voxel} in the typical voxel), "
            f"theta {p.theta:.3g} deg (normal noise {self.normal_noise_deg:.2f} deg), "
            f"psi {p.psi:.3g} voxel edges (offset noise {self.offset_noise:.3f}), k {p.k}"
        )


def typical_occupancy(points: np.ndarray, zeta: float, *, sample: int = 400_000, seed: int = 0) -> float:
    """Points in the voxel of the median point, estimated on a subsample."""
    return Occupancy(points, sample, seed).at(zeta)


class Occupancy:
    """:func:`typical_occupancy` at many zetas: the subsample drawn, and the cloud's corner
    and extent read, once (at 8M points each of those took a third of a second, and a
    choice of zeta may try forty). :meth:`of_sample` builds one from a sample drawn
    elsewhere (a streamed cloud's, chunk by chunk)."""

    def __init__(self, points: np.ndarray, sample: int, seed: int):
        self.fraction = min(1.0, sample / len(points))
        self.sub = points if self.fraction == 1.0 else points[order_free_sample(points, int(sample), seed)]
        self.lower = column_min(points)
        self.extent = float(np.max(column_max(points) - self.lower))

    @classmethod
    def of_sample(cls, sub: np.ndarray, n_points: int, lower, extent: float) -> "Occupancy":
        probe = cls.__new__(cls)
        probe.sub, probe.fraction = sub, min(1.0, len(sub) / n_points)
        probe.lower, probe.extent = np.asarray(lower, dtype=np.float64), float(extent)
        return probe

    def at(self, zeta: float) -> float:
        count, inverse = voxel_counts(self.sub, zeta * self.extent, self.lower)
        return float(np.median(count[inverse])) / self.fraction


def choose_zeta(
    points: np.ndarray | None, target: float = TARGET_POINTS, probe: Occupancy | None = None
) -> tuple[float, float]:
    """Smallest zeta on a geometric grid whose typical voxel holds ``target`` points.

    Where even the grid's smallest zeta holds more (a dense survey hundreds of metres
    across), zeta is taken down from it as the points on a surface scale, with the square of
    the edge, to at most :data:`ZETA_FLOOR`: the subsample is too sparse to count smaller
    voxels directly."""
    grid = np.geomspace(*ZETA_RANGE, 40)
    if probe is None:
        if points is None:
            raise ValueError("choose_zeta needs the points or their probe")
        probe = Occupancy(points, SAMPLE_POINTS, 0)
    occupancy = 0.0
    for zeta in grid:
        occupancy = probe.at(zeta)
        if occupancy >= target:
            if zeta == grid[0] and occupancy > target:
                finer = max(ZETA_FLOOR, float(zeta) * float(np.sqrt(target / occupancy)))
                return finer, occupancy * (finer / float(zeta)) ** 2
            return float(zeta), occupancy
    return float(grid[-1]), occupancy


def surface_noise(points: np.ndarray | None, zeta: float, neighbours: int = 6, voxels=None) -> tuple[float, float]:
    """Median angle (deg) between neighbouring voxel normals and median neighbour offset (voxel
    edges); ``voxels`` (fitted at ``zeta`` with any planarity) saves fitting them again."""
    if voxels is None:
        if points is None:
            raise ValueError("surface_noise needs the points or their voxels")
        voxels = fit_voxels(points, zeta, max_curvature=1 / 3)
    if len(voxels) < neighbours + 1:
        return 5.0, 0.1
    _, idx = tree_query(cKDTree(voxels.centroid), voxels.centroid, neighbours + 1)
    idx = idx[:, 1:]
    cos = np.abs(np.einsum("ij,ikj->ik", voxels.normal, voxels.normal[idx]))
    angle = np.degrees(np.arccos(np.clip(cos, 0, 1)))
    offset = np.abs(np.einsum("ikj,ij->ik", voxels.centroid[idx] - voxels.centroid[:, None, :], voxels.normal))
    return float(np.median(angle)), float(np.median(offset) / voxels.edge)


def choose_params(points: np.ndarray, base: Params = Params()) -> AutoChoice:
    """Parameters for this cloud: zeta from density, theta and psi from measured noise.

    Parameters
    ----------
    points : (N, 3) array
        Local (offset-centred) coordinates, ``Cloud.local``.
    base : Params
        Its fields other than zeta, theta and psi are kept.

    Returns
    -------
    AutoChoice
        The parameters and the density and noise they were chosen from.

    Examples
    --------
    >>> from geostructure.synthetic import observatory_scene
    >>> choice = choose_params(observatory_scene(60_000, seed=1).cloud.local)
    >>> 0.001 <= choice.params.zeta <= 0.1 and choice.params.k
    8
    """
    probe = Occupancy(points, SAMPLE_POINTS, 0)
    last: list = []

    def fit(zeta: float):  # fit_voxels' grid, its moments kept for the filter
        moments, inverse = accumulate_moments(points, zeta * probe.extent, probe.lower)
        last[:] = [CloudMoments(moments, inverse)]
        return voxel_planes_from_moments(moments, 5, 1 / 3)[0]

    def noise_fit(zeta: float):  # whole voxels drawn by hash: sigma only
        edge = zeta * probe.extent
        drawn = points[noise_sample(points, probe.lower, edge, len(points))]
        return voxel_planes_from_moments(accumulate_moments(drawn, edge, probe.lower)[0], 5, 1 / 3)[0]

    choice = choose_from(probe, fit, base, noise_fit if samples_noise(len(points)) else None)
    return replace(choice, moments=last[0] if last else None)


def samples_noise(n_points: int) -> bool:
    """Whether a cloud of ``n_points`` has its noise read on drawn voxels (:func:`noise_sample`)."""
    return n_points > 2 * NOISE_SAMPLE_POINTS


def noise_sample(points: np.ndarray, lower, edge: float, n_points: int) -> np.ndarray:
    """Which of ``points`` (of a cloud of ``n_points``) lie in the voxels of ``edge``
    (anchored at ``lower``) drawn by their key's hash to hold about
    :data:`NOISE_SAMPLE_POINTS`: the same voxels whole, in any order and chunk by chunk."""
    return sampled_blocks(points, lower, edge, NOISE_SAMPLE_POINTS / n_points, seed=1)


def rounded_zeta(zeta: float) -> float:
    """Zeta as chosen: five decimals, or three significant digits below 0.001.

    Examples
    --------
    >>> rounded_zeta(0.0123456), rounded_zeta(0.000123456)
    (0.01235, 0.000123)
    """
    return round(zeta, 5) if zeta >= 1e-3 else float(f"{zeta:.3g}")


def choose_from(probe: Occupancy, fit, base: Params = Params(), noise_fit=None) -> AutoChoice:
    """:func:`choose_params` from an occupancy probe of the cloud and ``fit(zeta)``, its
    voxel planes at ``zeta`` with any planarity: how a streamed cloud, never in memory
    at once, is given the same choice. ``noise_fit(zeta)``, when given, is the planes of a
    sample of whole voxels (:func:`noise_sample`), the noise sigma read on them; ``fit`` is
    then called once, at the zeta chosen."""
    density_zeta, occupancy = choose_zeta(None, probe=probe)
    # Fitted at the zeta the parameters will carry, so the last fit's grid is the filter's.
    density_zeta = rounded_zeta(density_zeta)
    voxels = (noise_fit or fit)(density_zeta)
    sigma = float(np.median(voxels.residual)) if len(voxels) else 0.0  # no voxel plane: no noise to read
    extent = probe.extent
    zeta = float(np.clip(max(density_zeta, sigma / (MAX_NOISE_RATIO * extent)), ZETA_FLOOR, ZETA_RANGE[1]))
    zeta = rounded_zeta(zeta)
    if zeta != density_zeta:  # noise made the voxels coarser: measure the noise at that size
        occupancy = probe.at(zeta)
    if zeta != density_zeta or noise_fit is not None:
        voxels = fit(zeta)
    angle, offset = surface_noise(None, zeta, voxels=voxels)
    theta = float(np.clip(1.5 * angle, *THETA_RANGE))
    psi = float(np.clip(3.0 * offset, *PSI_RANGE))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ParameterWarning)  # a sparse cloud may need zeta past 0.07
        params = base.with_(zeta=zeta, theta=round(theta, 2), psi=round(psi, 3), k=8)
    return AutoChoice(params, occupancy, angle, offset)
