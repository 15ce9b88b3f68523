"""Rock-mass statistics of a run's joint sets: spacing, persistence and intensity.

:func:`rock_mass` puts together the exposure and the planes' persistence
(:mod:`.exposure`), each set's spacing (:mod:`.spacing`), and the intensities
(Dershowitz & Herda 1992):

- P10, joints met per metre along each set's scanlines;
- P21, trace length per square metre of exposure, from the joints' traces on the face
  (:mod:`.tracelengths`: the stretches their facets show; a joint that crosses the face without a
  face of its own leaves no trace in the cloud);
- P32, joint area per cubic metre, from P10 with C13 = 1 / mean |n . line| over the set's
  planes, and from P21 with C23 = 1 / mean sin(angle between plane and face normals);
- the volumetric joint count Jv = sum of 1 / spacing over the sets with a spacing (ISRM
  1978; Palmstrom 2005) and the block volume Vb = beta Jv^-3 with beta = 36 (Palmstrom 2005's value for
  equidimensional blocks), and for three sets S1 S2 S3 / (sin g12 sin g23 sin g31);
- RQD from Jv (Palmström 2005), and its least and greatest along a line (Priest & Hudson
  1976; :mod:`.rqd`).

Per set, the mean trace length is the exponential distribution's estimate with censoring,
the sum of all traces over the number not censored, and not the mean of the traces, which
censoring biases short: of its planes' traces (the facets', about 0.5 m whatever the joints'
size), and of its joints' traces on the face (:mod:`.tracelengths`), whose ISRM class is the set's
persistence.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from geostructure.detect.traces import Traces
from geostructure.detect.uncertainty import correlated_tilt
from geostructure.rockmass.exposure import Persistence, exposure
from geostructure.rockmass.face import face_parts
from geostructure.rockmass.joints import PlaneMoments, joint_planes
from geostructure.rockmass.jointtable import Joints
from geostructure.rockmass.rqd import block_size_class, rqd_from_jv, rqd_range
from geostructure.rockmass.sections import FaceSections, face_sections_of, section_exposures, sectioned_persistence
from geostructure.rockmass.setflags import set_flags
from geostructure.rockmass.spacing import (
    nearest_plane_gaps,
    pooled_scanlines,
    scanline_spacing,
    spacing_class,
    spacing_statistics,
)
from geostructure.rockmass.tracelengths import TraceLengths, joint_traces, persistence_class, trace_lengths
from geostructure.rockmass.tracemaps import TRACE_SET_COLUMNS, trace_set_rows

#: Palmstrom (2005)'s block shape factor for Vb = beta Jv^-3 (equidimensional blocks).
BLOCK_SHAPE_FACTOR = 36.0
#: Sets with a measured spacing a block volume needs: fewer cut slabs or columns.
BLOCK_SETS = 3


def exposure_span(exposures) -> float:
    """The longest line across the exposed face (m): the diagonal of the largest section's
    occupied cells."""
    spans = [0.0]
    for face in exposures:
        rows, columns = np.nonzero(face.occupied)
        if len(rows):
            spans.append(float(np.hypot(np.ptp(rows) + 1, np.ptp(columns) + 1) * face.cell))
    return max(spans)


#: The columns ``sets.csv`` adds per set after the orientation statistics.
ROCK_SET_COLUMNS = (
    "spacing_m",
    "spacing_std_error_m",
    "spacing_mean_gap_m",
    "spacing_median_m",
    "spacing_mode_m",
    "spacing_n_gaps",
    "spacing_exp_mean_m",
    "spacing_exp_aic",
    "spacing_exp_ks",
    "spacing_lognorm_mu",
    "spacing_lognorm_sigma",
    "spacing_lognorm_aic",
    "spacing_lognorm_ks",
    "spacing_best_fit",
    "spacing_nearest_m",
    "spacing_nearest_median_m",
    "spacing_persistent_m",
    "spacing_traces_m",
    "spacing_basis",
    "joints_met",
    "scanline_length_m",
    "scanline_cosine",
    "p10_per_m",
    "p21_per_m",
    "p32_per_m",
    "p32_from_p21_per_m",
    "trace_strike_median_m",
    "trace_strike_mean_m",
    "trace_dip_median_m",
    "trace_dip_mean_m",
    "n_censored",
    "joint_traces",
    "joint_traces_censored",
    "joint_trace_median_m",
    "joint_trace_mean_m",
    "joint_trace_std_error_m",
    "joint_trace_estimate_m",
    "exposure_span_m",
    "persistence",
    "spacing_class",
    "n_joints",
    *TRACE_SET_COLUMNS,
    "flags",
)


@dataclass
class RockMass:
    """Spacing, persistence and intensity of a run's sets (:func:`rock_mass`).

    Parameters
    ----------
    persistence : Persistence
        Each plane's traces on the face and whether the face's edge cuts them.
    exposure_area : float
        The exposed face's area (m^2).
    set_labels : (P,) int array
        Each plane's set (-1 for none).
    scanlines, trace_scanlines : list of Scanlines
        Per set, the virtual scanlines meeting its joints as persistent planes, and only
        along the stretches of their traces their facets show.
    joint_trace_lengths, nearest_gaps : list
        Per set, its joints' trace lengths and DSE-style nearest-plane spacings (m).
    p21, c13, c23 : (S,) arrays
        Per set, P21 and the factors that turn P10 and P21 into P32.
    ground, clutter : (P,) bool arrays, optional
        The planes on the level ground before or above the face, and in clutter
        (vegetation, debris, objects): in no set either way.
    point_part : (N,) array, optional
        Each point's part (:data:`~geostructure.rockmass.face.FACE`, ``GROUND`` or ``CLUTTER``).
    joints : Joints, optional
        Every discontinuity once (:class:`~geostructure.rockmass.jointtable.Joints`).
    exposure_span : float
        The longest line across the exposed face (m): no mean trace is given past it.

    The other fields (the correlated tilt, the face's bend and sections, the planes' standard
    errors, the unit) are what :func:`rock_mass` read on the way, recorded in ``run.json``.

    Examples
    --------
    >>> from geostructure import measure
    >>> from geostructure.synthetic import outcrop_scene
    >>> from geostructure.workflows.sets_and_mass import plane_sets
    >>> result = measure(outcrop_scene(width=8.0, height=5.0, seed=5).cloud)
    >>> sets = plane_sets(result.planes)
    >>> rock = rock_mass(result.filtered.local, result.labels, result.planes.normal, sets.labels, sets.mean_normal)
    >>> len(rock.spacing) == len(sets), sorted(rock.set_rows()[0])[:3]
    (True, ['exposure_span_m', 'flags', 'joint_trace_estimate_m'])
    """

    persistence: Persistence
    exposure_area: float
    set_labels: np.ndarray
    scanlines: list = field(default_factory=list)
    trace_scanlines: list = field(default_factory=list)  # the joints met only where their traces show
    joint_trace_lengths: list = field(default_factory=list)  # per set, its joints' traces (TraceLengths)
    nearest_gaps: list = field(default_factory=list)
    p21: np.ndarray = field(default_factory=lambda: np.zeros(0))
    c13: np.ndarray = field(default_factory=lambda: np.zeros(0))
    c23: np.ndarray = field(default_factory=lambda: np.zeros(0))
    correlated_tilt: float = 0.0  # degrees RMS, read from the joints' facets
    correlated_tilt_n: int = 0  # facets it was read from
    tilt_facets_short: int = 0  # facets in joints when too few to read it (uncertainty.MIN_TILT_FACETS)
    tilt_facets_along: int = 0  # facets in joints of sets along the face, not read for it
    exposure_span: float = float("inf")  # m: the longest line across the exposed face (its sections')
    face_bend: float = 0.0  # degrees the face turns along its strike (exposure.face_bend)
    face_sections: int = 1  # the sections it was measured in (sections.section_exposures)
    sections: FaceSections | None = None  # those sections, which a fitted slope takes too
    traces: Traces | None = None  # the face's fracture traces (tracemaps.face_traces), in the cloud's unit
    plane_errors: dict = field(default_factory=dict)  # per plane, with the tilt (runs.plane_rock_mass)
    metres_per_unit: float = 1.0  # of the cloud's coordinates: every length here is in metres
    ground: np.ndarray | None = None  # per plane; None: no ground was told from the face
    clutter: np.ndarray | None = None  # per plane, as ground
    point_part: np.ndarray | None = None  # per point: face.FACE, GROUND or CLUTTER; None: all face
    joints: Joints | None = None  # the sets' facets grouped into joints, every discontinuity once
    exposures: list = field(default_factory=list)  # the face's sections (Exposure), in metres: the circular windows

    @property
    def traces_only(self) -> np.ndarray:
        """Per set, whether its joints are counted only where their traces show: when that
        spacing is :data:`TRACE_DISAGREEMENT` times or more the persistent planes' (see
        :func:`~geostructure.rockmass.notes.persistence_note`)."""
        if not self.trace_scanlines:
            return np.zeros(len(self.scanlines), dtype=bool)
        persistent = np.array([line.spacing for line in self.scanlines], dtype=np.float64)
        traces = np.array([line.spacing for line in self.trace_scanlines], dtype=np.float64)
        with np.errstate(invalid="ignore"):
            return np.isfinite(traces) & (traces >= TRACE_DISAGREEMENT * persistent)

    @property
    def lines(self) -> list:
        """Per set, the scanlines its spacing, P10 and P32 are read on: the joints extended
        as persistent planes, or counted where their traces show (:attr:`traces_only`)."""
        return [t if only else p for p, t, only in zip(self.scanlines, self.trace_scanlines, self.traces_only)] \
            if self.trace_scanlines else list(self.scanlines)  # fmt: skip

    @property
    def spacing(self) -> np.ndarray:
        """Mean normal spacing (m) per set along its scanlines (NaN where none was measured)."""
        return np.array([line.spacing for line in self.lines], dtype=np.float64)

    @property
    def p10(self) -> np.ndarray:
        """Joints per metre along each set's scanlines."""
        return np.array([line.p10 for line in self.lines], dtype=np.float64)

    @property
    def p32_from_p10(self) -> np.ndarray:
        return self.c13 * self.p10

    @property
    def p32_from_p21(self) -> np.ndarray:
        return self.c23 * self.p21

    @property
    def jv(self) -> float:
        """Volumetric joint count (joints per m^3): the sum of 1 / spacing over the sets whose
        spacing was measured (:func:`~geostructure.rockmass.notes.jv_scope` names those left out)."""
        s = self.spacing
        return float(np.sum(1.0 / s[np.isfinite(s)])) if np.isfinite(s).any() else float("nan")

    @property
    def block_volume(self) -> float:
        """Palmstrom's Vb = 36 Jv^-3 (m^3), NaN with fewer than :data:`BLOCK_SETS` sets whose
        spacing was measured: one or two sets cut slabs or columns, which no count closes
        into blocks (an indoor room's floor gave an 11 m^3 "block")."""
        measured = int(np.isfinite(self.spacing).sum())
        return BLOCK_SHAPE_FACTOR * self.jv**-3 if self.jv > 0 and measured >= BLOCK_SETS else float("nan")

    def block_volume_three_sets(self, set_normals) -> float:
        """S1 S2 S3 / (sin g12 sin g23 sin g31) for the three largest sets (m^3; ISRM 1978),
        NaN with fewer than three spacings."""
        s = self.spacing[:3]
        if len(s) < 3 or not np.isfinite(s).all():
            return float("nan")
        n = np.asarray(set_normals, dtype=np.float64)[:3]
        sines = [np.linalg.norm(np.cross(n[a], n[b])) for a, b in ((0, 1), (1, 2), (2, 0))]
        return float(np.prod(s) / max(np.prod(sines), 1e-9))

    def plane_columns(self) -> dict:
        """Per-plane columns for ``planes.csv``: traces (m), the censoring flag (1 when cut
        by the exposure's edge), the ground flag (1: level ground before or above the face),
        the clutter flag (1: a plane in vegetation) and its joint (``joints.csv``; -1 for none)."""
        p = self.persistence
        none = np.zeros(len(p.censored), dtype=bool)
        ground = none if self.ground is None else self.ground
        clutter = none if self.clutter is None else self.clutter
        return {
            "trace_strike_m": p.trace_strike,
            "trace_dip_m": p.trace_dip,
            "trace_face_m": p.trace_face,
            "censored": p.censored.astype(np.int64),
            "ground": ground.astype(np.int64),
            "clutter": clutter.astype(np.int64),
            **({} if self.joints is None else {"joint": self.joints.plane_joint}),
        }

    def set_rows(self) -> list[dict]:
        """Per set, the columns ``sets.csv`` adds after the orientation statistics."""
        rows = []
        p = self.persistence
        only = self.traces_only
        n_joints = self.joints.counts(len(self.lines)) if self.joints is not None else np.zeros(len(self.lines), int)
        trace_rows = trace_set_rows(
            self.traces, len(self.lines), self.exposure_area, self.metres_per_unit, self.exposures
        )
        for s, line in enumerate(self.lines):
            members = np.flatnonzero(self.set_labels == s)
            gap = spacing_statistics(line.gaps)
            near = self.nearest_gaps[s]
            row = {
                "spacing_m": float(line.spacing),
                "spacing_std_error_m": float(line.spacing_std_error),
                "spacing_mean_gap_m": gap["mean"],
                "spacing_median_m": gap["median"],
                "spacing_mode_m": gap["mode"],
                "spacing_n_gaps": gap["n"],
                "spacing_exp_mean_m": gap["exp_mean"],
                "spacing_exp_aic": gap["exp_aic"],
                "spacing_exp_ks": gap["exp_ks"],
                "spacing_lognorm_mu": gap["lognorm_mu"],
                "spacing_lognorm_sigma": gap["lognorm_sigma"],
                "spacing_lognorm_aic": gap["lognorm_aic"],
                "spacing_lognorm_ks": gap["lognorm_ks"],
                "spacing_best_fit": gap["best_fit"],
                "spacing_nearest_m": float(near.mean()) if len(near) else float("nan"),
                "spacing_nearest_median_m": float(np.median(near)) if len(near) else float("nan"),
                "spacing_persistent_m": float(self.scanlines[s].spacing),
                "spacing_traces_m": float(self.trace_scanlines[s].spacing) if self.trace_scanlines else float("nan"),
                "spacing_basis": "traces" if only[s] else "persistent",
                "joints_met": int(line.joints),
                "scanline_length_m": float(line.length),
                "scanline_cosine": float(line.cosine),
                "p10_per_m": float(line.p10),
                "p21_per_m": float(self.p21[s]),
                "p32_per_m": float(self.p32_from_p10[s]),
                "p32_from_p21_per_m": float(self.p32_from_p21[s]),
            }
            for name, trace in (("strike", p.trace_strike), ("dip", p.trace_dip)):
                # The planes' traces, their mean with censoring as the joints' (TraceLengths.mean).
                facets = TraceLengths(trace[members], p.censored[members])
                row[f"trace_{name}_median_m"] = facets.median
                row[f"trace_{name}_mean_m"] = facets.mean
            row["n_censored"] = int(p.censored[members].sum())
            lengths = self.joint_trace_lengths[s] if self.joint_trace_lengths else TraceLengths.none()
            row["joint_traces"] = len(lengths.length)
            row["joint_traces_censored"] = int(lengths.censored.sum())
            row["joint_trace_median_m"] = lengths.median
            row["joint_trace_mean_m"] = lengths.mean
            row["joint_trace_std_error_m"] = lengths.std_error
            row["persistence"] = lengths.persistence
            row["exposure_span_m"] = self.exposure_span
            row["joint_trace_estimate_m"] = lengths.mean
            if lengths.mean > self.exposure_span:
                # The censored estimate reaches past anything this face can show: not a
                # measurement, but a bound: the traces are longer than the exposure spans.
                row["joint_trace_mean_m"] = row["joint_trace_std_error_m"] = float("nan")
                row["persistence"] = persistence_class(self.exposure_span, at_least=True)
            row["spacing_class"] = spacing_class(line.spacing)
            row["n_joints"] = int(n_joints[s])
            row.update(trace_rows[s])
            row["flags"] = ";".join(set_flags(row))  # after the traces' columns: it reads them too
            rows.append(row)
        return rows

    def summary(self, set_normals) -> dict:
        """What ``run.json`` records of the rock mass."""
        return {
            "exposure_area_m2": self.exposure_area,
            "jv_per_m3": self.jv,
            "jv_lower_bound": bool(np.isfinite(self.spacing).sum() < BLOCK_SETS),  # other sets unseen
            "block_volume_m3": self.block_volume,
            "block_volume_three_sets_m3": self.block_volume_three_sets(set_normals),
            "block_size_class": block_size_class(self.jv),
            "rqd_from_jv": rqd_from_jv(self.jv),
            **dict(zip(("rqd_min_by_direction", "rqd_max_by_direction"), rqd_range(set_normals, self.spacing))),
            "spacing_method": "scanlines on the mean face, joints extended as persistent planes, or counted "
            f"where their traces show for a set whose spacing that makes {TRACE_DISAGREEMENT:g} times as long",
            "correlated_tilt_deg": self.correlated_tilt,
            "correlated_tilt_facets": self.correlated_tilt_n,
            "face_bend_deg": self.face_bend,
            "face_sections": self.face_sections,
            "metres_per_cloud_unit": self.metres_per_unit,
            "ground_planes": 0 if self.ground is None else int(self.ground.sum()),
            "clutter_planes": 0 if self.clutter is None else int(self.clutter.sum()),
        }


