"""A measured folder's kinematic analysis: the slope face, the tests, and their files.

:func:`add_kinematics` reads a folder ``measure`` wrote (with its sets when it has them),
fits the slope face to the cloud unless it is given, runs the tests of :mod:`.kinematics`
per plane, per pair of planes and per set, and adds ``kinematics.csv``, ``wedges.csv``,
``kinematics.json`` and ``kinematics.png`` to the folder as one set.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import ParameterError
from .exposure import face_bend, face_plane
from .face import face_members
from .io.atomic import write_columns_csv, write_figure, write_json, write_table_csv
from .io.crs import recorded_unit
from .io.outdir import KINEMATICS_FILES, REPORT_FILES, output_set
from .io.results import read_planes, read_sets
from .kinematic_summary import kinematics_of
from .kinematics import LATERAL_LIMIT, UNIT_WEIGHT, Slope
from .orientation import Frame, orientation_from_normals
from .planes import plane_rows
from .sections import FaceSections, face_sections
from .setnotes import bent_slope, gentle_slope, note_of, sectioned_slope, warn_of
from .stream.thin import read_measured
from .uncertainty import normal_standard_errors


@dataclass(frozen=True)
class FittedFace:
    """A slope fitted to a cloud: the whole face's plane (``slope``), and for a face that
    turns its ``sections`` (:mod:`.sections`) with each one's own fitted slope (``slopes``,
    in the sections' order; the whole face's alone for a face that does not turn).
    ``offset``: what the fitted points were relative to (a cloud's ``offset``)."""

    slope: Slope
    sections: FaceSections | None
    slopes: tuple[Slope, ...]
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def plane_sections(self, planes) -> np.ndarray:
        """The section each plane of a table lies in (its centroid's)."""
        if self.sections is None or len(self.slopes) == 1:
            return np.zeros(len(planes), dtype=np.int64)
        return self.sections.of(planes.centroid - np.asarray(self.offset))


def fit_face(
    points, frame: Frame = Frame(), members=None, bend: float | None = None, offset=None, sections=None
) -> FittedFace:
    """The slope of an outcrop cloud (:func:`fit_slope`), and for a face that turns, the
    slope of each of its sections (:func:`~.sections.face_sections`), each fitted to the
    points of its own section. ``members`` and ``bend`` as :func:`fit_slope` takes them;
    ``offset``: what ``points`` are relative to (a cloud's), for the planes' sections;
    ``sections``: the :class:`~.sections.FaceSections` of the same points, when the sets' rock
    mass cut them already.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> u, v = rng.random((2, 40_000)) * [[24.0], [6.0]]
    >>> arm = u > 12  # a cut dipping 70 degrees that turns a right angle half way along
    >>> x = np.where(arm, 12.0 + v * np.cos(np.radians(70)), u)
    >>> y = np.where(arm, 12.0 - u, v * np.cos(np.radians(70)))
    >>> face = fit_face(np.column_stack([x, y, v * np.sin(np.radians(70))]))
    >>> round(face.slope.dip), [(round(s.dip), round(s.dip_direction)) for s in face.slopes]
    (10, [(70, 180), (70, 270)])
    """
    points = np.asarray(points, dtype=np.float64)
    if members is not None:
        points = points[members]
    offset = tuple(np.zeros(3) if offset is None else np.asarray(offset, dtype=np.float64).reshape(3))
    slope = fit_slope(points, frame, bend=bend)
    if sections is None:
        sections = face_sections(points, frame.matrix[2], bend=slope.face_bend)
    if len(sections) == 1:
        return FittedFace(slope, sections, (slope,), offset)
    label = sections.of(points)
    slopes = tuple(fit_slope(points[label == k], frame) for k in range(len(sections)))
    return FittedFace(slope, sections, slopes, offset)


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


def add_kinematics(outdir, friction: float, **options):
    """Run the kinematic tests on a measured folder and add their files (see the module).
    ``options``: :func:`stage_kinematics`'s keywords, listed here.

    Parameters
    ----------
    outdir : str or Path
        A folder ``geostructure measure`` wrote.
    friction : float
        The joints' friction angle (degrees).
    slope : Slope or FittedFace, optional
        The slope face, one for all the planes; fitted to the cloud when not given
        (:func:`fit_face`), and then, on a face that turns, one for each of its sections,
        each plane tested against its own section's (as a :class:`FittedFace` given is).
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
    points : tuple, optional
        The measured points, when the caller holds them: positions relative to the planes'
        offset, each point's ``region_id`` and vegetation mark (or None), as
        :func:`~.io.results.read_regions` reads them from ``regions.ply`` otherwise.

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
    from .runs import redraw_report  # lazy: runs imports the report's modules when drawing

    with output_set(outdir, replace=False, rewrites=KINEMATICS_FILES + REPORT_FILES) as outputs:
        had_report = (outputs.outdir / "report.html").is_file()
        summary, paths = stage_kinematics(outputs, outputs.outdir, friction, **options)
        if had_report:  # the report's stereonet shows the envelopes: draw it again
            paths.update(redraw_report(outputs))
    return summary, paths


def stage_kinematics(
    outputs,
    source,
    friction: float,
    *,
    slope: Slope | None = None,
    lateral_limit: float = LATERAL_LIMIT,
    cohesion: float = 0.0,
    unit_weight: float = UNIT_WEIGHT,
    height: float | None = None,
    upper_slope: tuple[float, float] | None = None,
    progress=None,
    points: tuple | None = None,
):
    """The kinematic tests of the planes in ``source`` (a measured folder, or the staging
    folder of a set being written), their files written into the open set ``outputs``,
    which commits them with the rest of its files: one command, one commit (a refusal or an
    interrupt here leaves the folder as it was). The keywords are described under
    :func:`add_kinematics`; returns the summary and output kind -> final path."""
    from .runs import detected_spacing  # lazy, as above

    report = progress or (lambda stage, done, total: None)
    source = Path(source)
    frame = Frame.from_dict(outputs.record.get("frame") or {})
    planes = read_planes(source)
    strength = {"cohesion_kpa": float(cohesion), "unit_weight_kn_m3": float(unit_weight)}
    if slope is None or (cohesion and height is None):
        report("slope", 0, None)
        points, region, vegetation = points or read_measured(source, outputs.record, planes.offset)[:3]
        if slope is None:
            spacing = detected_spacing(outputs.record.get("detection"))
            labels = plane_rows(region, planes.region_id)
            slope = fit_face(points, frame, face_members(points, labels, planes.normal, frame.matrix[2],
                                                         spacing=spacing, vegetation=vegetation),
                             offset=planes.offset)  # fmt: skip
        if cohesion and height is None:  # the face's height: the cloud's, along up, in metres
            height = float(np.ptp(frame.to_enu(points)[:, 2])) * recorded_unit(outputs.record)["metres"]
            strength["height_source"] = "the cloud's height"
    if cohesion:
        strength["height_m"] = float(height)
        strength.setdefault("height_source", "given")
    face = slope if isinstance(slope, FittedFace) else FittedFace(slope, None, (slope,))
    if upper_slope is not None:
        gentlest = min(part.dip for part in face.slopes)  # of a face in sections, its gentlest
        if not upper_slope[0] < gentlest:
            raise ParameterError(
                f"the upper slope ({upper_slope[0]:g} deg) must dip less than the face ({gentlest:.1f} deg): "
                f"there is no crest otherwise."
            )
        strength["upper_slope_dip"], strength["upper_slope_dip_direction"] = map(float, upper_slope)
    report("kinematics", 0, None)
    # each plane tested against the slope of the section it lies in
    sections = (face.plane_sections(planes), face.slopes) if len(face.slopes) > 1 else None
    summary, rows, wedge_columns, figure = kinematics_of(
        planes, read_sets(source), face.slope, friction, lateral_limit, strength, sections
    )
    where = outputs.outdir
    warn_of(bent_slope(summary["slope"]), where)
    warn_of(gentle_slope(summary), where)
    note_of(sectioned_slope(summary), where)
    report("write", 0, None)
    write_table_csv(rows, outputs.path("kinematics.csv"), columns=KINEMATICS_COLUMNS)
    write_columns_csv({name: wedge_columns[name] for name in WEDGE_COLUMNS}, outputs.path("wedges.csv"))
    write_json(summary, outputs.path("kinematics.json"))
    # tight: the legend grows with the sets and their wedges
    write_figure(figure, outputs.path("kinematics.png").with_suffix(""), formats=("png",), dpi=120, bbox_inches="tight")
    outputs.record["kinematics"] = {k: summary[k] for k in ("slope", "friction_deg", "lateral_limit_deg", "strength")}
    names = {
        "kinematics": "kinematics.csv",
        "wedges": "wedges.csv",
        "kinematics_json": "kinematics.json",
        "kinematics_png": "kinematics.png",
    }
    return summary, {key: outputs.final(name) for key, name in names.items()}


KINEMATICS_COLUMNS = (
    "region_id",
    "set",
    "joint",
    "section",
    "dip",
    "dip_direction",
    "planar_sliding",
    "flexural_toppling",
    "planar_fs",
    "toppling_base",
    "oblique_toppling_base",
)
WEDGE_COLUMNS = ("region_id_a", "region_id_b", "section", "trend", "plunge", "wedge_fs", "slides_on")
