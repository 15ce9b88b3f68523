"""The kinematic tests of a plane table and its sets against a slope, as ``kinematics.json``,
``kinematics.csv`` and ``wedges.csv`` hold them, and what ``kinematics.png`` draws of each
section (:class:`KinematicPanel`; the report draws it, :mod:`geostructure.report.kinematics_plot`).

A face that turns (:mod:`.sections`) is tested section by section: each plane against the
slope of the section it lies in, pairs of planes within a section, the sets' means against
every section's slope. The summary's modes count the planes critical in their own section;
``sections`` holds each section's own summary.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from geostructure.core.orientation import Frame, drawn_azimuth, normal_from_orientation, orientation_from_normals
from geostructure.kinematics.modes import (
    LATERAL_LIMIT,
    UNIT_WEIGHT,
    DirectToppling,
    Slope,
    Wedges,
    direct_toppling,
    flexural_toppling,
    percent_critical,
    planar_factor_of_safety,
    planar_sliding,
    wedges,
)

#: Pairs are tested among this many of the largest planes at most (of each section).
MAX_WEDGE_PLANES = 2000


@dataclass
class _Tests:
    """One slope's tests on a plane table: per plane (``planar``, ``toppling``, ``fs``,
    ``base``, ``oblique_base``, ``in_wedge``), the critical pairs among the largest planes
    (``wedges``, ``direct``, their indices into the table) and the set means' wedges."""

    planar: np.ndarray
    toppling: np.ndarray
    fs: np.ndarray
    base: np.ndarray
    oblique_base: np.ndarray
    in_wedge: np.ndarray
    wedges: Wedges
    direct: DirectToppling
    mean_wedges: Wedges
    planes_in_pairs: int
    joint_wedges: Wedges | None = None  # among the joints' planes (joint_orientations), with the rock mass


@dataclass
class KinematicPanel:
    """What one section's stereonet shows: its planes' dips and dip directions, its slope,
    which planes are critical for planar sliding and for flexural toppling, the critical
    wedges' and direct toppling's lines (trend, plunge), the sets' means (set, dip, dip
    direction) and their critical wedges (set a, set b, trend, plunge), each pole's set."""

    dip: np.ndarray
    dip_direction: np.ndarray
    slope: Slope
    planar: np.ndarray
    toppling: np.ndarray
    wedge_lines: tuple
    toppling_lines: tuple
    oblique_lines: tuple
    set_means: list
    set_wedges: list
    pole_sets: np.ndarray | None = None


@dataclass
class KinematicResult:
    """The kinematic tests' results: the summary (as ``kinematics.json`` holds it), the plane
    rows (``kinematics.csv``), the wedge columns (``wedges.csv``), the settings and one
    :class:`KinematicPanel` a section of the face, for the figure."""

    summary: dict
    rows: list
    wedge_columns: dict
    friction: float
    lateral_limit: float
    panels: list = field(default_factory=list)


def slope_dict(slope: Slope) -> dict:
    """A slope as ``kinematics.json`` writes it."""
    return {
        "dip": slope.dip,
        "dip_direction": slope.dip_direction,
        "dip_uncertainty_deg": slope.dip_uncertainty,
        "dip_direction_uncertainty_deg": slope.dip_direction_uncertainty,
        "source": slope.source,
        **({"face_bend_deg": slope.face_bend} if slope.source == "fitted" else {}),
    }


