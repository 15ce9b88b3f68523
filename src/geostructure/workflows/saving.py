"""Saving a measurement and what is made from it (joint sets, report), each as one set.

These are the functions the command line calls after measuring, and a Python user can call
the same: every one writes through :func:`~geostructure.io.outdir.output_set`, so the
files of one call appear in the folder together or not at all, and what a call reads
from a folder is checked against the folder's manifest first.
"""

from __future__ import annotations

import os
import shutil
import warnings
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace
from pathlib import Path

import numpy as np

from geostructure.core.orientation import Frame
from geostructure.core.planes import Planes, plane_rows
from geostructure.core.threads import preload
from geostructure.detect.uncertainty import normal_standard_errors, with_correlated_tilt
from geostructure.errors import GeoStructureWarning
from geostructure.evaluation.scoring import Evaluation, stage_evaluation
from geostructure.io.atomic import write_table_csv
from geostructure.io.crs import in_metres, note_unstated_unit, recorded_unit
from geostructure.io.laz import add_point_sets
from geostructure.io.outdir import REPORT_FILES, SETS_FILES, OutputSet, output_set
from geostructure.io.results import read_planes, read_sets
from geostructure.io.writers import rewrite_regions_ply, write_plane_tables, write_result
from geostructure.reconstruct.georef import unscaled
from geostructure.rockmass.exposure import exposure
from geostructure.rockmass.face import face_parts
from geostructure.rockmass.mass import RockMass, rock_mass, with_rock_mass
from geostructure.rockmass.notes import note_bent_face, note_tilt_unread, note_vegetation, note_voxel_planes
from geostructure.rockmass.sets import JointSets, find_sets
from geostructure.rockmass.tables import rock_mass_tables, sets_record
from geostructure.stream.output import rewrite_regions_laz
from geostructure.stream.thin import FOLDER_ROWS, cell_point_sets, point_set_values, read_measured


def save_measurement(
    result,
    outdir,
    *,
    extra: dict | None = None,
    evaluation: Evaluation | None = None,
    evaluation_extra: dict | None = None,
    report: bool = False,
    max_points: int | None = None,
    inputs=(),
    sets=None,
    rock=None,
    point_files=True,
    then=None,
) -> dict[str, Path]:
    """Write a measurement's files, and optionally its evaluation and report, as one set.

    Parameters
    ----------
    result : Result
        What :func:`~geostructure.measure` found.
    outdir : str or Path
        The output folder; its previous GeoStructure set is replaced as a whole.
    extra : dict, optional
        More entries for ``run.json`` (the automatic choice, a reconstruction's record).
    evaluation : Evaluation, optional
        Scores against ground truth, written as ``evaluation.csv`` and ``evaluation.json``.
    report : bool
        Also write ``report.html``, the stereonet and the rose diagram.
    inputs : sequence of paths
        Files the run read: refused if they are among the outputs it would overwrite.
    sets : JointSets, optional
        The planes' joint sets (:func:`plane_sets`): a ``set`` column and ``sets.csv``.
    rock : RockMass, optional
        Their spacing, persistence and intensity (:func:`plane_rock_mass`), in ``sets.csv``,
        ``planes.csv`` and ``run.json``.
    point_files : bool or callable
        How ``regions.ply`` and ``regions.laz`` are written (:func:`~.io.writers.write_result`).
    then : callable, optional
        ``then(outputs)`` stages more files into the same set before the report (the
        kinematics of ``measure --kinematics``), reading the staged ones, and returns their
        paths: the set commits once, after it, or not at all.

    Returns
    -------
    dict
        Output kind -> final path.

    Examples
    --------
    >>> import tempfile
    >>> from geostructure import measure
    >>> from geostructure.synthetic import observatory_scene
    >>> result = measure(observatory_scene(30_000, seed=1).cloud)
    >>> paths = save_measurement(result, tempfile.mkdtemp())
    >>> sorted(paths)[:3]
    ['dips', 'planes', 'regions']
    """
    with output_set(outdir, inputs=inputs) as outputs:
        paths = write_result(result, outputs, extra, point_files=point_files, **written_sets(result, extra, sets, rock))
        if evaluation is not None:
            paths.update(stage_evaluation(outputs, evaluation, evaluation_extra))
        if then is not None:
            outputs.write_record()  # the staged set's readers read its record too
            paths.update(then(outputs))
        if report:
            outputs.write_record()
            paths.update(stage_report(outputs, outputs.staging, max_points))
    return paths


