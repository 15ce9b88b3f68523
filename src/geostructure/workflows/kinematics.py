"""The kinematic tests run on a measured folder (or a set being staged), their files
written with it: ``geostructure kinematics`` and ``measure --kinematics``. The tests
themselves are :mod:`geostructure.kinematics`."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from geostructure.core.orientation import Frame
from geostructure.core.planes import plane_rows
from geostructure.errors import ParameterError
from geostructure.io.atomic import write_columns_csv, write_figure, write_json, write_table_csv
from geostructure.io.crs import recorded_unit
from geostructure.io.outdir import KINEMATICS_FILES, REPORT_FILES, output_set
from geostructure.io.results import read_planes, read_sets
from geostructure.io.thinned_folder import read_measured
from geostructure.kinematics.catalog import PLANE_TEST_COLUMNS
from geostructure.kinematics.modes import LATERAL_LIMIT, UNIT_WEIGHT, Slope
from geostructure.kinematics.slope import FittedFace, fit_face
from geostructure.kinematics.summary import kinematics_of
from geostructure.report.kinematics_plot import kinematics_result_figure
from geostructure.rockmass.face import face_members
from geostructure.rockmass.notes import bent_slope, gentle_slope, note_of, sectioned_slope, warn_of


def add_kinematics(outdir, friction: float, **options):
    """Run the kinematic tests on a measured folder and add their files (see the module).
    ``options``: :func:`write_kinematics_into`'s keywords, listed here.

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
        depend on it: see :func:`~geostructure.kinematics.modes.planar_factor_of_safety`.)
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
    >>> from geostructure.workflows.saving import save_measurement
    >>> from geostructure.synthetic import outcrop_scene
    >>> out = tempfile.mkdtemp()
    >>> _ = save_measurement(measure(outcrop_scene(width=6.0, height=4.0, seed=1).cloud), out)
    >>> summary, paths = add_kinematics(out, 30.0)
    >>> summary["slope"]["source"], sorted(paths)
    ('fitted', ['kinematics', 'kinematics_json', 'kinematics_png', 'wedges'])
    """
    from geostructure.workflows.saving import redraw_report  # lazy: runs imports the report's modules when drawing

    with output_set(outdir, replace=False, rewrites=KINEMATICS_FILES + REPORT_FILES) as outputs:
        had_report = (outputs.outdir / "report.html").is_file()
        summary, paths = write_kinematics_into(outputs, outputs.outdir, friction, **options)
        if had_report:  # the report's stereonet shows the envelopes: draw it again
            paths.update(redraw_report(outputs))
    return summary, paths


def write_kinematics_into(
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
    source = Path(source)
    planes = read_planes(source)
    record = outputs.record
    tested = kinematic_tests(
        planes, read_sets(source), friction, frame=Frame.from_dict(record.get("frame") or {}),
        detection=record.get("detection"), metres_per_unit=recorded_unit(record)["metres"],
        points=points or (lambda: read_measured(source, record, planes.offset)[:3]), slope=slope,
        lateral_limit=lateral_limit, cohesion=cohesion, unit_weight=unit_weight, height=height,
        upper_slope=upper_slope, progress=progress,
    )  # fmt: skip
    return tested.summary, write_kinematic_files(outputs, tested, progress)


def kinematic_tests(
    planes, sets: list, friction: float, *, frame: Frame, detection: dict | None, metres_per_unit: float,
    points, slope: Slope | FittedFace | None = None, lateral_limit: float = LATERAL_LIMIT, cohesion: float = 0.0,
    unit_weight: float = UNIT_WEIGHT, height: float | None = None, upper_slope: tuple[float, float] | None = None,
    progress=None,
):  # fmt: skip
    """The kinematic tests of ``planes`` and the ``sets``' rows (as ``sets.csv`` holds them),
    in memory: the slope fitted to the face where it is not given, the strength settled, each
    plane tested against its own section's slope. ``points``: the measured points (positions
    relative to the planes' offset, region ids, vegetation marks), or a function giving them,
    read only where the slope or the height is to be fitted; ``detection`` and
    ``metres_per_unit``: the run's detector record and unit. The other keywords are
    described under :func:`add_kinematics`. Returns the
    :class:`~geostructure.kinematics.summary.KinematicResult`."""
    from geostructure.workflows.sets_and_mass import detected_spacing  # lazy, as above

    report = progress or (lambda stage, done, total: None)
    strength: dict[str, float | str] = {"cohesion_kpa": float(cohesion), "unit_weight_kn_m3": float(unit_weight)}
    if slope is None or (cohesion and height is None):
        report("slope", 0, None)
        held, region, vegetation = points() if callable(points) else points
        if slope is None:
            labels = plane_rows(region, planes.region_id)
            slope = fit_face(held, frame, face_members(held, labels, planes.normal, frame.matrix[2],
                                                       spacing=detected_spacing(detection), vegetation=vegetation),
                             offset=planes.offset)  # fmt: skip
        if cohesion and height is None:  # the face's height: the cloud's, along up, in metres
            height = float(np.ptp(frame.to_enu(held)[:, 2])) * metres_per_unit
            strength["height_source"] = "the cloud's height"
    if cohesion:
        assert height is not None, "a height is given or read from the cloud above"
        strength["height_m"] = float(height)
        strength.setdefault("height_source", "given")
    assert slope is not None, "a slope is given or fitted above"
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
    return kinematics_of(planes, sets, face.slope, friction, lateral_limit, strength, sections)


def write_kinematic_files(outputs, tested, progress=None) -> dict:
    """The kinematic tests' files (``kinematics.csv``, ``wedges.csv``, ``kinematics.json``,
    ``kinematics.png``) written into the open set ``outputs``, what the slope tells said, and
    ``run.json``'s ``kinematics`` set; returns output kind -> final path."""
    summary, rows, wedge_columns = tested.summary, tested.rows, tested.wedge_columns
    where = outputs.outdir
    warn_of(bent_slope(summary["slope"]), where)
    warn_of(gentle_slope(summary), where)
    note_of(sectioned_slope(summary), where)
    (progress or (lambda stage, done, total: None))("write", 0, None)
    write_table_csv(rows, outputs.path("kinematics.csv"), columns=KINEMATICS_COLUMNS)
    write_columns_csv({name: wedge_columns[name] for name in WEDGE_COLUMNS}, outputs.path("wedges.csv"))
    write_json(summary, outputs.path("kinematics.json"))
    # tight: the legend grows with the sets and their wedges
    write_figure(
        kinematics_result_figure(tested),
        outputs.path("kinematics.png").with_suffix(""),
        formats=("png",),
        dpi=120,
        bbox_inches="tight",
    )
    outputs.record["kinematics"] = {k: summary[k] for k in ("slope", "friction_deg", "lateral_limit_deg", "strength")}
    names = {
        "kinematics": "kinematics.csv",
        "wedges": "wedges.csv",
        "kinematics_json": "kinematics.json",
        "kinematics_png": "kinematics.png",
    }
    return {key: outputs.final(name) for key, name in names.items()}


KINEMATICS_COLUMNS = (
    "region_id",
    "set",
    "joint",
    "section",
    "dip",
    "dip_direction",
    *PLANE_TEST_COLUMNS,
    "left_out",
)
WEDGE_COLUMNS = ("region_id_a", "region_id_b", "section", "trend", "plunge", "wedge_fs", "slides_on")