#: A set's joints are counted only where their traces show when that spacing is this many
#: times the persistent planes': they are seen over short stretches of the face. On twenty
#: faces of planes that cross the rock mass the two differ by 1.55 times at most, and by 1.79
#: with bushes hiding part of the face (1.75 read it on its traces, 1.62 times too long); on
#: faces of joints 1.5 to 6 m across, by 2.2 to 6.3 times (docs/rockmass.md, "Persistence and
#: spacing").
TRACE_DISAGREEMENT = 2.0


def rock_mass(
    points, labels, normals, set_labels, set_normals, up=(0.0, 0.0, 1.0), standard_errors=None, *, face=None, parts=None
) -> RockMass:
    """Spacing, persistence and intensity from labelled points, planes and their sets.

    Parameters
    ----------
    points : (N, 3) array
        The filtered cloud, local coordinates.
    labels : (N,) int array
        Each point's plane (-1 for none).
    normals : (P, 3) array
        The planes' normals, in the same coordinates.
    set_labels : (P,) int array
        Each plane's set (-1 for none).
    set_normals : (S, 3) array
        The sets' mean normals.
    up : (3,) array
        The cloud's up direction (the frame's), for strike and dip.
    standard_errors : (P,) array, optional
        The planes' normal standard errors (degrees), from which the correlated tilt is read
        (:func:`~geostructure.detect.uncertainty.correlated_tilt`).
    face : :class:`~geostructure.rockmass.exposure.Exposure`, optional
        ``exposure(points, up)``, when it was made already (it needs the points alone, so
        :func:`~geostructure.workflows.sets_and_mass.sets_and_rock_mass` makes it while the sets are found).
    parts : :class:`~geostructure.rockmass.face.FaceParts`, optional
        The face's ground and clutter the exposure ``face`` left out, recorded in the
        result; found here when ``face`` is not given.

    Returns
    -------
    RockMass
        Per set its scanlines, spacing, traces, P10, P21 and P32; per plane its traces; the
        face's parts, sections and the joints (``set_rows`` and ``summary`` give them as
        ``sets.csv`` and ``run.json`` hold them).

    Examples
    --------
    >>> from geostructure import measure
    >>> from geostructure.workflows.sets_and_mass import plane_sets
    >>> from geostructure.synthetic import outcrop_scene
    >>> scene = outcrop_scene(width=8.0, height=5.0, seed=5)
    >>> result = measure(scene.cloud)
    >>> sets = plane_sets(result.planes)
    >>> rock = rock_mass(result.filtered.local, result.labels, result.planes.normal, sets.labels, sets.mean_normal)
    >>> truth = [scene.set_spacing[np.abs(scene.set_normals @ m).argmax()] for m in sets.mean_normal]
    >>> bool(np.all(np.abs(rock.spacing / truth - 1) < 0.25))
    True
    """
    points = np.asarray(points, dtype=np.float64)
    labels = np.asarray(labels)
    normals = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    set_labels = np.asarray(set_labels)
    set_normals = np.asarray(set_normals, dtype=np.float64).reshape(-1, 3)
    if face is None:
        parts = face_parts(points, labels, normals, up)
        face = exposure(points, up, members=parts.members)
    moments = PlaneMoments.of(points, labels, len(normals))
    centroids = moments.centroid
    # A face that turns is measured section by section, each on its own mean face, and a
    # set's lines, traces and exposure pooled over them (docs/rockmass.md, "A face that turns").
    sections, exposures, point_section = section_exposures(points, face, up)
    plane_section = np.zeros(len(normals), dtype=np.int64)
    if point_section is not None:
        plane_section = face_sections_of(exposures, point_section, labels, len(normals))
    persistence = sectioned_persistence(points, labels, normals, exposures, plane_section, up)
    n_sets = len(set_normals)
    result = RockMass(persistence, float(sum(f.area for f in exposures)), set_labels)
    result.exposure_span = exposure_span(exposures)
    result.exposures = list(exposures)
    result.face_bend, result.face_sections, result.sections = face.bend, len(exposures), sections
    if parts is not None:
        result.ground, result.clutter, result.point_part = parts.ground, parts.clutter, parts.point_part
    result.p21, result.c13, result.c23 = np.zeros(n_sets), np.full(n_sets, np.nan), np.full(n_sets, np.nan)
    # The scanlines run over the face alone (not over the ground before it).
    on_face = [points if f.members is None else points[f.members] for f in exposures]
    uv = [f.project(p) for f, p in zip(exposures, on_face)]
    groups = []
    for s, mean in enumerate(set_normals):
        lines, trace_lines, lengths, crossing, facing = [], [], [], [], []
        for k, f in enumerate(exposures):
            members = np.flatnonzero((set_labels == s) & (plane_section == k))
            own = moments.subset(members)
            joint, joint_normal, joint_centre = joint_planes(own, normals[members])
            traces = joint_traces(own, joint, joint_normal, f.normal)
            lines.append(scanline_spacing(on_face[k], joint_normal, joint_centre, mean, f, uv[k]))
            # A set along the face (no line crosses it: bedding on a level exposure) shows its
            # planes, not traces: their extents are its size, in the plane table.
            if lines[-1].direction is not None:
                lengths.append(trace_lengths(traces, joint_centre, f))
                crossing.append(np.abs(normals[members] @ lines[-1].direction))
            along = lines[-1].direction is None
            groups.append((members, joint, s, k, joint_normal, traces.joint, None if along else lengths[-1]))
            trace_lines.append(scanline_spacing(on_face[k], joint_normal, joint_centre, mean, f, uv[k], traces))
            facing.append(np.sqrt(np.clip(1.0 - (normals[members] @ f.normal) ** 2, 0.0, 1.0)))
        result.scanlines.append(pooled_scanlines(lines))
        result.trace_scanlines.append(pooled_scanlines(trace_lines))
        along_face = not lengths
        pooled = TraceLengths.none() if along_face else TraceLengths.pooled(lengths)
        result.joint_trace_lengths.append(pooled)
        members = np.flatnonzero(set_labels == s)
        result.nearest_gaps.append(nearest_plane_gaps(normals, centroids, members, mean, persistence))
        # The joints' traces, not their facets' (with those, P32 read 0.37 to 1.09 of the truth).
        area = result.exposure_area
        result.p21[s] = pooled.length.sum() / area if area > 0 and not along_face else np.nan
        if len(members):
            if crossing and len(np.concatenate(crossing)):
                result.c13[s] = 1.0 / np.concatenate(crossing).mean()
            result.c23[s] = 1.0 / max(np.concatenate(facing).mean(), 1e-6)
    result.joints = Joints.of(len(normals), groups)
    if standard_errors is not None:
        along_pairs = {(set_id, section) for _, _, set_id, section, _, _, seen in groups if seen is None}
        read_correlated_tilt(result, normals, standard_errors, moments, along_pairs)
    return result