def written_sets(result, extra: dict | None, sets, rock) -> dict:
    """What :func:`~geostructure.io.writers.write_result` takes of the sets and rock mass:
    the plane table with their columns, the rock mass's tables (their sizes in metres, from
    the unit ``run.json`` will record) and the sets' record; nothing without sets."""
    if sets is None:
        return {"rock": rock}
    planes = with_rock_mass(result.planes, sets, rock)
    metres = recorded_unit({"crs": result.cloud.crs, **(extra or {})})["metres"]
    return {
        "planes": planes,
        "rock": rock,
        "tables": rock_mass_tables(planes, sets, rock, result.frame, metres),
        "sets_record": sets_record(sets, rock),
    }


def plane_sets(
    planes: Planes,
    frame: Frame = Frame(),
    n_sets: int | None = None,
    *,
    metres_per_unit: float = 1.0,
    leave_out=None,
) -> JointSets:
    """The joint sets of a plane table: poles weighted by area (:func:`~geostructure.rockmass.sets.find_sets`),
    the planes' centroids in metres (``metres_per_unit`` of the table's coordinates, as
    :func:`~.io.crs.metres_per_unit` reads it from the CRS) for the joints' metric tolerances.
    The planes ``leave_out`` marks (a boolean per plane: the ground and the clutter,
    :attr:`~geostructure.rockmass.face.FaceParts.off_face`) are clustered with no set and left in none.

    Examples
    --------
    >>> import numpy as np
    >>> from geostructure.synthetic import fisher_directions
    >>> rng = np.random.default_rng(0)
    >>> normals = np.vstack([fisher_directions(n, 60.0, 40, rng) for n in ([0, -0.7, 0.7], [0.9, 0, 0.4])])
    >>> sets = plane_sets(Planes(normal=normals, area=rng.uniform(0.1, 2.0, 80)))
    >>> len(sets), sets.n_planes.sum()
    (2, np.int64(80))
    """
    rows = np.arange(len(planes)) if leave_out is None else np.flatnonzero(~np.asarray(leave_out, dtype=bool))
    centroids = planes.local_centroid[rows] * metres_per_unit
    sets = find_sets(planes.normal[rows], planes.area[rows], n_sets=n_sets, frame=frame, centroids=centroids)
    if len(rows) < len(planes):
        labels = np.full(len(planes), -1)
        labels[rows] = sets.labels
        sets = replace(sets, labels=labels)
    return sets if metres_per_unit == 1.0 else replace(sets, area=sets.area * metres_per_unit**2)