def kinematics_of(
    planes, sets: list, slope: Slope, friction: float, lateral_limit: float = LATERAL_LIMIT, strength=None,
    sections=None,
):  # fmt: skip
    """The kinematic tests of a plane table against a slope: per plane, per pair of planes
    (wedges) and per set, section by section on a face that turns.

    Parameters
    ----------
    planes : Planes
        The plane table (with ``set`` and ``joint`` columns when the sets were found).
    sets : list of dict
        The sets' rows, as ``sets.csv`` holds them; [] for none.
    slope : Slope
        The slope face (the whole face's, for a face in sections).
    friction : float
        The joints' friction angle (degrees).
    lateral_limit : float
        Degrees either side of the slope's dip direction (of its opposite for toppling).
    strength : dict, optional
        ``cohesion_kpa``, ``unit_weight_kn_m3`` and ``height_m`` for the planar and wedge
        factors of safety; frictional and dry without it.
    sections : (labels, slopes), optional
        Each plane's section and each section's slope, for a face that turns.

    Returns
    -------
    KinematicResult
        The summary (as ``kinematics.json`` holds it), the plane rows and wedge columns (as
        ``kinematics.csv`` and ``wedges.csv`` hold them) and what the figure draws.

    Examples
    --------
    >>> from geostructure.core.planes import Planes
    >>> from geostructure.kinematics.modes import Slope
    >>> planes = Planes(normal=[[0.0, -0.5, 0.866], [0.0, 0.94, 0.342]], area=[2.0, 3.0])
    >>> tested = kinematics_of(planes, [], Slope(65.0, 180.0), 30.0)
    >>> tested.summary["planar_sliding"]["planes"], [r["flexural_toppling"] for r in tested.rows]
    (1, [False, True])
    """
    strength = strength or {"cohesion_kpa": 0.0, "unit_weight_kn_m3": UNIT_WEIGHT}
    everything = planes
    label, slopes = sections if sections is not None else (np.zeros(len(planes), dtype=np.int64), [slope])
    reason = left_out_reasons(planes)
    kept = np.flatnonzero(reason == "")
    planes, label = planes.subset(kept), np.asarray(label, dtype=np.int64)[kept]
    n = len(planes)
    planar, toppling, base, oblique_base, in_wedge = (np.zeros(n, dtype=bool) for _ in range(5))
    fs = np.full(n, np.nan)
    wedge_parts, parts, panels = [], [], []
    for k, part_slope in enumerate(slopes):
        members = np.flatnonzero(label == k)
        part = planes.subset(members)
        tests = _tests(part, sets, part_slope, friction, lateral_limit, strength)
        for full, mine in ((planar, tests.planar), (toppling, tests.toppling), (fs, tests.fs), (base, tests.base),
                           (oblique_base, tests.oblique_base), (in_wedge, tests.in_wedge)):  # fmt: skip
            full[members] = mine
        ids = np.asarray(part.region_id).astype(np.int64)
        wedge_parts.append(_wedge_columns(tests.wedges, ids, k))
        parts.append({"section": k, "slope": slope_dict(part_slope), "planes": len(members),
                      **_summary(part, sets, tests, part_slope, friction, lateral_limit)})  # fmt: skip
        panels.append(
            KinematicPanel(
                part.dip, part.dip_direction, part_slope, tests.planar, tests.toppling,
                wedge_lines=(tests.wedges.trend, tests.wedges.plunge),
                toppling_lines=(tests.direct.trend, tests.direct.plunge),
                oblique_lines=(tests.direct.oblique_trend, tests.direct.oblique_plunge),
                set_means=[(int(r["set"]), r["dip"], r["dip_direction"]) for r in sets],
                set_wedges=[(*w["sets"], w["trend"], w["plunge"]) for w in parts[-1]["set_mean_wedges"]],
                pole_sets=part.extra.get("set"),
            )
        )  # fmt: skip
    set_labels = planes.extra.get("set", np.full(n, -1))
    rows = _plane_rows(everything, kept, reason, np.asarray(sections[0]) if sections is not None else None,
                       planar, toppling, fs, base, oblique_base)  # fmt: skip
    wedge_columns = {key: np.concatenate([w[key] for w in wedge_parts]) for key in wedge_parts[0]}
    if len(parts) == 1:
        common = {key: value for key, value in parts[0].items() if key not in ("section", "slope", "planes")}
    else:
        common = _merged(parts, planes, set_labels, planar, toppling, fs, in_wedge)
    summary = {
        "slope": {**slope_dict(slope), **({"sections": len(parts)} if len(parts) > 1 else {})},
        "friction_deg": friction,
        "lateral_limit_deg": lateral_limit,
        "strength": {
            **strength,
            "wedge_fs": "with cohesion: the tetrahedral block under the face, "
            + ("its top the upper slope" if "upper_slope_dip" in strength else "level top")
            + " (Hoek & Bray 1981)"
            if strength["cohesion_kpa"]
            else "frictional",
        },
        "planes_tested": int(n),
        "left_out": {why: int((reason == why).sum()) for why in LEFT_OUT},
        **common,
        **({"sections": parts} if len(parts) > 1 else {}),
    }
    return KinematicResult(summary, rows, wedge_columns, friction, lateral_limit, panels)


#: Planes the kinematic tests leave out, by the column that marks them: no discontinuity can
#: slide or topple on them (the level ground, vegetation and debris, the face's own surface).
LEFT_OUT = ("ground", "clutter", "face_surface")


