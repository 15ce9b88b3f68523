"""Parameters of the measuring pipeline, with the paper's Table 1 ranges."""

from __future__ import annotations

import math
import numbers
import warnings
from dataclasses import asdict, dataclass, replace

from geostructure.errors import GeoStructureWarning, ParameterError

#: The choices each method parameter takes; the detector modules that implement them
#: import their names from here, so that the parameters stay below the stages.
FILTER_METHODS = ("local", "global", "none")
RECTANGLE_METHODS = ("exact", "golden")
REFERENCES = ("region", "seed")
DETECTORS = ("facets", "voxel")

#: Beyond this many standard deviations the outlier filter keeps every point of any real cloud, and
#: its squares stay far from overflow; ``--filter none`` says so plainly.
MAX_FILTER_SIGMA = 1000.0
#: The most neighbours a seed may ask for: the paper's k is 8 to 30; a billion asked for
#: arrays of a billion rows per seed (a traceback, out of memory).
MAX_K = 10_000
#: The finest voxel edge, as a share of the extent: a million voxels along the cloud. At
#: 1e-300 the run measured first and was refused after.
MIN_ZETA = 1e-6

#: The paper's Table 1 (start, end, step): the ranges of its four experiments.
TABLE1 = {"zeta": (0.01, 0.07, 0.006), "theta": (0.0, 30.0, 3.0), "psi": (0.01, 0.6, 0.06), "k": (1, 20, 2)}


class ParameterWarning(GeoStructureWarning):
    """A parameter lies outside the range the paper tested."""


@dataclass(frozen=True)
class Params:
    """Everything that steers a run. Defaults follow the paper's findings (lower is better).

    Parameters
    ----------
    zeta : float
        Voxel edge as a fraction of the cloud's largest extent (paper 0.01-0.07).
    theta : float
        Region-growing angle threshold, degrees (paper's optimum 3-8).
    psi : float
        Region-growing offset threshold, in voxel edges (paper's optimum 0.01-0.2).
    k : int
        Neighbours per seed in region growing (paper's optimum 3-11).
    min_points : int or None
        Smallest region reported; ``None``: 30 for facets, and for regions grown over voxels
        0.1% of the filtered points, at least 30.
    filter : str
        ``local`` (default), ``global`` (the paper's formula) or ``none``.
    filter_sigma : float
        Mahalanobis distance beyond which a point is an outlier.
    min_voxel_points : int
        Voxels with fewer points fit no plane.
    max_curvature : float
        Voxels less planar than this (smallest eigenvalue / sum) are dropped.
    reference : str
        Region growing compares normals with the ``region`` plane or the ``seed``.
    max_gap : float
        Region-growing neighbours further than this many voxel edges are ignored.
    rectangle : str
        ``exact`` (rotating calipers) or ``golden`` (the paper's search).
    merge : bool
        Join coplanar regions split by a small gap (not in the paper; see :mod:`.merge`).
    detector : str
        ``facets`` (facets grown on a fine grid's local planes, down to small joints on rough rock, with
        the paper's voxel growing where a grown facet is curved; see :mod:`.facets`) or
        ``voxel`` (the paper's region growing over voxel planes alone).

    Examples
    --------
    >>> p = Params(theta=4)
    >>> p.theta, p.with_(k=5).k, p.k
    (4, 5, 8)
    """

    zeta: float = 0.01
    theta: float = 5.0
    psi: float = 0.1
    k: int = 8
    min_points: int | None = None
    filter: str = "local"
    filter_sigma: float = 3.0
    min_voxel_points: int = 5
    max_curvature: float = 0.05
    reference: str = "region"
    max_gap: float = 2.0
    rectangle: str = "exact"
    merge: bool = True
    detector: str = "facets"

    def __post_init__(self):
        for name in ("zeta", "theta", "psi", "filter_sigma", "max_curvature", "max_gap"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(value):
                raise ParameterError(f"{name} must be a finite number, not {value!r}.")
        for name in ("k", "min_points", "min_voxel_points"):
            value = getattr(self, name)
            if value is not None and (
                isinstance(value, bool)
                or not isinstance(value, numbers.Real)
                or not math.isfinite(value)
                or int(value) != value
            ):
                raise ParameterError(f"{name} must be a whole number, not {value!r}.")
        checks = [
            (
                MIN_ZETA <= self.zeta < 1,
                f"zeta must lie between {MIN_ZETA:g} and 1 (a fraction of the cloud's extent), got {self.zeta:g}",
            ),
            (0 <= self.theta <= 90, f"theta must lie between 0 and 90 degrees, got {self.theta}"),
            (self.psi > 0, f"psi must be positive (voxel edges), got {self.psi}"),
            (
                not MIN_ZETA <= self.zeta < 1 or self.psi * self.zeta <= 1,  # zeta's own check comes first
                f"psi must be at most 1/zeta = {1 / max(self.zeta, 1e-300):g} voxel edges (a larger offset is "
                f"wider than the cloud itself), got {self.psi:g}",
            ),
            (
                int(self.k) == self.k and 1 <= self.k <= MAX_K,
                f"k must be a whole number from 1 to {MAX_K:,}, got {self.k}",
            ),
            (self.min_points is None or self.min_points >= 3, f"min-points must be at least 3, got {self.min_points}"),
            (self.filter in FILTER_METHODS, f"filter must be one of {', '.join(FILTER_METHODS)}, got '{self.filter}'"),
            (self.filter_sigma > 0, f"filter sigma must be positive, got {self.filter_sigma}"),
            (
                self.filter_sigma <= MAX_FILTER_SIGMA,
                f"filter sigma must be at most {MAX_FILTER_SIGMA:g} standard deviations (--filter none keeps every "
                f"point), got {self.filter_sigma:g}",
            ),
            (self.min_voxel_points >= 3, f"min voxel points must be at least 3, got {self.min_voxel_points}"),
            (0 < self.max_curvature <= 1 / 3, f"max curvature must lie in (0, 1/3], got {self.max_curvature}"),
            (self.reference in REFERENCES, f"reference must be one of {', '.join(REFERENCES)}, got '{self.reference}'"),
            (self.max_gap > 0, f"max gap must be positive, got {self.max_gap}"),
            (self.detector in DETECTORS, f"detector must be one of {', '.join(DETECTORS)}, got '{self.detector}'"),
            (
                self.rectangle in RECTANGLE_METHODS,
                f"rectangle must be one of {', '.join(RECTANGLE_METHODS)}, got '{self.rectangle}'",
            ),
        ]
        for ok, message in checks:
            if not ok:
                raise ParameterError(message + ".")
        object.__setattr__(self, "k", int(self.k))
        for name, (lo, hi, _) in TABLE1.items():
            value = getattr(self, name)
            if not lo <= value <= hi:
                warnings.warn(
                    f"{name}={value} is outside the range the paper tested ({lo} to {hi}).",
                    ParameterWarning,
                    stacklevel=3,
                )

    def with_(self, **changes) -> "Params":
        """A copy with some fields changed (validated again)."""
        return replace(self, **changes)

    def to_dict(self) -> dict:
        return asdict(self)
