"""Joint spacing per set (ISRM 1978): virtual scanlines on the face, and DSE's nearest planes.

The joints are a set's facets grouped by plane (:func:`~geostructure.rockmass.joints.joint_planes`).

- **Scanlines** (:func:`scanline_spacing`): lines on the mean face every
  :data:`LINE_SPACING`, in the direction of the set's mean normal projected onto the face
  (the direction that meets most of the set's joints), each as long as the cloud under it.
  Every joint is extended as a persistent plane and meets a line where its plane crosses
  it; or, given its traces (:func:`~geostructure.rockmass.tracelengths.joint_traces`), only where the stretches of its trace
  that its facets show cross it (joints a few metres long on a longer face). The gaps
  between consecutive crossings, times the cosine between line and mean normal (Terzaghi
  1965), are normal spacings; the set's mean normal spacing is the cosine
  times the lines' length over the crossings (Priest & Hudson 1976), which the lines' ends
  do not bias, as they bias the mean of the gaps.
- **Nearest planes** (:func:`nearest_plane_gaps`), after DSE (Riquelme et al. 2015): the
  normal distance from each plane to the nearest plane of its set that overlaps it seen
  along the set's mean normal. No persistence is assumed, so on a face where a set's joints
  are seen only in parts it reads the distance to the nearest exposed neighbour.
- **Distributions** (:func:`spacing_statistics`): mean, median, mode, and the exponential and
  lognormal fits by maximum likelihood, with their AIC and Kolmogorov-Smirnov statistics.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from geostructure.rockmass.exposure import Exposure, Persistence
from geostructure.rockmass.joints import SAME_JOINT_TOLERANCE

#: Distance (m) between neighbouring scanlines across the face.
LINE_SPACING = 1.0
#: Crossings of one line nearer than this (m, normal distance) are one joint split in two.
CROSSING_TOLERANCE = 0.005
#: Scanlines meet a set too obliquely below this cosine between line and mean normal.
MIN_SCANLINE_COSINE = 0.25
#: Plane pairs compared at once by :func:`nearest_plane_gaps`: some 32 MB per pair array.
PAIRS_AT_ONCE = 1 << 22


@dataclass
class Scanlines:
    """One set's scanlines: ``gaps`` (normal spacings, m), total ``length`` (m), ``crossings``,
    ``joints`` (distinct joints met), ``cosine`` between line and mean normal, ``direction``."""

    gaps: np.ndarray
    length: float
    crossings: int
    joints: int
    cosine: float
    direction: np.ndarray | None

    @property
    def p10(self) -> float:
        """Joints per metre of line."""
        return self.crossings / self.length if self.length > 0 else float("nan")

    @property
    def spacing(self) -> float:
        """Mean normal spacing (m): cosine over P10."""
        return self.cosine / self.p10 if self.p10 > 0 else float("nan")

    @property
    def spacing_std_error(self) -> float:
        """Standard error (m) of :attr:`spacing`, taking the joints met as a Poisson count:
        adjacent lines meet the same joints, so the gaps are not independent samples."""
        return self.spacing / np.sqrt(self.joints) if self.joints > 0 else float("nan")


def pooled_scanlines(lines: list[Scanlines]) -> Scanlines:
    """One set's scanlines on the sections of a face that turns, as one: their gaps, lengths,
    crossings and joints summed, and the cosine their lengths weight, so that the spacing is
    the lines' normal length over their crossings (Priest & Hudson 1976) on every section
    together; the direction of the longest. One section's lines come back as they are.

    Examples
    --------
    >>> a = Scanlines(np.array([0.5]), 10.0, 20, 18, 0.9, np.array([1.0, 0.0, 0.0]))
    >>> b = Scanlines(np.array([0.6]), 5.0, 8, 8, 0.6, np.array([0.0, 1.0, 0.0]))
    >>> both = pooled_scanlines([a, b])
    >>> both.length, both.crossings, round(both.spacing, 4), round((9.0 + 3.0) / 28, 4)
    (15.0, 28, 0.4286, 0.4286)
    """
    if len(lines) == 1:
        return lines[0]
    length = float(sum(line.length for line in lines))
    seen = [line for line in lines if line.direction is not None]
    if not seen:
        return Scanlines(np.zeros(0), 0.0, 0, 0, max((line.cosine for line in lines), default=0.0), None)
    cosine = sum(line.cosine * line.length for line in seen) / length if length > 0 else seen[0].cosine
    return Scanlines(
        np.concatenate([line.gaps for line in lines]),
        length,
        sum(line.crossings for line in lines),
        sum(line.joints for line in lines),
        float(cosine),
        max(seen, key=lambda line: line.length).direction,
    )


def scanline_spacing(points, joint_normal, joint_centre, mean, face: Exposure, uv=None, traces=None) -> Scanlines:
    """One set's joints along virtual scanlines on the face (see the module's description).

    Parameters
    ----------
    points : (N, 3) array
        The cloud (local coordinates): the lines run as far as it does.
    joint_normal, joint_centre : (J, 3) array
        The set's joints (:func:`joint_planes`).
    mean : (3,) array
        The set's mean normal.
    face : Exposure
    uv : (N, 2) array, optional
        ``face.project(points)``, when made already (one projection serves every set).
    traces : ~.tracelengths.Traces, optional
        Each joint's trace on the face and the stretches of it its facets show
        (:func:`~geostructure.rockmass.tracelengths.joint_traces`): a line meets a joint only there. Without it, every joint is
        a persistent plane across the face.
    """
    direction = mean - (mean @ face.normal) * face.normal
    cosine = float(np.linalg.norm(direction))
    if cosine < MIN_SCANLINE_COSINE or len(joint_normal) == 0:
        return Scanlines(np.zeros(0), 0.0, 0, 0, cosine, None)
    direction /= cosine
    across = np.cross(face.normal, direction)
    # Both lines lie in the face: the points' face coordinates give their positions along them.
    uv = face.project(points) if uv is None else uv
    along_2d, across_2d = face.axes @ direction, face.axes @ across  # the lines' axes in face coordinates
    along_pts, across_pts = uv @ along_2d, uv @ across_2d
    start = across_pts.min() + LINE_SPACING / 2
    # Each line runs as far as the points within a cell of it (a band as wide as the lines'
    # spacing would overstate a line that cuts the face's edge obliquely).
    line = np.round((across_pts - start) / LINE_SPACING).astype(np.int64)
    near = (np.abs(across_pts - start - line * LINE_SPACING) <= face.cell) & (line >= 0)
    n_lines = int(line.max()) + 1
    t_lo, t_hi = np.full(n_lines, np.inf), np.full(n_lines, -np.inf)
    np.minimum.at(t_lo, line[near], along_pts[near])
    np.maximum.at(t_hi, line[near], along_pts[near])
    facing = np.flatnonzero(np.abs(joint_normal @ direction) > 0.1)
    gaps, length, crossings, met = [], 0.0, 0, set()
    for k in np.flatnonzero(np.isfinite(t_lo)):
        offset = start + k * LINE_SPACING
        # Only the stretches of the line over exposed face count: not a hole, nor the
        # ground between the face and a few points beyond it.
        exposed, step = _exposed_stretches(face, offset * across_2d, along_2d, t_lo[k], t_hi[k])
        length += step * exposed.sum()
        origin = face.origin + offset * across
        n = joint_normal[facing]
        t = np.einsum("ij,ij->i", n, joint_centre[facing] - origin) / (n @ direction)
        at = np.minimum(np.floor((t - t_lo[k]) / step).astype(np.int64), len(exposed) - 1)
        inside = (t >= t_lo[k]) & (t <= t_hi[k])
        if traces is not None:  # the joint's trace reaches the line
            crossing = np.einsum("ij,ij->i", origin + np.outer(t, direction), traces.direction[facing])
            inside[inside] = traces.reach(facing[inside], crossing[inside])
        inside[inside] = exposed[at[inside]]
        order = np.argsort(t[inside])
        t, at, who = t[inside][order] * cosine, at[inside][order], facing[inside][order]
        if len(t) == 0:
            continue
        keep = np.concatenate([[True], np.diff(t) > CROSSING_TOLERANCE])  # a joint split in two
        crossings += int(keep.sum())
        met.update(who[keep].tolist())
        # A gap across a stretch the line does not see is no spacing.
        hidden = np.concatenate([[0], np.cumsum(~exposed)])[at[keep]]
        gaps.append(np.diff(t[keep])[hidden[1:] == hidden[:-1]])
    return Scanlines(
        np.concatenate(gaps) if gaps else np.zeros(0), float(length), crossings, len(met), cosine, direction
    )


def _exposed_stretches(face: Exposure, offset, along, t_lo: float, t_hi: float) -> tuple[np.ndarray, float]:
    """Whether the face is exposed along one line (its points ``offset + t along`` in face
    coordinates), in steps of half an occupancy cell from ``t_lo`` to ``t_hi``; and the step."""
    step = face.cell / 2
    t = t_lo + step * (np.arange(max(int(np.ceil((t_hi - t_lo) / step)), 1)) + 0.5)
    return face.exposed_at(offset + t[:, None] * along), step


def nearest_plane_gaps(normals, centroids, members, mean, persistence: Persistence) -> np.ndarray:
    """After DSE: per plane, the normal distance to the nearest same-set plane overlapping it
    along the set's mean normal (the discs of their traces overlap)."""
    if len(members) < 2:
        return np.zeros(0)
    c = centroids[members]
    depth = c @ mean
    flat = c - depth[:, None] * mean
    radius = 0.5 * np.maximum(persistence.trace_strike[members], persistence.trace_dip[members])
    nearest = np.full(len(members), np.inf)
    # Every pair is compared, a block of rows at a time: a set of 10,000 planes (a 100M-point
    # face's) made its whole pair arrays gigabytes at once.
    rows = max(1, PAIRS_AT_ONCE // len(members))
    for start in range(0, len(members), rows):
        block = slice(start, start + rows)
        lateral = np.linalg.norm(flat[block, None, :] - flat[None, :, :], axis=2)
        apart = np.abs(depth[block, None] - depth[None, :])
        facing = (lateral < radius[block, None] + radius[None, :]) & (apart > SAME_JOINT_TOLERANCE)
        nearest[block] = np.where(facing, apart, np.inf).min(axis=1)
    return nearest[np.isfinite(nearest)]


#: ISRM (1978)'s spacing classes: the greatest spacing (m) of each.
SPACING_CLASSES = ((0.02, "extremely close"), (0.06, "very close"), (0.2, "close"), (0.6, "moderate"),
                   (2.0, "wide"), (6.0, "very wide"), (np.inf, "extremely wide"))  # fmt: skip


def spacing_class(spacing: float) -> str:
    """ISRM (1978)'s description of a set's normal spacing (m); an empty string for none.

    Examples
    --------
    >>> spacing_class(0.04), spacing_class(0.45), spacing_class(0.73), spacing_class(float("nan"))
    ('very close', 'moderate', 'wide', '')
    """
    return class_of(spacing, SPACING_CLASSES)


def class_of(value: float, classes) -> str:
    """The name of the first of ``classes`` ((upper bound, name), ascending, the last
    unbounded) that ``value`` falls below; an empty string for NaN.

    Examples
    --------
    >>> class_of(2.5, ((1.0, "small"), (np.inf, "large"))), class_of(float("nan"), ())
    ('large', '')
    """
    if not np.isfinite(value):
        return ""
    return next(name for bound, name in classes if value < bound)


def spacing_statistics(gaps) -> dict:
    """Mean, median, mode and the exponential and lognormal fits (maximum likelihood) of
    spacings, with each fit's AIC and Kolmogorov-Smirnov statistic.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> s = spacing_statistics(rng.exponential(0.5, 2000))
    >>> round(s["mean"], 1), s["best_fit"]
    (0.5, 'exponential')
    >>> spacing_statistics(rng.lognormal(np.log(0.4), 0.5, 2000))["best_fit"]
    'lognormal'
    """
    g = np.asarray(gaps, dtype=np.float64)
    g = g[g > 0]
    keys = (
        "n",
        "mean",
        "median",
        "mode",
        "exp_mean",
        "exp_aic",
        "exp_ks",
        "lognorm_mu",
        "lognorm_sigma",
        "lognorm_aic",
        "lognorm_ks",
        "best_fit",
    )
    if len(g) < 3:
        few: dict = dict.fromkeys(keys, float("nan"))
        few.update(n=len(g), best_fit="", mean=float(g.mean()) if len(g) else float("nan"))
        return few
    from scipy.special import ndtr  # the normal CDF; scipy.stats costs 0.6 s to import

    counts, edges = np.histogram(g, bins="fd")
    top = int(counts.argmax())
    mean = float(g.mean())
    mu, sigma = float(np.log(g).mean()), float(max(np.log(g).std(), 1e-9))
    exp_ll = -len(g) * np.log(mean) - len(g)
    z = (np.log(g) - mu) / sigma
    log_ll = float(np.sum(-np.log(g * sigma * np.sqrt(2.0 * np.pi)) - 0.5 * z**2))
    out: dict = {
        "n": int(len(g)),
        "mean": mean,
        "median": float(np.median(g)),
        "mode": float(0.5 * (edges[top] + edges[top + 1])),
        "exp_mean": mean,
        "exp_aic": float(2 * 1 - 2 * exp_ll),
        "exp_ks": ks_statistic(g, 1.0 - np.exp(-np.sort(g) / mean)),
        "lognorm_mu": mu,
        "lognorm_sigma": sigma,
        "lognorm_aic": float(2 * 2 - 2 * log_ll),
        "lognorm_ks": ks_statistic(g, ndtr((np.log(np.sort(g)) - mu) / sigma)),
    }
    out["best_fit"] = "exponential" if out["exp_aic"] <= out["lognorm_aic"] else "lognormal"
    return out


def ks_statistic(sample: np.ndarray, cdf_of_sorted: np.ndarray) -> float:
    """Kolmogorov-Smirnov statistic: the largest gap between the sample's empirical CDF and a
    fitted CDF, given at the sorted sample (the statistic of ``scipy.stats.kstest``).

    Examples
    --------
    >>> ks_statistic(np.array([1.0, 2.0]), np.array([0.5, 1.0]))
    0.5
    """
    n = len(sample)
    above = np.arange(1, n + 1) / n - cdf_of_sorted
    below = cdf_of_sorted - np.arange(n) / n
    return float(max(above.max(), below.max()))