def left_out_reasons(planes) -> np.ndarray:
    """Per plane, why the kinematic tests leave it out ('' when tested): the first of
    :data:`LEFT_OUT` whose column marks it.

    Examples
    --------
    >>> from geostructure.core.planes import Planes
    >>> planes = Planes(normal=[[0, 0, 1.0]] * 3).with_columns(clutter=np.array([0, 1, 0]),
    ...                                                       face_surface=np.array([0, 0, 1]))
    >>> left_out_reasons(planes).tolist()
    ['', 'clutter', 'face_surface']
    """
    reason = np.full(len(planes), "", dtype=object)
    for why in reversed(LEFT_OUT):
        marked = np.asarray(planes.extra.get(why, np.zeros(len(planes))), dtype=np.float64) > 0
        reason[marked] = why
    return reason


def _plane_rows(planes, kept, reason, section, planar, toppling, fs, base, oblique_base) -> list[dict]:
    """``kinematics.csv``'s rows, one per plane of the table: the tested planes' results at
    ``kept``, the others with why they were left out."""
    n = len(planes)
    at = np.full(n, -1)
    at[kept] = np.arange(len(kept))
    set_labels = planes.extra.get("set", np.full(n, -1))
    joints = planes.extra.get("joint", np.full(n, -1))  # -1: no joint, or a folder from before them
    section = np.zeros(n, dtype=np.int64) if section is None else np.asarray(section, dtype=np.int64)
    rows = []
    for i in range(n):
        j = at[i]
        tested = j >= 0
        rows.append({
            "region_id": int(planes.region_id[i]),
            "set": int(set_labels[i]),
            "joint": int(joints[i]),
            "section": int(section[i]),
            "dip": float(planes.dip[i]),
            "dip_direction": float(planes.dip_direction[i]),
            "planar_sliding": bool(tested and planar[j]),
            "flexural_toppling": bool(tested and toppling[j]),
            "planar_fs": float(fs[j]) if tested and planar[j] else float("nan"),
            "toppling_base": bool(tested and base[j]),
            "oblique_toppling_base": bool(tested and oblique_base[j]),
            "left_out": str(reason[i]),
        })  # fmt: skip
    return rows


def _tests(planes, sets, slope: Slope, friction, lateral_limit, strength) -> _Tests:
    dip, dd = planes.dip, drawn_azimuth(planes.dip_direction)  # a level plane's blank: 0
    fs = planar_factor_of_safety(dip, friction, cohesion=strength["cohesion_kpa"], height=strength.get("height_m"),
                                 slope_dip=slope.dip, unit_weight=strength["unit_weight_kn_m3"])  # fmt: skip
    tested = np.arange(min(len(planes), MAX_WEDGE_PLANES))  # the table is largest first
    block = {  # the wedges' strength and the block under the face, for their factors of safety
        "lateral_limit": lateral_limit,
        "cohesion": strength["cohesion_kpa"],
        "height": strength.get("height_m"),
        "unit_weight": strength["unit_weight_kn_m3"],
        "upper_normal": normal_from_orientation(strength["upper_slope_dip_direction"], strength["upper_slope_dip"])
        if "upper_slope_dip" in strength
        else (0.0, 0.0, 1.0),
    }
    w = wedges(dip[tested], dd[tested], slope, friction, max_planes=MAX_WEDGE_PLANES, **block)
    direct = direct_toppling(dip[tested], dd[tested], slope, friction, lateral_limit, max_planes=MAX_WEDGE_PLANES)
    base = np.zeros(len(planes), dtype=bool)
    base[tested] = direct.base
    oblique_base = np.zeros(len(planes), dtype=bool)
    oblique_base[tested] = direct.oblique_base
    in_wedge = np.zeros(len(planes), dtype=bool)
    in_wedge[w.a], in_wedge[w.b] = True, True
    # The sets' mean planes tested as planes are: what a geologist reads off the set table.
    mean_wedges = wedges(
        np.array([r["dip"] for r in sets]), np.array([r["dip_direction"] for r in sets]), slope, friction, **block
    )
    joints = joint_orientations(planes)
    if joints is not None:  # the largest joints, as the largest planes (a 100M-point face held 3,753)
        joints = tuple(values[:MAX_WEDGE_PLANES] for values in joints)
    joint_wedges = None if joints is None else wedges(*joints, slope, friction, max_planes=MAX_WEDGE_PLANES, **block)
    return _Tests(
        planar_sliding(dip, dd, slope, friction, lateral_limit),
        flexural_toppling(dip, dd, slope, friction, lateral_limit),
        fs, base, oblique_base, in_wedge, w, direct, mean_wedges, len(tested), joint_wedges,
    )  # fmt: skip


