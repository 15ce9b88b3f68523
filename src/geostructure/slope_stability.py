"""A measured folder's kinematic analysis: the slope face, the tests, and their files.

:func:`add_kinematics` reads a folder ``measure`` wrote (with its sets when it has them),
fits the slope face to the cloud unless it is given, runs the tests of :mod:`.kinematics`
per plane, per pair of planes and per set, and adds ``kinematics.csv``, ``wedges.csv``,
``kinematics.json`` and ``kinematics.png`` to the folder as one set.
"""

from __future__ import annotations

import numpy as np

from .errors import ParameterError
from .exposure import face_bend, face_plane
from .face import face_members
from .io.atomic import write_columns_csv, write_figure, write_json, write_table_csv
from .io.crs import recorded_unit
from .io.outdir import KINEMATICS_FILES, REPORT_FILES, output_set
from .io.results import read_planes, read_regions, read_sets
from .kinematics import (
    LATERAL_LIMIT,
    UNIT_WEIGHT,
    Slope,
    direct_toppling,
    flexural_toppling,
    percent_critical,
    planar_factor_of_safety,
    planar_sliding,
    wedges,
)
from .orientation import Frame, normal_from_orientation, orientation_from_normals
from .planes import plane_rows
from .setnotes import bent_slope, warn_of
from .uncertainty import normal_standard_errors

#: Pairs are tested among this many of the largest planes at most.
MAX_WEDGE_PLANES = 2000


def fit_slope(points, frame: Frame = Frame(), members=None, bend: float | None = None) -> Slope:
    """The overall face of an outcrop cloud: the least-squares plane of all its points (not
    its largest joint), with the standard errors of its dip and dip direction from a block
    regression over the whole face (:func:`~.uncertainty.normal_standard_errors`).
    ``members`` (:func:`~.face.face_members`) leaves the ground before or above the face and
    the clutter on it out (see :func:`~.exposure.exposure`). ``bend``: how far those points
    turn (:func:`~.exposure.face_bend`), when the sets' exposure measured it already.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> ab = rng.random((20_000, 2)) * [10.0, 5.0]
    >>> face = np.column_stack([ab[:, 0], ab[:, 1] * np.cos(np.radians(70)), ab[:, 1] * np.sin(np.radians(70))])  # rising north
    >>> slope = fit_slope(face + 0.01 * rng.standard_normal(face.shape))
    >>> round(slope.dip), round(slope.dip_direction), slope.source
    (70, 180, 'fitted')
    """
    points = np.asarray(points, dtype=np.float64)
    up = frame.matrix[2]
    if members is not None:
        points = points[members]
    # The plane alone: the exposure's occupancy grid (and the density read for it) is not needed.
    origin, normal, axes = face_plane(points, up)
    labels = np.zeros(len(points), dtype=np.int64)
    errors = normal_standard_errors(points, labels, normal[None, :], origin[None, :], axes[:1], up)
    o = orientation_from_normals(normal, frame)
    return Slope(
        float(o.dip[0]),
        float(o.dip_direction[0]),
        float(errors["dip"][0]),
        float(errors["dip_direction"][0]),
        "fitted",
        face_bend(points, up) if bend is None else float(bend),
    )


