"""Kinematic tests of a rock slope: which planes, and pairs of planes, can slide or topple out.

All angles are degrees; orientations are dip and dip direction (of planes), trend and plunge
(of lines), in the run's frame. The tests are those a geologist draws on a stereonet
(Markland 1972; Hoek & Bray 1981; Goodman 1980; Wyllie & Mah 2004), as Dips applies them:

- **Planar sliding** (:func:`planar_sliding`): the plane dips out of the slope within
  ``lateral_limit`` of its dip direction, steeper than the friction angle, and daylights: its
  dip is less than the slope's apparent dip in the plane's dip direction,
  tan(apparent) = tan(slope dip) cos(plane dip direction - slope dip direction).
- **Wedge sliding** (:func:`wedges`; pairs at least :data:`MIN_PAIR_ANGLE` apart): the
  intersection line of two planes plunges steeper than
  the friction angle and daylights (its plunge is less than the slope's apparent dip along its
  trend). The wedge rides on both planes when the normal forces that hold it up are both
  pushing; otherwise it lifts off one and slides on the other alone (Hocking 1976), which is
  the planar test's case and is flagged ``single_plane``: such a wedge is critical only where
  that plane passes the planar test (daylight, lateral limits); a block lifted onto a plane
  dipping into the face cannot move.
- **Flexural toppling** (:func:`flexural_toppling`; Goodman 1980): the plane dips into the slope,
  its dip direction within ``lateral_limit`` of the slope's opposite, and its pole lies outside
  Dips' slip limit plane (dip: slope dip - friction, dip direction: the slope's): the pole's
  plunge is less than that plane's apparent dip along the pole's trend. Along the slope's dip
  direction this is Goodman's dip > 90 - slope dip + friction.
- **Direct toppling** (:func:`direct_toppling`; Hudson & Harrison 1997, as Dips applies it): the
  intersection line of two planes plunges into the slope, its trend within ``lateral_limit`` of
  the slope's opposite, and steeper than 90 - slope dip (the block leans out of the face), and
  base planes exist on which such blocks stand: planes dipping out of the slope within the
  lateral limits, gentler than the slope; a base plane steeper than the friction angle lets
  the blocks slide as they topple. Dips' secondary zone (``oblique``): lines as steep, outside
  those lateral limits, that do not daylight; near vertical, a column can topple off its
  line's trend. Base planes there (``oblique_base``) dip gentler than the slope, outside its
  lateral limits, and their poles do not daylight.
- **Factor of safety**, dry: planar FS = tan(friction) / tan(dip), and with cohesion that of
  the block under a face of given height (Hoek & Bray 1981; :func:`planar_factor_of_safety`); a wedge's
  from limit equilibrium along its line, FS = (N_a + N_b) tan(friction) / sin(plunge) for a
  block of unit weight, which is Hoek & Bray's (1981) FS = A tan(phi_a) + B tan(phi_b).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from geostructure.core.orientation import normal_from_orientation
from geostructure.errors import ParameterError
from geostructure.kinematics.wedge import UNIT_WEIGHT, wedge_blocks, wedge_factor_of_safety

#: Dips' default lateral limits (degrees) for planar sliding and flexural toppling.
LATERAL_LIMIT = 20.0
#: Two planes nearer than this (degrees) form no wedge and no block: their line is noise (two
#: facets of one joint meet anywhere along their plane).
MIN_PAIR_ANGLE = 10.0


@dataclass(frozen=True)
class Slope:
    """The slope face: dip, dip direction, their standard errors (degrees), how it was set
    (``given``, or ``fitted`` to the cloud), and for a fitted one how far the face turns along
    its strike (degrees, :func:`~geostructure.rockmass.exposure.face_bend`): one plane stands for a face that
    turns by :data:`~geostructure.rockmass.exposure.BENT_FACE` or more for none of its parts.

    Parameters
    ----------
    dip, dip_direction : float
        The face's orientation (degrees).
    dip_uncertainty, dip_direction_uncertainty : float
        Their standard errors (degrees); 0 for a slope given by hand.
    source : str
        ``given``, or ``fitted`` to the cloud.
    face_bend : float
        For a fitted slope, how far the face turns along its strike (degrees).

    Examples
    --------
    >>> slope = Slope(65.0, 180.0)
    >>> slope.dip, slope.source
    (65.0, 'given')

    """

    dip: float
    dip_direction: float
    dip_uncertainty: float = 0.0
    dip_direction_uncertainty: float = 0.0
    source: str = "given"
    face_bend: float = 0.0

    def __post_init__(self):
        if not (np.isfinite(self.dip) and 0.0 < self.dip <= 90.0):
            raise ParameterError(f"the slope's dip must be more than 0 and at most 90 degrees, not {self.dip}.")
        if not np.isfinite(self.dip_direction):
            raise ParameterError(f"the slope's dip direction must be a number of degrees, not {self.dip_direction}.")
        object.__setattr__(self, "dip_direction", float(self.dip_direction) % 360.0)


def check_friction(friction: float) -> float:
    if not (np.isfinite(friction) and 0.0 < friction < 90.0):
        raise ParameterError(f"the friction angle must be more than 0 and less than 90 degrees, not {friction}.")
    return float(friction)


#: The bounds of the cohesion (kPa), the unit weight (kN/m3) and the slope's height (m):
#: bounds no rock reaches, so that the arithmetic cannot overflow. The strongest intact
#: rock's cohesion is some 50 MPa, rock weighs 20 to 30 kN/m3 (water 9.8), no slope is 10 km
#: high, nor a block measured on one a centimetre.
MAX_COHESION = 1e5
MIN_UNIT_WEIGHT, MAX_UNIT_WEIGHT = 1.0, 100.0
MIN_HEIGHT, MAX_HEIGHT = 0.01, 1e4


def check_strength(cohesion: float | None, unit_weight: float | None, height: float | None) -> None:
    """Refuse a cohesion, unit weight or height (None: not given) out of its bounds, naming
    the option.

    Examples
    --------
    >>> check_strength(20.0, 26.0, None)
    >>> check_strength(None, 1e9, None)
    Traceback (most recent call last):
    ...
    geostructure.errors.ParameterError: --unit-weight must be a finite number from 1 to 100, not 1e+09.
    """
    for name, value, least, most in (
        ("--cohesion", cohesion, 0.0, MAX_COHESION),
        ("--unit-weight", unit_weight, MIN_UNIT_WEIGHT, MAX_UNIT_WEIGHT),
        ("--height", height, MIN_HEIGHT, MAX_HEIGHT),
    ):
        if value is not None and not (math.isfinite(value) and least <= value <= most):
            raise ParameterError(f"{name} must be a finite number from {least:g} to {most:g}, not {value:g}.")


def angular_difference(a, b) -> np.ndarray:
    """|a - b| folded into [0, 180] (degrees)."""
    return np.abs((np.asarray(a, dtype=np.float64) - b + 180.0) % 360.0 - 180.0)


def _daylights(trend, plunge, slope: Slope) -> np.ndarray:
    """Lines (trend, plunge) that come out of the slope face: plunge below its apparent dip."""
    cosine = np.cos(np.radians(np.asarray(trend, dtype=np.float64) - slope.dip_direction))
    apparent = np.degrees(np.arctan(np.tan(np.radians(slope.dip)) * np.clip(cosine, 0.0, None)))
    return (cosine > 0) & (np.asarray(plunge) < apparent)


def planar_sliding(dip, dip_direction, slope: Slope, friction: float, lateral_limit: float = LATERAL_LIMIT):
    """Which planes can slide out of the slope on themselves (see the module's description).

    Examples
    --------
    >>> slope = Slope(dip=60.0, dip_direction=180.0)
    >>> planar_sliding([45, 45, 25, 45, 65], [180, 210, 180, 0, 180], slope, friction=30.0).tolist()
    [True, False, False, False, False]
    """
    friction = check_friction(friction)
    dip = np.asarray(dip, dtype=np.float64)
    lateral = angular_difference(dip_direction, slope.dip_direction) <= lateral_limit
    return lateral & (dip > friction) & _daylights(dip_direction, dip, slope)


def flexural_toppling(dip, dip_direction, slope: Slope, friction: float, lateral_limit: float = LATERAL_LIMIT):
    """Which planes dip into the slope steeply enough for the slabs between them to topple.

    Examples
    --------
    >>> slope = Slope(dip=75.0, dip_direction=180.0)
    >>> flexural_toppling([70, 70, 40, 70], [0, 180, 0, 40], slope, friction=30.0).tolist()
    [True, False, False, False]
    """
    friction = check_friction(friction)
    dip = np.asarray(dip, dtype=np.float64)
    opposite = angular_difference(dip_direction, slope.dip_direction + 180.0) <= lateral_limit
    pole_trend, pole_plunge = np.asarray(dip_direction, dtype=np.float64) + 180.0, 90.0 - dip
    limit = max(slope.dip - friction, 0.0)  # the slip limit plane's dip
    cosine = np.cos(np.radians(pole_trend - slope.dip_direction))
    apparent = np.degrees(np.arctan(np.tan(np.radians(limit)) * np.clip(cosine, 0.0, None)))
    return opposite & (pole_plunge < apparent)


@dataclass
class DirectToppling:
    """Pairs ``a`` < ``b`` whose intersection line (``trend``, ``plunge``) lies in the direct
    toppling zone, and per plane whether it is a ``base`` plane for such blocks and whether
    blocks on it would slide too (``sliding_base``). The ``oblique_*`` fields are the same for
    Dips' secondary zone (oblique toppling; see the module's description)."""

    a: np.ndarray
    b: np.ndarray
    trend: np.ndarray
    plunge: np.ndarray
    base: np.ndarray
    sliding_base: np.ndarray
    oblique_a: np.ndarray
    oblique_b: np.ndarray
    oblique_trend: np.ndarray
    oblique_plunge: np.ndarray
    oblique_base: np.ndarray

    @property
    def critical(self) -> bool:
        """Blocks can form and have something to topple over: lines in the zone and a base plane."""
        return bool(len(self.a)) and bool(self.base.any())

    @property
    def oblique_critical(self) -> bool:
        """Steep columns in the secondary zone, and a base plane of either zone to stand on."""
        return bool(len(self.oblique_a)) and bool((self.base | self.oblique_base).any())


def direct_toppling(
    dip, dip_direction, slope: Slope, friction: float, lateral_limit: float = LATERAL_LIMIT, *, max_planes: int = 3000
) -> DirectToppling:
    """Direct toppling's intersections and base planes, in Dips' primary and secondary zones
    (see the module's description).

    Examples
    --------
    >>> slope = Slope(dip=70.0, dip_direction=180.0)
    >>> t = direct_toppling([85, 85, 20], [330, 30, 180], slope, friction=30.0)  # two steep joints, a flat base
    >>> t.a.tolist(), t.b.tolist(), round(float(t.plunge[0])), t.base.tolist(), t.critical  # the line plunges north
    ([0], [1], 84, [False, False, True], True)
    >>> t = direct_toppling([85, 85, 20], [60, 120, 180], slope, friction=30.0)  # their line plunges east
    >>> t.critical, t.oblique_a.tolist(), round(float(t.oblique_trend[0])), t.oblique_critical
    (False, [0], 90, True)
    """
    friction = check_friction(friction)
    dip = np.asarray(dip, dtype=np.float64)
    dd = np.asarray(dip_direction, dtype=np.float64)
    n = len(dip)
    if n > max_planes:
        raise ParameterError(
            f"{n} planes make {n * (n - 1) // 2:,} pairs; test the largest {max_planes} or the sets' means."
        )
    normals = normal_from_orientation(dd, dip).reshape(-1, 3)
    a, b = plane_pairs(normals)
    trend, plunge = intersection_lines(normals[a], normals[b])
    steep = np.isfinite(plunge) & (plunge > 90.0 - slope.dip)  # the block leans out of the face
    into = angular_difference(trend, slope.dip_direction + 180.0) <= lateral_limit
    zone = steep & into
    oblique = steep & ~into & ~_daylights(trend, plunge, slope)
    gentle = dip < slope.dip
    out_of_slope = angular_difference(dd, slope.dip_direction) <= lateral_limit
    base = out_of_slope & gentle
    oblique_base = gentle & ~out_of_slope & ~_daylights(dd + 180.0, 90.0 - dip, slope)
    return DirectToppling(
        a[zone], b[zone], trend[zone], plunge[zone], base, base & (dip > friction),
        a[oblique], b[oblique], trend[oblique], plunge[oblique], oblique_base,
    )  # fmt: skip


def planar_factor_of_safety(
    dip, friction: float, *, cohesion: float = 0.0, height: float | None = None, slope_dip: float | None = None,
    unit_weight: float = UNIT_WEIGHT,
) -> np.ndarray:  # fmt: skip
    """Factor of safety of a block sliding on a plane, dry (Hoek & Bray 1981).

    Without cohesion it is tan(friction) / tan(dip), whatever the block's size (inf for a
    flat plane). With ``cohesion`` (kPa) the block counts. Per metre of slope, the block
    under a face of ``slope_dip`` and ``height`` (m), with a level top and no tension crack,
    has a sliding plane of A = H / sin(dip) and a weight of
    W = unit_weight H^2 (cot(dip) - cot(slope_dip)) / 2 (kN), so that
    FS = (cohesion A + W cos(dip) tan(friction)) / (W sin(dip)). A plane at least as steep
    as the face cuts no block: NaN. Ground rising above the crest would change nothing: with
    no tension crack the block is a triangle on its sliding plane whose height is the
    crest's distance from the plane, so its weight grows with A and c A / W stays.

    Examples
    --------
    Culmann's critical height, 4 c sin(face) cos(phi) / (gamma (1 - cos(face - phi))), is
    where the plane at (face + phi) / 2 is at FS = 1:

    >>> c, phi, face, gamma = 20.0, 30.0, 60.0, 26.0
    >>> h = 4 * c * np.sin(np.radians(face)) * np.cos(np.radians(phi)) / (gamma * (1 - np.cos(np.radians(face - phi))))
    >>> float(planar_factor_of_safety(45.0, phi, cohesion=c, height=h, slope_dip=face, unit_weight=gamma).round(6))
    1.0
    """
    friction = check_friction(friction)
    dip = np.radians(np.asarray(dip, dtype=np.float64))
    with np.errstate(divide="ignore", invalid="ignore"):
        frictional = np.tan(np.radians(friction)) / np.tan(dip)
        if not cohesion:
            return frictional
        if height is None or slope_dip is None or not height > 0 or not unit_weight > 0:
            raise ParameterError(
                "a factor of safety with cohesion needs the slope's height and dip, and a unit weight."
            )
        face = np.radians(slope_dip)
        weight = 0.5 * unit_weight * height**2 * (1.0 / np.tan(dip) - 1.0 / np.tan(face))
        fs = frictional + cohesion * (height / np.sin(dip)) / (weight * np.sin(dip))
    return np.where(weight > 0, fs, np.nan)


def intersection_lines(normals_a, normals_b) -> tuple[np.ndarray, np.ndarray]:
    """Trend and plunge (degrees) of the downward line where planes a and b meet (ENU normals);
    NaN for parallel planes."""
    line = np.cross(np.asarray(normals_a, dtype=np.float64), np.asarray(normals_b, dtype=np.float64))
    length = np.linalg.norm(line, axis=-1, keepdims=True)
    line = np.where(length > 1e-9, line / np.maximum(length, 1e-300), np.nan)
    line = np.where(line[..., 2:3] > 0, -line, line)  # downward
    trend = np.degrees(np.arctan2(line[..., 0], line[..., 1])) % 360.0
    plunge = np.degrees(np.arcsin(np.clip(-line[..., 2], -1.0, 1.0)))
    return trend, plunge


@dataclass
class Wedges:
    """Every pair of planes ``a`` < ``b`` whose intersection is critical, with its line's
    ``trend`` and ``plunge``, ``factor_of_safety`` and ``single_plane`` (-1 when the wedge rides
    on both planes, else the index of the one it slides on alone); ``pairs_tested`` counts the pairs
    at least :data:`MIN_PAIR_ANGLE` apart that were tested; ``lifted_into_face`` the pairs whose
    line daylights but whose block lifts off one plane onto one that cannot slide out (it dips
    into the face or outside the lateral limits), left out as not critical."""

    a: np.ndarray
    b: np.ndarray
    trend: np.ndarray
    plunge: np.ndarray
    factor_of_safety: np.ndarray
    single_plane: np.ndarray
    pairs_tested: int = 0
    lifted_into_face: int = 0

    def __len__(self) -> int:
        return len(self.a)


def wedges(
    dip, dip_direction, slope: Slope, friction: float, *, max_planes: int = 3000, cohesion: float = 0.0,
    height: float | None = None, unit_weight: float = UNIT_WEIGHT, upper_normal=(0.0, 0.0, 1.0),
    lateral_limit: float = LATERAL_LIMIT,
) -> Wedges:  # fmt: skip
    """The critical wedges among all pairs of planes (see the module's description); with
    ``cohesion`` (kPa), their factor of safety is that of the tetrahedral block each pair cuts
    under a face of ``height`` m whose top has the upward ``upper_normal`` (level by
    default; :mod:`.wedge`).

    Examples
    --------
    >>> slope = Slope(dip=70.0, dip_direction=180.0)
    >>> w = wedges([55, 55, 20], [140, 220, 180], slope, friction=30.0)  # a symmetric wedge, and a flat plane
    >>> w.a.tolist(), w.b.tolist(), round(float(w.plunge[0]), 1), round(float(w.trend[0]), 1)
    ([0], [1], 47.6, 180.0)
    """
    friction = check_friction(friction)
    dip = np.asarray(dip, dtype=np.float64)
    n = len(dip)
    if n > max_planes:
        raise ParameterError(
            f"{n} planes make {n * (n - 1) // 2:,} pairs; test the largest {max_planes} or the sets' means."
        )
    normals = normal_from_orientation(np.asarray(dip_direction, dtype=np.float64), dip).reshape(-1, 3)
    a, b = plane_pairs(normals)
    pairs_tested = len(a)
    trend, plunge = intersection_lines(normals[a], normals[b])
    critical = np.isfinite(plunge) & (plunge > friction) & _daylights(trend, plunge, slope)
    a, b, trend, plunge = a[critical], b[critical], trend[critical], plunge[critical]
    blocks = None
    if cohesion:
        if height is None or not height > 0 or not unit_weight > 0:
            raise ParameterError("a wedge's factor of safety with cohesion needs the slope's height and a unit weight.")
        face = normal_from_orientation(slope.dip_direction, slope.dip)
        blocks = wedge_blocks(normals[a], normals[b], face, height, upper_normal)
    fs, single = wedge_factor_of_safety(
        normals[a], normals[b], friction, cohesion_a=cohesion, blocks=blocks, unit_weight=unit_weight
    )
    single = np.where(single == 0, a, np.where(single == 1, b, -1))
    # A block that lifts off one plane slides down the other's dip, not along the line: it
    # moves only where that plane could slide out on its own (daylight, lateral limits).
    rides = single >= 0
    riding = np.maximum(single, 0)
    can_move = ~rides | planar_sliding(dip[riding], np.asarray(dip_direction, dtype=np.float64)[riding], slope,
                                       friction, lateral_limit)  # fmt: skip
    keep = np.flatnonzero(can_move)
    return Wedges(a[keep], b[keep], trend[keep], plunge[keep], fs[keep], single[keep], pairs_tested,
                  int(len(a) - len(keep)))  # fmt: skip


def plane_pairs(normals) -> tuple[np.ndarray, np.ndarray]:
    """Every pair a < b of planes at least :data:`MIN_PAIR_ANGLE` apart."""
    a, b = np.triu_indices(len(normals), k=1)
    apart = np.abs(np.einsum("ij,ij->i", normals[a], normals[b])) < np.cos(np.radians(MIN_PAIR_ANGLE))
    return a[apart], b[apart]


def percent_critical(critical, weights=None) -> float:
    """Share (%) of the planes that are critical, by count or weighted (by area)."""
    critical = np.asarray(critical, dtype=bool)
    if len(critical) == 0:
        return float("nan")
    w = np.ones(len(critical)) if weights is None else np.asarray(weights, dtype=np.float64)
    return float(min(100.0, 100.0 * w[critical].sum() / w.sum())) if w.sum() > 0 else float("nan")