def joint_orientations(planes) -> tuple[np.ndarray, np.ndarray] | None:
    """Dip and dip direction of each joint of a plane table's ``joint`` column: its facets'
    normals averaged by area (each turned to its largest facet's side), the plane its
    facets stand for; the joints the table holds, largest first. None without joints.

    Examples
    --------
    >>> from geostructure.core.planes import Planes
    >>> planes = Planes(normal=[[0, 0, 1.0], [0.02, 0, 1.0], [1.0, 0, 0.2]], area=[3.0, 1.0, 2.0])
    >>> dip, dd = joint_orientations(planes.with_columns(joint=np.array([0, 0, 1])))
    >>> np.round(dip, 2).tolist(), np.round(dd, 1).tolist()
    ([0.29, 78.69], [90.0, 90.0])
    """
    joint = planes.extra.get("joint")
    if joint is None:
        return None
    grouped = np.flatnonzero(np.asarray(joint) >= 0)
    if not len(grouped):
        return np.zeros(0), np.zeros(0)
    ids, j = np.unique(np.asarray(joint)[grouped], return_inverse=True)
    normal = normal_from_orientation(drawn_azimuth(planes.dip_direction[grouped]), planes.dip[grouped]).reshape(-1, 3)
    area = np.nan_to_num(np.asarray(planes.area, dtype=np.float64)[grouped])
    largest = np.full(len(ids), -1)
    order = np.lexsort((-area, j))
    first = np.ones(len(order), dtype=bool)
    first[1:] = j[order][1:] != j[order][:-1]
    largest[j[order][first]] = order[first]
    side = np.where(np.einsum("ij,ij->i", normal, normal[largest][j]) < 0, -1.0, 1.0)
    weighted = normal * (side * np.maximum(area, 1e-12))[:, None]
    mean = np.stack([np.bincount(j, weighted[:, a], len(ids)) for a in range(3)], axis=1)
    o = orientation_from_normals(mean, Frame(), outward=normal[largest])
    size = np.bincount(j, area, len(ids))
    by_size = np.argsort(-size, kind="stable")
    return o.dip[by_size], o.dip_direction[by_size]


def _wedge_columns(w: Wedges, ids: np.ndarray, section: int) -> dict:
    """Columns, not a dict per pair: an outcrop's 1,500 planes make 240,000."""
    single = np.asarray(w.single_plane)
    return {
        "region_id_a": ids[w.a],
        "region_id_b": ids[w.b],
        "section": np.full(len(w), section, dtype=np.int64),
        "trend": np.asarray(w.trend, dtype=np.float64),
        "plunge": np.asarray(w.plunge, dtype=np.float64),
        "wedge_fs": np.asarray(w.factor_of_safety, dtype=np.float64),
        "slides_on": np.where(single < 0, "both", ids[np.maximum(single, 0)].astype(str)),
    }


def _mode(critical, area, joint=None) -> dict:
    return {
        "planes": int(np.sum(critical)),
        "percent_by_count": percent_critical(critical),
        "percent_by_area": percent_critical(critical, np.nan_to_num(area)),
        **({} if joint is None else critical_joints(critical, area, joint)),
    }


def critical_joints(critical, area, joint) -> dict:
    """The joints (``joints.csv``) a failure mode takes: those whose critical facets hold half
    their facets' area or more, as the joint's own plane, their area-weighted mean, would
    test; and their share of the joints tested. A joint exposed as ten facets counts once.

    Examples
    --------
    >>> critical_joints(np.array([True, True, False, True]), np.array([1.0, 1.0, 3.0, 2.0]), np.array([0, 0, 0, 1]))
    {'joints': 1, 'percent_of_joints': 50.0}
    """
    joint = np.asarray(joint, dtype=np.int64)
    grouped = joint >= 0
    if not grouped.any():
        return {"joints": 0, "percent_of_joints": float("nan")}
    j, weight = joint[grouped], np.nan_to_num(np.asarray(area, dtype=np.float64)[grouped])
    n = int(j.max()) + 1
    total, taken = np.bincount(j, weight, n), np.bincount(j, weight * np.asarray(critical)[grouped], n)
    tested = np.bincount(j, minlength=n) > 0
    hit = tested & (taken >= 0.5 * total) & (taken > 0)
    return {"joints": int(hit.sum()), "percent_of_joints": float(100.0 * hit.sum() / tested.sum())}