def plane_rock_mass(
    points,
    labels,
    planes: Planes,
    sets: JointSets,
    frame: Frame = Frame(),
    *,
    face=None,
    parts=None,
    errors=None,
    metres_per_unit: float = 1.0,
    metric=None,
) -> RockMass:
    """Spacing, persistence and intensity of the sets of a plane table (:func:`~geostructure.rockmass.mass.rock_mass`).

    Parameters
    ----------
    points : (N, 3) array
        The labelled points, relative to ``planes.offset``.
    labels : (N,) int array
        Each point's plane (its row in ``planes``), -1 for none.
    planes : Planes
    sets : JointSets
        The planes' sets (:func:`plane_sets`).
    frame : Frame
        The run's frame, whose up gives strike and dip.
    face : :class:`~geostructure.rockmass.exposure.Exposure`, optional
        The points' exposure (in metres), when it was made already.
    parts : :class:`~geostructure.rockmass.face.FaceParts`, optional
        The face's ground and clutter (:func:`~geostructure.rockmass.face.face_parts`), with ``face``.
    errors : dict, optional
        The planes' block standard errors as measured (:meth:`~geostructure.core.planes.Planes.standard_errors`
        of a fresh :func:`~geostructure.measure`'s table). Without them they are computed
        again: a folder's table may carry a correlated tilt already, which must not be
        added twice.
    metres_per_unit : float
        Metres in one unit of ``points`` (:func:`~.io.crs.metres_per_unit`): the rock mass's
        lengths, areas and intensities are in metres, whatever the cloud's unit.
    metric : (N, 3) array, optional
        ``points`` in metres, when scaled already (the exposure's caller scales them once).
    """
    up = frame.matrix[2]
    if errors is None:
        errors = normal_standard_errors(points, labels, planes.normal, planes.local_centroid, planes.rect_u, up)
    metric = in_metres(points, metres_per_unit) if metric is None else metric
    rock = rock_mass(metric, labels, planes.normal, sets.labels, sets.mean_normal, up, errors["normal"], face=face,
                     parts=parts)  # fmt: skip
    rock.plane_errors = with_correlated_tilt(errors, rock.correlated_tilt, planes.normal, up)
    rock.metres_per_unit = float(metres_per_unit)
    return rock


def sets_and_rock_mass(
    points,
    labels,
    planes: Planes,
    frame: Frame = Frame(),
    n_sets: int | None = None,
    progress=None,
    *,
    errors=None,
    spacing: float | None = None,
    metres_per_unit: float = 1.0,
    vegetation=None,
) -> tuple[JointSets, RockMass]:
    """:func:`plane_sets`, then :func:`plane_rock_mass` (``errors`` as it takes them); the
    exposure's grid, which needs the points alone, is made in a thread meanwhile (its
    kd-tree and grid are numpy's and scipy's work, the sets' EM mostly Python's: on the
    0.7M-point outcrop the two overlap). ``progress(stage)`` is told each stage as it starts;
    ``spacing``, the points' spacing as the facet detector read it (:func:`detected_spacing`),
    spares the exposure reading it again. ``metres_per_unit``: as :func:`plane_rock_mass`
    takes it. ``vegetation``: the points the input classifies so, clutter
    (:func:`~geostructure.rockmass.face.face_parts`).

    Examples
    --------
    >>> from geostructure import measure
    >>> from geostructure.synthetic import outcrop_scene
    >>> result = measure(outcrop_scene(width=6.0, height=4.0, seed=1).cloud)
    >>> sets, rock = sets_and_rock_mass(result.filtered.local, result.labels, result.planes)
    >>> len(sets), len(rock.spacing)
    (3, 3)
    """
    report = progress or (lambda stage: None)
    report("sets")
    preload("scipy.ndimage")  # the exposure's thread imports it (threads.preload says why)
    with ThreadPoolExecutor(1) as pool:  # left only once the exposure is done, error or not
        f, metric = metres_per_unit, in_metres(points, metres_per_unit)  # one copy, for a cloud in feet
        # The face without the ground before it and the clutter (vegetation) on it.
        parts = face_parts(points, labels, planes.normal, frame.matrix[2], spacing=spacing, vegetation=vegetation)
        face = pool.submit(exposure, metric, frame.matrix[2], spacing=spacing and spacing * f, members=parts.members)
        # On rough rock, the planes of the face's own surface are no discontinuity either.
        leave_out = parts.off_face | (np.asarray(planes.extra.get("face_surface", 0)) > 0)
        sets = plane_sets(planes, frame, n_sets, metres_per_unit=f, leave_out=leave_out)
        report("spacing and persistence")
        rock = plane_rock_mass(points, labels, planes, sets, frame, face=face.result(), parts=parts, errors=errors,
                               metres_per_unit=f, metric=metric)  # fmt: skip
    return sets, rock


def detected_spacing(detection: dict | None) -> float | None:
    """The point spacing the facet detector read (a run's ``detection`` record), if it ran.

    Examples
    --------
    >>> detected_spacing({"facet_thresholds": {"spacing": 0.03}}), detected_spacing(None)
    (0.03, None)
    """
    spacing = ((detection or {}).get("facet_thresholds") or {}).get("spacing")
    return float(spacing) if spacing else None