def add_kinematics(
    outdir,
    friction: float,
    *,
    slope: Slope | None = None,
    lateral_limit: float = LATERAL_LIMIT,
    cohesion: float = 0.0,
    unit_weight: float = UNIT_WEIGHT,
    height: float | None = None,
    upper_slope: tuple[float, float] | None = None,
    progress=None,
):
    """Run the kinematic tests on a measured folder and add their files (see the module).

    Parameters
    ----------
    outdir : str or Path
        A folder ``geostructure measure`` wrote.
    friction : float
        The joints' friction angle (degrees).
    slope : Slope, optional
        The slope face; fitted to the cloud (:func:`fit_slope`) when not given.
    lateral_limit : float
        Degrees either side of the slope's dip direction (of its opposite for toppling).
    cohesion : float
        The joints' cohesion (kPa), for the planar and wedge factors of safety; 0: frictional.
    unit_weight : float
        The rock's unit weight (kN/m3).
    height : float, optional
        The slope's height (m) for the planar and wedge blocks with cohesion; the cloud's height
        along up when not given.
    upper_slope : (dip, dip direction), optional
        The ground above the crest (degrees), for the wedges with cohesion; level when not
        given. It must dip less than the face. (A planar block's factor of safety does not
        depend on it: see :func:`~.kinematics.planar_factor_of_safety`.)
    progress : callable, optional
        ``progress(stage, done, total)``, called as each stage starts (the slope's fit, the
        tests, the files).

    Returns
    -------
    tuple
        The summary (what ``kinematics.json`` holds) and output kind -> final path.

    Examples
    --------
    >>> import tempfile
    >>> from geostructure import measure
    >>> from geostructure.runs import save_measurement
    >>> from geostructure.synthetic import outcrop_scene
    >>> out = tempfile.mkdtemp()
    >>> _ = save_measurement(measure(outcrop_scene(width=6.0, height=4.0, seed=1).cloud), out)
    >>> summary, paths = add_kinematics(out, 30.0)
    >>> summary["slope"]["source"], sorted(paths)
    ('fitted', ['kinematics', 'kinematics_json', 'kinematics_png', 'wedges'])
    """
    from .runs import detected_spacing, redraw_report  # lazy: runs imports the report's modules when drawing

    report = progress or (lambda stage, done, total: None)
    with output_set(outdir, replace=False, rewrites=KINEMATICS_FILES + REPORT_FILES) as outputs:
        frame = Frame.from_dict(outputs.record.get("frame") or {})
        had_report = (outputs.outdir / "report.html").is_file()
        planes = read_planes(outputs.outdir)
        strength = {"cohesion_kpa": float(cohesion), "unit_weight_kn_m3": float(unit_weight)}
        if slope is None or (cohesion and height is None):
            report("slope", 0, None)
            points, region, vegetation = read_regions(outputs.outdir, planes.offset)
            if slope is None:
                spacing = detected_spacing(outputs.record.get("detection"))
                labels = plane_rows(region, planes.region_id)
                slope = fit_slope(points, frame, face_members(points, labels, planes.normal, frame.matrix[2],
                                                              spacing=spacing, vegetation=vegetation))  # fmt: skip
            if cohesion and height is None:  # the face's height: the cloud's, along up, in metres
                height = float(np.ptp(frame.to_enu(points)[:, 2])) * recorded_unit(outputs.record)["metres"]
                strength["height_source"] = "the cloud's height"
        if cohesion:
            strength["height_m"] = float(height)
            strength.setdefault("height_source", "given")
        if upper_slope is not None:
            if not upper_slope[0] < slope.dip:
                raise ParameterError(
                    f"the upper slope ({upper_slope[0]:g} deg) must dip less than the face ({slope.dip:.1f} deg): "
                    f"there is no crest otherwise."
                )
            strength["upper_slope_dip"], strength["upper_slope_dip_direction"] = map(float, upper_slope)
        report("kinematics", 0, None)
        summary, rows, wedge_columns, figure = kinematics_of(
            planes, read_sets(outputs.outdir), slope, friction, lateral_limit, strength
        )
        warn_of(bent_slope(summary["slope"]), outdir)
        report("write", 0, None)
        write_table_csv(rows, outputs.path("kinematics.csv"), columns=KINEMATICS_COLUMNS)
        write_columns_csv({name: wedge_columns[name] for name in WEDGE_COLUMNS}, outputs.path("wedges.csv"))
        write_json(summary, outputs.path("kinematics.json"))
        write_figure(figure, outputs.path("kinematics.png").with_suffix(""), formats=("png",), dpi=120)
        outputs.record["kinematics"] = {
            k: summary[k] for k in ("slope", "friction_deg", "lateral_limit_deg", "strength")
        }
        names = {
            "kinematics": "kinematics.csv",
            "wedges": "wedges.csv",
            "kinematics_json": "kinematics.json",
            "kinematics_png": "kinematics.png",
        }
        paths = {key: outputs.final(name) for key, name in names.items()}
        if had_report:  # the report's stereonet shows the envelopes: draw it again
            paths.update(redraw_report(outputs))
    return summary, paths


