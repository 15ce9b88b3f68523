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
from pathlib import Path

from geostructure.core.orientation import Frame
from geostructure.core.planes import plane_rows
from geostructure.errors import GeoStructureWarning
from geostructure.evaluation.scoring import Evaluation, write_evaluation_into
from geostructure.io.crs import note_unstated_unit, recorded_unit
from geostructure.io.exports import write_table
from geostructure.io.laz import add_point_sets
from geostructure.io.outdir import REPORT_FILES, SETS_FILES, OutputSet, output_set
from geostructure.io.results import read_grey, read_planes, read_sets
from geostructure.io.thinned_folder import FOLDER_ROWS, cell_point_sets, point_set_values, read_measured
from geostructure.io.writers import rewrite_regions_ply, write_plane_tables, write_result
from geostructure.reconstruct.georef import unscaled
from geostructure.rockmass.mass import RockMass, with_rock_mass
from geostructure.rockmass.notes import note_bent_face, note_tilt_unread, note_vegetation, note_voxel_planes
from geostructure.rockmass.sets import JointSets
from geostructure.rockmass.tables import rock_mass_tables, sets_record
from geostructure.stream.output import rewrite_regions_laz
from geostructure.workflows.sets_and_mass import detected_spacing, sets_and_rock_mass


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
    result : Measurement
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
            paths.update(write_evaluation_into(outputs, evaluation, evaluation_extra))
        if then is not None:
            outputs.write_record()  # the staged set's readers read its record too
            paths.update(then(outputs))
        if report:
            outputs.write_record()
            paths.update(write_report_into(outputs, outputs.staging, max_points))
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
                                        vegetation=vegetation,
                                        grey=read_grey(outputs.outdir) if cells is None else None)  # fmt: skip
        note_vegetation(vegetation, rock, outdir)
        note_voxel_planes((outputs.record.get("params") or {}).get("detector"), outdir)
        note_bent_face(rock.face_bend, outdir, rock.face_sections)
        note_tilt_unread(rock.tilt_facets_short, outdir, rock.tilt_facets_along)
        report("write", 0, None)
        planes = with_rock_mass(planes, sets, rock)
        staged = write_plane_tables(planes, outputs, outputs.record.get("crs"), outputs.record.get("enu_origin"),
                                    traces=rock.traces)  # fmt: skip
        metres = recorded_unit(outputs.record)["metres"]
        paths_of_traces = {}
        for kind, name, rows, columns in rock_mass_tables(planes, sets, rock, frame, metres):
            write_table(rows, outputs.path(name), columns=columns)
            if kind.startswith("trace"):
                paths_of_traces[kind] = outputs.final(name)
        outputs.record["sets"] = sets_record(sets, rock)
        paths = {"sets": outputs.final("sets.csv"), "spacing": outputs.final("spacing.csv")}
        paths["joints"] = outputs.final("joints.csv")
        paths.update(paths_of_traces)
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
    return write_report_into(outputs, outputs.staging, None)


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
        paths = write_report_into(outputs, outputs.outdir, max_points)
    return paths


def write_report_into(outputs: OutputSet, source: Path, max_points: int | None) -> dict[str, Path]:
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