def add_sets(outdir, *, n_sets: int | None = None, progress=None) -> tuple[JointSets, RockMass, dict[str, Path]]:
    """Find the joint sets of a measured folder and add them with their spacing, persistence
    and intensity: ``sets.csv``, and ``set``, trace and ``censored`` columns in ``planes.csv``
    (``set`` in ``planes_dips.csv`` and ``regions.laz``); a report there is drawn again.

    Parameters
    ----------
    outdir : str or Path
        A measured folder.
    n_sets : int, optional
        The number of sets; chosen by BIC when not given.
    progress : callable, optional
        ``progress(stage, done, total)``, called as each stage starts.

    Returns
    -------
    tuple
        The sets, their :class:`~geostructure.rockmass.mass.RockMass`, and output kind -> final path.

    Examples
    --------
    >>> import tempfile
    >>> from geostructure import measure
    >>> from geostructure.synthetic import outcrop_scene
    >>> out = tempfile.mkdtemp()
    >>> _ = save_measurement(measure(outcrop_scene(width=6.0, height=4.0, seed=1).cloud), out)
    >>> sets, rock, paths = add_sets(out)
    >>> len(sets), paths["sets"].name  # the outcrop's three joint sets
    (3, 'sets.csv')
    """
    report = progress or (lambda stage, done, total: None)
    reads = ("planes.csv", "regions.laz")  # both written again, with the sets: they must be this run's
    with output_set(outdir, replace=False, rewrites=SETS_FILES + REPORT_FILES, reads=reads) as outputs:
        frame = Frame.from_dict(outputs.record.get("frame") or {})
        had_report = (outputs.outdir / "report.html").is_file()
        report("read", 0, None)
        planes = read_planes(outputs.outdir)
        points, region, vegetation, cells = read_measured(outputs.outdir, outputs.record, planes.offset)
        labels, spacing = plane_rows(region, planes.region_id), detected_spacing(outputs.record.get("detection"))
        if unscaled(outputs.record):
            warnings.warn(
                f"{outdir}: the cloud's scale is the reconstruction's own (no control points, GPS or --scale), so "
                f"its spacings, traces, areas and intensities are in model units, not metres.",
                GeoStructureWarning,
                stacklevel=2,
            )
        if not outputs.record.get("unit") and not outputs.record.get("crs"):
            note_unstated_unit(spacing, outdir)
        sets, rock = sets_and_rock_mass(points, labels, planes, frame, n_sets, lambda name: report(name, 0, None),
                                        spacing=spacing, metres_per_unit=recorded_unit(outputs.record)["metres"],
                                        vegetation=vegetation)  # fmt: skip
        note_vegetation(vegetation, rock, outdir)
        note_voxel_planes((outputs.record.get("params") or {}).get("detector"), outdir)
        note_bent_face(rock.face_bend, outdir, rock.face_sections)
        note_tilt_unread(rock.tilt_facets_short, outdir, rock.tilt_facets_along)
        report("write", 0, None)
        planes = with_rock_mass(planes, sets, rock)
        staged = write_plane_tables(planes, outputs, outputs.record.get("crs"), outputs.record.get("enu_origin"))
        metres = recorded_unit(outputs.record)["metres"]
        for _, name, rows, columns in rock_mass_tables(planes, sets, rock, frame, metres):
            write_table_csv(rows, outputs.path(name), columns=columns)
        outputs.record["sets"] = sets_record(sets, rock)
        paths = {"sets": outputs.final("sets.csv"), "spacing": outputs.final("spacing.csv")}
        paths["joints"] = outputs.final("joints.csv")
        paths["planes"] = outputs.final("planes.csv")
        paths["dips"] = outputs.final("planes_dips.csv")
        if "planes.gpkg" in staged:
            paths.update(geojson=outputs.final("planes.geojson"), gpkg=outputs.final("planes.gpkg"))
        # The point files gain each point's set, joint and face part: regions.ply for a
        # CloudCompare that reads no LAS, regions.laz for the rest.
        rewrite_regions_ply(outputs.outdir / "regions.ply", outputs.path("regions.ply"),
                            point_set_values(outputs.outdir, planes, rock.point_part, cells), FOLDER_ROWS)  # fmt: skip
        paths["regions"] = outputs.final("regions.ply")
        if (outputs.outdir / "regions.laz").is_file():  # folders before 2026-12-02 have none
            if cells is None:
                add_point_sets(outputs.outdir / "regions.laz", outputs.path("regions.laz"), planes, rock.point_part)
            else:  # a thinned survey's: every point of it, chunk by chunk
                values = cell_point_sets(outputs.outdir, cells, planes, rock.point_part)
                rewrite_regions_laz(outputs.outdir / "regions.laz", outputs.path("regions.laz"), values, FOLDER_ROWS)
            paths["regions_laz"] = outputs.final("regions.laz")
        if had_report:  # the report shows the sets: draw it again from the new set of files
            paths.update(redraw_report(outputs))
    return sets, rock, paths