KINEMATICS_COLUMNS = (
    "region_id",
    "set",
    "dip",
    "dip_direction",
    "planar_sliding",
    "flexural_toppling",
    "planar_fs",
    "toppling_base",
    "oblique_toppling_base",
)
WEDGE_COLUMNS = ("region_id_a", "region_id_b", "trend", "plunge", "wedge_fs", "slides_on")


def kinematics_of(
    planes, sets: list, slope: Slope, friction: float, lateral_limit: float = LATERAL_LIMIT, strength=None
):
    """The tests on a plane table and its sets' rows: (summary, plane rows, wedge columns,
    figure); ``strength`` holds the cohesion (kPa), unit weight and height for the planar
    and wedge factors of safety (frictional without it)."""
    from .report.kinematics_plot import kinematics_figure  # lazy: matplotlib

    dip, dd, area = planes.dip, planes.dip_direction, planes.area
    set_labels = planes.extra.get("set", np.full(len(planes), -1))
    planar = planar_sliding(dip, dd, slope, friction, lateral_limit)
    toppling = flexural_toppling(dip, dd, slope, friction, lateral_limit)
    strength = strength or {"cohesion_kpa": 0.0, "unit_weight_kn_m3": UNIT_WEIGHT}
    fs = planar_factor_of_safety(
        dip,
        friction,
        cohesion=strength["cohesion_kpa"],
        height=strength.get("height_m"),
        slope_dip=slope.dip,
        unit_weight=strength["unit_weight_kn_m3"],
    )
    tested = np.arange(min(len(planes), MAX_WEDGE_PLANES))  # the table is largest first
    block = {  # the wedges' strength and the block under the face, for their factors of safety
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
    pairs = w.pairs_tested
    ids = planes.region_id
    # The sets' mean planes tested as planes are: what a geologist reads off the set table.
    mean_wedges = wedges(
        np.array([r["dip"] for r in sets]), np.array([r["dip_direction"] for r in sets]), slope, friction, **block
    )
    rows = [
        {
            "region_id": int(ids[i]),
            "set": int(set_labels[i]),
            "dip": float(dip[i]),
            "dip_direction": float(dd[i]),
            "planar_sliding": bool(planar[i]),
            "flexural_toppling": bool(toppling[i]),
            "planar_fs": float(fs[i]) if planar[i] else float("nan"),
            "toppling_base": bool(base[i]),
            "oblique_toppling_base": bool(oblique_base[i]),
        }
        for i in range(len(planes))
    ]
    single, ids = np.asarray(w.single_plane), np.asarray(ids).astype(np.int64)
    wedge_columns = {  # columns, not a dict per pair: an outcrop's 1,500 planes make 240,000
        "region_id_a": ids[w.a],
        "region_id_b": ids[w.b],
        "trend": np.asarray(w.trend, dtype=np.float64),
        "plunge": np.asarray(w.plunge, dtype=np.float64),
        "wedge_fs": np.asarray(w.factor_of_safety, dtype=np.float64),
        "slides_on": np.where(single < 0, "both", ids[np.maximum(single, 0)].astype(str)),
    }
    wedge_area = np.zeros(len(planes))
    in_wedge = np.zeros(len(planes), dtype=bool)
    in_wedge[w.a], in_wedge[w.b] = True, True
    wedge_area[in_wedge] = area[in_wedge]

    def mode(critical):
        return {
            "planes": int(np.sum(critical)),
            "percent_by_count": percent_critical(critical),
            "percent_by_area": percent_critical(critical, np.nan_to_num(area)),
        }

    summary = {
        "slope": {
            "dip": slope.dip,
            "dip_direction": slope.dip_direction,
            "dip_uncertainty_deg": slope.dip_uncertainty,
            "dip_direction_uncertainty_deg": slope.dip_direction_uncertainty,
            "source": slope.source,
            **({"face_bend_deg": slope.face_bend} if slope.source == "fitted" else {}),
        },
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
        "planar_sliding": {
            **mode(planar),
            "min_fs": float(np.min(fs[planar])) if planar.any() else float("nan"),
            "median_fs": float(np.median(fs[planar])) if planar.any() else float("nan"),
        },
        "flexural_toppling": mode(toppling),
        "wedge_sliding": {
            **mode(in_wedge),
            "pairs_tested": int(pairs),
            "critical_pairs": int(len(w)),
            "planes_in_pairs": int(len(tested)),
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
        "sets": _set_summary(
            sets, mean_wedges, set_labels, planar, toppling, in_wedge, area, slope, friction, lateral_limit
        ),
        "set_mean_wedges": [
            {
                "sets": [int(sets[a]["set"]), int(sets[b]["set"])],
                "trend": float(t),
                "plunge": float(p),
                "wedge_fs": float(fs),
            }
            for a, b, t, p, fs in zip(
                mean_wedges.a, mean_wedges.b, mean_wedges.trend, mean_wedges.plunge, mean_wedges.factor_of_safety
            )
        ],
    }
    figure = kinematics_figure(
        dip, dd, slope=slope, friction=friction, lateral_limit=lateral_limit, planar=planar, toppling=toppling,
        wedge_lines=(w.trend, w.plunge), toppling_lines=(direct.trend, direct.plunge),
        oblique_lines=(direct.oblique_trend, direct.oblique_plunge),
        set_means=[(int(r["set"]), r["dip"], r["dip_direction"]) for r in sets],
        set_wedges=[(*wedge["sets"], wedge["trend"], wedge["plunge"]) for wedge in summary["set_mean_wedges"]],
    )  # fmt: skip
    return summary, rows, wedge_columns, figure


def _set_summary(
    sets, mean_wedges, set_labels, planar, toppling, in_wedge, area, slope, friction, lateral_limit
) -> list[dict]:
    """Per set: its mean's tests, the share of its planes critical per mode, and the wedges
    its mean forms with the other sets' means (``mean_wedges``, on the means in ``sets``'s order)."""
    if not sets:
        return []
    mean_dip = np.array([r["dip"] for r in sets])
    mean_dd = np.array([r["dip_direction"] for r in sets])
    mean_planar = planar_sliding(mean_dip, mean_dd, slope, friction, lateral_limit)
    mean_toppling = flexural_toppling(mean_dip, mean_dd, slope, friction, lateral_limit)
    w = mean_wedges
    direct = direct_toppling(mean_dip, mean_dd, slope, friction, lateral_limit)
    out = []
    for i, row in enumerate(sets):
        s = int(row["set"])
        members = set_labels == s
        weights = np.nan_to_num(area[members])

        def partners(a, b):  # the sets whose means pair with this one's in (a, b)
            return [int(sets[y if x == i else x]["set"]) for x, y in zip(a, b) if i in (x, y)]

        out.append(
            {
                "set": s,
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
                "planar_percent_by_count": percent_critical(planar[members]),
                "planar_percent_by_area": percent_critical(planar[members], weights),
                "toppling_percent_by_count": percent_critical(toppling[members]),
                "toppling_percent_by_area": percent_critical(toppling[members], weights),
                "wedge_percent_by_count": percent_critical(in_wedge[members]),
            }
        )
    return out