def read_correlated_tilt(result: RockMass, normals, standard_errors, moments, along: set) -> None:
    """The correlated tilt (:func:`~geostructure.detect.uncertainty.correlated_tilt`) into ``result``, read from
    the joints of the sets that cross the face. ``along``: the (set, section) pairs that lie
    along it, whose joints are pieces of the face itself: their facets follow the face's
    bends and undulations, its shape and not the cloud's errors. A drone survey's terrain read
    4.4 degrees from them, and every plane of it carried that (docs/rockmass.md)."""
    joints = result.joints
    assert joints is not None, "the joints are read before their tilt"
    members = joints.members()
    crossing = [m for m, s, k in zip(members, joints.set, joints.section) if (int(s), int(k)) not in along]
    result.correlated_tilt, result.correlated_tilt_n = correlated_tilt(normals, standard_errors, crossing, moments)
    if not result.correlated_tilt_n:
        result.tilt_facets_short = sum(len(j) for j in crossing if len(j) >= 3)
        result.tilt_facets_along = sum(len(j) for j in members if len(j) >= 3) - result.tilt_facets_short


def with_rock_mass(planes, sets, rock: RockMass | None):
    """The plane table (:class:`~geostructure.core.planes.Planes`) with its ``set`` column (from ``sets``, a
    :class:`~geostructure.rockmass.sets.JointSets`) and, with ``rock``, the traces, the censoring flag and the
    standard errors with the correlated tilt the joints show (``rock.plane_errors``)."""
    planes = planes.with_columns(set=sets.labels)
    if rock is None:
        return planes
    e = rock.plane_errors
    planes = replace(
        planes,
        normal_uncertainty_deg=e["normal"],
        dip_uncertainty_deg=e["dip"],
        dip_direction_uncertainty_deg=e["dip_direction"],
    )
    return planes.with_columns(**rock.plane_columns())