#: A plane carries the headline factors of safety when it holds this many points or more: a
#: patch about ten spacings across, whatever the spacing (a 10-point plane of 0.01 m² on a
#: 3 cm cloud is a sliver, not a discontinuity to design against).
HEADLINE_POINTS = 100


def _planar(planar, fs, area, joint=None, n_points=None) -> dict:
    counted = n_points is not None and bool(np.any(np.asarray(n_points) > 0))  # 0: a table without counts
    large = planar & (np.asarray(n_points) >= HEADLINE_POINTS) if counted else planar
    return {
        **_mode(planar, area, joint),
        "min_fs": float(np.min(fs[large])) if large.any() else float("nan"),
        "median_fs": float(np.median(fs[large])) if large.any() else float("nan"),
        "headline_min_points": HEADLINE_POINTS if counted else 0,
        "headline_planes": int(large.sum()),
        "min_fs_any_size": float(np.min(fs[planar])) if planar.any() else float("nan"),
    }


def _summary(planes, sets, t: _Tests, slope, friction, lateral_limit) -> dict:
    """One slope's modes, sets and set means' wedges."""
    area, pairs, direct = planes.area, t.wedges.pairs_tested, t.direct
    set_labels = planes.extra.get("set", np.full(len(planes), -1))
    joint = planes.extra.get("joint")
    return {
        "planar_sliding": _planar(t.planar, t.fs, area, joint, planes.n_points),
        "flexural_toppling": _mode(t.toppling, area, joint),
        "wedge_sliding": {
            **_mode(t.in_wedge, area, joint),
            "pairs_tested": int(pairs),
            "critical_pairs": int(len(t.wedges)),
            "planes_in_pairs": int(t.planes_in_pairs),
            **(
                {}
                if t.joint_wedges is None
                else {
                    "joint_pairs_tested": int(t.joint_wedges.pairs_tested),
                    "critical_joint_pairs": int(len(t.joint_wedges)),
                }
            ),
        },
        "direct_toppling": {
            "critical": direct.critical,
            "intersections_in_zone": int(len(direct.a)),
            "percent_of_pairs": 100.0 * len(direct.a) / pairs if pairs else float("nan"),
            "base_planes": int(direct.base.sum()),
            "sliding_base_planes": int(direct.sliding_base.sum()),
            "oblique": {  # Dips' secondary zone: steep columns outside the lateral limits
                "critical": direct.oblique_critical,
                "intersections_in_zone": int(len(direct.oblique_a)),
                "percent_of_pairs": 100.0 * len(direct.oblique_a) / pairs if pairs else float("nan"),
                "base_planes": int(direct.oblique_base.sum()),
            },
        },
        "sets": _set_summary(sets, t, set_labels, area, slope, friction, lateral_limit),
        "set_mean_wedges": [
            {
                "sets": [int(sets[a]["set"]), int(sets[b]["set"])],
                "trend": float(tr),
                "plunge": float(p),
                "wedge_fs": float(f),
            }
            for a, b, tr, p, f in zip(
                t.mean_wedges.a,
                t.mean_wedges.b,
                t.mean_wedges.trend,
                t.mean_wedges.plunge,
                t.mean_wedges.factor_of_safety,
            )
        ],  # fmt: skip
    }


def _shares(members, planar, toppling, in_wedge, area) -> dict:
    """The share of a set's planes critical in each mode."""
    weights = np.nan_to_num(area[members])
    return {
        "planar_percent_by_count": percent_critical(planar[members]),
        "planar_percent_by_area": percent_critical(planar[members], weights),
        "toppling_percent_by_count": percent_critical(toppling[members]),
        "toppling_percent_by_area": percent_critical(toppling[members], weights),
        "wedge_percent_by_count": percent_critical(in_wedge[members]),
    }