def redraw_report(outputs: OutputSet) -> dict[str, Path]:
    """Draw a folder's report again inside an open set (after its sets or kinematics change),
    from the staged files and the folder's kept ones together."""
    _link_kept(outputs)
    outputs.write_record()
    return stage_report(outputs, outputs.staging, None)


def _link_kept(outputs: OutputSet) -> None:
    """Put the folder's kept files beside the staged ones, for a reader of the whole set."""
    for name in outputs.kept:
        target = outputs.staging / name
        if not target.exists():
            try:
                os.link(outputs.outdir / name, target)
            except OSError:  # a file system without hard links
                shutil.copy2(outputs.outdir / name, target)


def add_report(outdir, *, max_points: int | None = None) -> dict[str, Path]:
    """Write ``report.html``, ``stereonet.png/.svg`` and ``rose.png`` for a measured folder.

    The folder is checked against its manifest first, so a report is never drawn from a
    mixture of two runs.

    Parameters
    ----------
    outdir : str or Path
        A folder written by :func:`save_measurement` (or ``geostructure measure``).
    max_points : int, optional
        Points drawn in the 3D view at most (default 100,000).

    Returns
    -------
    dict
        Output kind -> path of each file written (``report``, ``stereonet``, ``rose``).

    Examples
    --------
    >>> import tempfile
    >>> from geostructure import measure
    >>> from geostructure.synthetic import observatory_scene
    >>> out = tempfile.mkdtemp()
    >>> _ = save_measurement(measure(observatory_scene(30_000, seed=1).cloud), out)
    >>> sorted(p.name for p in add_report(out, max_points=5000).values())
    ['report.html', 'rose.png', 'stereonet.png', 'stereonet.svg']
    """
    with output_set(outdir, replace=False, rewrites=REPORT_FILES) as outputs:
        paths = stage_report(outputs, outputs.outdir, max_points)
    return paths


def stage_report(outputs: OutputSet, source: Path, max_points: int | None) -> dict[str, Path]:
    """Draw the report from the files in ``source`` (the staged set, or a verified folder)."""
    # Lazy on purpose: plotly and matplotlib (0.4 to 0.5 s to import here) load only when a report is asked for.
    from geostructure.report.html import build_report
    from geostructure.report.stereonet import rose_figure, save, stereonet_figure

    planes = read_planes(source)
    build_report(source, outputs.path("report.html"), max_points=max_points)
    sets = read_sets(source) if "set" in planes.extra else []
    labels = planes.extra.get("set")
    save(stereonet_figure(planes.strike, planes.dip, set_labels=labels, sets=sets)[0], outputs.staging / "stereonet")
    save(rose_figure(planes.strike, planes.dip)[0], outputs.staging / "rose", formats=("png",))
    return {
        "report": outputs.final("report.html"),
        "stereonet_png": outputs.final("stereonet.png"),
        "stereonet_svg": outputs.final("stereonet.svg"),
        "rose": outputs.final("rose.png"),
    }