def _set_summary(sets, t: _Tests, set_labels, area, slope, friction, lateral_limit) -> list[dict]:
    """Per set: its mean's tests, the share of its planes critical per mode, and the wedges
    its mean forms with the other sets' means (``t.mean_wedges``, on the means in ``sets``'s order)."""
    if not sets:
        return []
    mean_dip = np.array([r["dip"] for r in sets])
    mean_dd = np.array([r["dip_direction"] for r in sets])
    mean_planar = planar_sliding(mean_dip, mean_dd, slope, friction, lateral_limit)
    mean_toppling = flexural_toppling(mean_dip, mean_dd, slope, friction, lateral_limit)
    w = t.mean_wedges
    direct = direct_toppling(mean_dip, mean_dd, slope, friction, lateral_limit)
    out = []
    for i, row in enumerate(sets):

        def partners(a, b):  # the sets whose means pair with this one's in (a, b)
            return [int(sets[y if x == i else x]["set"]) for x, y in zip(a, b) if i in (x, y)]

        out.append(
            {
                "set": int(row["set"]),
                "mean_dip": float(mean_dip[i]),
                "mean_dip_direction": float(mean_dd[i]),
                "mean_planar_sliding": bool(mean_planar[i]),
                "mean_flexural_toppling": bool(mean_toppling[i]),
                "mean_wedges_with_sets": partners(w.a, w.b),
                "mean_toppling_blocks_with_sets": partners(direct.a, direct.b) if direct.base.any() else [],
                "mean_toppling_base": bool(direct.base[i]),
                "mean_oblique_toppling_blocks_with_sets": partners(direct.oblique_a, direct.oblique_b)
                if direct.oblique_critical
                else [],
                **_shares(set_labels == int(row["set"]), t.planar, t.toppling, t.in_wedge, area),
            }
        )
    return out


def _merged(parts: list[dict], planes, set_labels, planar, toppling, fs, in_wedge) -> dict:
    """The sections' summaries as one: each plane critical in its own section, the pairs
    and intersections of every section, a set's mean critical where it is in any section."""
    area = planes.area

    def total(key, field, sub=None):
        return sum((p[key][sub] if sub else p[key])[field] for p in parts)

    pairs = total("wedge_sliding", "pairs_tested")
    zone, oblique = (
        total("direct_toppling", "intersections_in_zone"),
        total("direct_toppling", "intersections_in_zone", "oblique"),
    )
    merged_sets = []
    for i, row in enumerate(parts[0]["sets"]):
        rows = [p["sets"][i] for p in parts]
        flags = ("mean_planar_sliding", "mean_flexural_toppling", "mean_toppling_base")
        lists = ("mean_wedges_with_sets", "mean_toppling_blocks_with_sets", "mean_oblique_toppling_blocks_with_sets")
        merged_sets.append({
            **{key: row[key] for key in ("set", "mean_dip", "mean_dip_direction")},
            **{key: any(r[key] for r in rows) for key in flags},
            **{key: sorted({s for r in rows for s in r[key]}) for key in lists},
            "mean_critical_in_sections": [p["section"] for p, r in zip(parts, rows) if _mean_critical(r)],
            **_shares(set_labels == int(row["set"]), planar, toppling, in_wedge, area),
        })  # fmt: skip
    joint = planes.extra.get("joint")
    return {
        "planar_sliding": _planar(planar, fs, area, joint, planes.n_points),
        "flexural_toppling": _mode(toppling, area, joint),
        "wedge_sliding": {
            **_mode(in_wedge, area, joint),
            "pairs_tested": int(pairs),
            "critical_pairs": int(total("wedge_sliding", "critical_pairs")),
            "planes_in_pairs": int(total("wedge_sliding", "planes_in_pairs")),
            **(
                {}
                if "joint_pairs_tested" not in parts[0]["wedge_sliding"]
                else {
                    "joint_pairs_tested": int(total("wedge_sliding", "joint_pairs_tested")),
                    "critical_joint_pairs": int(total("wedge_sliding", "critical_joint_pairs")),
                }
            ),
        },
        "direct_toppling": {
            "critical": any(p["direct_toppling"]["critical"] for p in parts),
            "intersections_in_zone": int(zone),
            "percent_of_pairs": 100.0 * zone / pairs if pairs else float("nan"),
            "base_planes": int(total("direct_toppling", "base_planes")),
            "sliding_base_planes": int(total("direct_toppling", "sliding_base_planes")),
            "oblique": {
                "critical": any(p["direct_toppling"]["oblique"]["critical"] for p in parts),
                "intersections_in_zone": int(oblique),
                "percent_of_pairs": 100.0 * oblique / pairs if pairs else float("nan"),
                "base_planes": int(total("direct_toppling", "base_planes", "oblique")),
            },
        },
        "sets": merged_sets,
        "set_mean_wedges": [{**w, "section": p["section"]} for p in parts for w in p["set_mean_wedges"]],
    }


def _mean_critical(row: dict) -> bool:
    """A set's mean slides, topples or forms a critical wedge or toppling block."""
    return bool(row["mean_planar_sliding"] or row["mean_flexural_toppling"] or row["mean_wedges_with_sets"]
                or row["mean_toppling_blocks_with_sets"])  # fmt: skip
