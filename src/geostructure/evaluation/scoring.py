"""A measured folder scored against a ground-truth CSV: the evaluation files, as one set.

The scores themselves are :mod:`.evaluate`'s; this module reads the folder and the truth
through :func:`~geostructure.io.outdir.output_set` and writes what they give, with the
frame fitted to the truth first for an unreferenced cloud (:mod:`.framefit`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from geostructure.core.orientation import Frame, normal_from_orientation
from geostructure.core.planes import Planes, reoriented
from geostructure.errors import InputError, ParameterError
from geostructure.evaluation.framefit import fit_frame_to_truth, fitted_frame, pairwise_angle_error
from geostructure.evaluation.groundtruth import Evaluation, evaluate
from geostructure.evaluation.mapcheck import MAX_ANGLE, MAX_DISTANCE, mapped_set_means, set_errors, validate
from geostructure.evaluation.tracescore import TOLERANCE as TRACE_TOLERANCE
from geostructure.evaluation.tracescore import (
    mapped_segments,
    null_segments,
    score_traces,
    set_trace_figures,
    trace_lines,
    window_figures,
)
from geostructure.io.atomic import write_json, write_table_csv
from geostructure.io.crs import recorded_unit
from geostructure.io.fieldmap import read_field_map, read_set_labels
from geostructure.io.outdir import EVALUATION_FILES, VALIDATION_FILES, OutputSet, output_set
from geostructure.io.results import read_planes, read_regions, read_traces
from geostructure.io.truth import GroundTruth, read_truth
from geostructure.io.writers import write_evaluation_files
from geostructure.rockmass.exposure import exposure


def add_evaluation(outdir, truth_path, *, fit_frame: bool = False) -> tuple[Evaluation, dict, dict[str, Path]]:
    """Score a measured folder against a ground-truth CSV and add the evaluation files.

    With ``fit_frame`` (an unreferenced cloud), the frame is first fitted to the truth
    planes and the scores are taken in that frame; the fit is returned and recorded.

    Parameters
    ----------
    outdir : str or Path
        A measured folder.
    truth_path : str or Path
        The ground-truth CSV (:mod:`geostructure.io.truth`).
    fit_frame : bool
        Fit the frame to the truth first (an SfM model without georeference).

    Returns
    -------
    evaluation, fit record (empty without ``fit_frame``), paths

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from geostructure import measure
    >>> from geostructure.workflows.saving import save_measurement
    >>> from geostructure.synthetic import observatory_scene
    >>> out = pathlib.Path(tempfile.mkdtemp())
    >>> _ = save_measurement(measure(observatory_scene(30_000, seed=1).cloud), out)
    >>> _ = (out.parent / "truth.csv").write_text("surface,dip,dip_direction\\nslope,40,89\\n")
    >>> evaluation, _, _ = add_evaluation(out, out.parent / "truth.csv")
    >>> evaluation.n_found
    1
    """
    with output_set(outdir, replace=False, rewrites=EVALUATION_FILES, inputs=[truth_path]) as outputs:
        frame = Frame.from_dict(outputs.record.get("frame") or {})
        planes = read_planes(outputs.outdir)
        truth = read_truth(truth_path, frame)
        extra, matched = {}, None
        if fit_frame:
            planes, truth, extra = refit_frame(planes, truth, frame, truth_path)
            matched = extra["frame_fit"]["matched_regions"]
        evaluation = evaluate(planes, truth, matched=matched)
        paths = write_evaluation_into(outputs, evaluation, extra)
    return evaluation, extra, paths


def refit_frame(planes: Planes, truth: GroundTruth, frame: Frame, truth_path):
    """Planes and truth re-expressed in the frame fitted from the truth itself (see framefit)."""
    # A rotation is fixed by two directions that are not parallel, in the truth and among
    # the planes both.
    for what, normals, count in (
        ("ground-truth planes", truth.normals, len(truth)),
        ("measured planes", planes.normal, len(planes)),
    ):
        if count < 2 or np.linalg.matrix_rank(np.asarray(normals).reshape(-1, 3), tol=1e-3) < 2:
            raise InputError(
                f"{truth_path}: --fit-frame needs two {what} or more that are not parallel (there are {count})."
            )
    order = np.argsort(-planes.n_points, kind="stable")
    fit = fit_frame_to_truth(planes.normal[order], truth.normals, candidates=30)
    fit.matched = order[fit.matched]
    new = fitted_frame(frame, fit)
    planes = reoriented(planes, new, frame)
    truth = read_truth(truth_path, new)
    pairwise = pairwise_angle_error(planes.normal[fit.matched], truth.normals)
    record = {
        "rotation_deg": fit.rotation_angle,
        "residuals_deg": fit.residuals.tolist(),
        "mean_residual_deg": fit.mean_residual,
        "matched_regions": fit.matched.tolist(),
        "pairwise_mean_deg": float(pairwise.mean()),
        "pairwise_max_deg": float(pairwise.max()),
        "frame_rotation": [list(r) for r in new.rotation],
    }
    return planes, truth, {"frame_fit": record}


def write_evaluation_into(outputs: OutputSet, evaluation: Evaluation, extra: dict | None) -> dict[str, Path]:
    write_evaluation_files(evaluation, outputs.staging, extra)
    return {"evaluation_csv": outputs.final("evaluation.csv"), "evaluation_json": outputs.final("evaluation.json")}


def add_validation(
    outdir,
    fractures,
    *,
    set_means=None,
    max_distance: float = MAX_DISTANCE,
    max_angle: float = MAX_ANGLE,
    fracture_sets=None,
) -> tuple[dict, dict[str, Path]]:
    """Score a measured folder against a field map (:mod:`.validation`'s rule) and add
    ``validation.csv`` (one row per mapped plane) and ``validation.json`` (the scores).

    Parameters
    ----------
    outdir : str or Path
        A measured folder (with ``sets.csv`` when the sets are to be scored).
    fractures : str or Path
        The field map (:mod:`geostructure.io.fieldmap`), in the cloud's coordinates.
    set_means : str or Path, optional
        Published set means (dip, dip_direction[, set] per row), scored against the
        measured sets as the field map's own ``set`` column is.
    max_distance, max_angle : float
        The rule's centroid distance (the cloud's unit) and angle (degrees).
    fracture_sets : str or Path, optional
        Each mapped fracture's set, row for row (DICE's ``set_labels.csv``), where the field
        map itself has no ``set`` column.

    With the discs' radii in the map (DICE's ``Radius``) and traces in the folder, the traces
    are scored too (:mod:`.tracescore`): fractures traced, trace precision, the null model's
    figures beside them, per set the found and mapped chords, and the fractures found by a
    plane or a trace.

    Returns
    -------
    the scores (as ``validation.json`` holds them), paths

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from geostructure import measure, save_measurement
    >>> from geostructure.synthetic import observatory_scene
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> result = measure(observatory_scene(40_000, seed=1).cloud)
    >>> _ = save_measurement(result, folder / "out")
    >>> row = result.planes.rows()[0]
    >>> _ = (folder / "map.csv").write_text("x,y,z,dip,dip_direction\\n" +
    ...     f"{row['centroid_x']},{row['centroid_y']},{row['centroid_z']},{row['dip']},{row['dip_direction']}\\n")
    >>> summary, paths = add_validation(folder / "out", folder / "map.csv")
    >>> summary["matched"], sorted(paths)
    (1, ['validation_csv', 'validation_json'])

    """
    if not (np.isfinite(max_distance) and max_distance > 0):
        raise ParameterError(f"--max-distance must be a positive distance, not {max_distance}.")
    if not (np.isfinite(max_angle) and 0 < max_angle <= 90):
        raise ParameterError(f"--max-angle must be more than 0 and at most 90 degrees, not {max_angle}.")
    inputs = [fractures] + [p for p in (set_means, fracture_sets) if p is not None]
    with output_set(outdir, replace=False, rewrites=VALIDATION_FILES, inputs=inputs) as outputs:
        mapped = read_field_map(fractures)
        if fracture_sets is not None:
            mapped = mapped.with_sets(read_set_labels(fracture_sets, len(mapped)))
        published = read_field_map(set_means, located=False) if set_means is not None else None
        planes = read_planes(outputs.outdir)
        if mapped.normals is not None:
            # A map that gives its normals (DICE's Nx, Ny, Nz) is compared in the cloud's own
            # axes, where the planes' normals are: no north, true or grid, comes between them
            normals = planes.normal / np.linalg.norm(planes.normal, axis=1, keepdims=True)
            map_normals = mapped.normals
        else:  # dip and dip direction against each other, both read from the same north
            o = planes.orientation
            normals = normal_from_orientation(o.dip_direction, o.dip)
            map_normals = normal_from_orientation(mapped.dip_direction, mapped.dip)
        found = validate(planes.centroid, normals, mapped.centres, map_normals,
                         max_distance=max_distance, max_angle=max_angle)  # fmt: skip
        measured_sets = _measured_set_normals(outputs.outdir)
        means = mapped_set_means(mapped.dip, mapped.dip_direction, mapped.sets)
        if published is not None:
            labels = [s or str(i + 1) for i, s in enumerate(published.sets)]
            means = mapped_set_means(published.dip, published.dip_direction, labels)
        summary = {
            "field_map": str(fractures),
            "max_distance": found.max_distance,
            "max_angle_deg": found.max_angle,
            "mapped": len(mapped),
            "matched": found.n_matched,
            "planes": len(planes),
            "planes_matching": int(found.useful.sum()),
            "precision": found.precision,
            "set_means_from": "published" if published is not None else "field map",
            "set_errors_deg": set_errors(means, measured_sets) if measured_sets is not None else None,
        }
        traced = None
        if mapped.radius is not None:
            traced, summary["traces"] = _trace_scores(outputs, mapped, map_normals, found, means, measured_sets)
        rows = [
            {"row": i + 2, "x": c[0], "y": c[1], "z": c[2], "dip": d, "dip_direction": dd, "set": s,
             "matched": int(m), "plane": int(p), "distance": dist, "angle_deg": a}
            for i, (c, d, dd, s, m, p, dist, a) in enumerate(zip(mapped.centres.tolist(), mapped.dip.tolist(),
                mapped.dip_direction.tolist(), mapped.sets, found.matched, found.plane, found.distance.tolist(),
                found.angle.tolist()))
        ]  # fmt: skip
        for row, hit in zip(rows, traced if traced is not None else ()):
            row["traced"] = int(hit)
        columns = VALIDATION_COLUMNS + (("traced",) if traced is not None else ())
        write_table_csv(rows, outputs.path("validation.csv"), columns=columns)
        write_json(summary, outputs.path("validation.json"))
        paths = {"validation_csv": outputs.final("validation.csv"), "validation_json": outputs.final("validation.json")}
    return summary, paths


#: ``validation.csv``'s columns: the mapped plane's row in its file, as given, and its match.
VALIDATION_COLUMNS = ("row", "x", "y", "z", "dip", "dip_direction", "set", "matched", "plane", "distance", "angle_deg")


def _trace_scores(outputs, mapped, map_normals, found, means, measured_sets) -> tuple[np.ndarray | None, dict]:
    """The traces' part of ``validation.json`` (see :func:`add_validation`), and each mapped
    fracture's traced flag (None without traces)."""
    read = read_traces(outputs.outdir)
    if read is None:
        return None, {"found": 0, "note": "no traces in this folder: measure it with --sets"}
    lines, trace_sets = read
    points, _, _ = read_regions(outputs.outdir)
    origin = points.mean(axis=0)  # scored about the cloud's middle: UTM's digits would eat the 5 cm
    points = points - origin
    tree = cKDTree(points)
    centres = mapped.centres - origin
    normals = map_normals
    metres = recorded_unit(outputs.record)["metres"]
    tolerance = TRACE_TOLERANCE / metres
    disc_lines = trace_lines(points, tree, centres, normals)
    local = [line - origin for line in lines]
    score = score_traces(local, centres, normals, mapped.radius, disc_lines, tolerance=tolerance)
    chords = np.array([np.linalg.norm(line[-1] - line[0]) for line in lines])
    null = score_traces(null_segments(points, tree, chords), centres, normals, mapped.radius, disc_lines,
                        tolerance=tolerance)  # fmt: skip
    either = found.matched | score.traced
    record = {
        "found": len(lines),
        "traced": score.n_traced,
        "trace_precision": score.precision,
        "null_traced": null.n_traced,
        "null_precision": null.precision,
        "found_by_plane_or_trace": int(either.sum()),
        "mapped_chord_median_m": float(np.median(2 * mapped.radius) * metres),
        "found_chord_median_m": float(np.median(chords) * metres) if len(chords) else float("nan"),
        "rule": f"60% of 11 samples within {TRACE_TOLERANCE:g} m of the disc's plane and its radius + "
        f"{TRACE_TOLERANCE:g} m of its centre, the chord within 15 degrees of its trace line",
    }
    if measured_sets is not None and means:
        figures = set_trace_figures(trace_sets, chords * metres, measured_sets, means, np.asarray(mapped.sets),
                                    2 * mapped.radius * metres)  # fmt: skip
        # The censoring-free estimates (circular windows), one set of windows for ours, the
        # map's and the null model's traces of each set.
        face = exposure(points * metres, np.asarray(outputs.record["frame"]["rotation"], dtype=np.float64)[2])
        segments = mapped_segments(centres, mapped.radius, disc_lines)
        nulls = null_segments(points, tree, chords)
        labels = np.asarray(mapped.sets)
        for label, figure in figures.items():
            ours = [line * metres for line, k in zip(local, trace_sets) if k == figure["measured_set"] >= 0]
            theirs = [line * metres for line, k in zip(segments, labels) if k == label]
            null_set = [line * metres for line, k in zip(nulls, trace_sets) if k == figure["measured_set"] >= 0]
            figure.update(window_figures(face, ours, theirs, null_set))
        record["sets"] = figures
    return score.traced, record


def _measured_set_normals(folder: Path) -> np.ndarray | None:
    """The measured sets' mean normals (ENU) from ``sets.csv``, or None without it."""
    path = Path(folder) / "sets.csv"
    if not path.is_file():
        return None
    table = np.genfromtxt(path, delimiter=",", names=True, usecols=("dip", "dip_direction"), ndmin=1)
    return normal_from_orientation(table["dip_direction"], table["dip"]).reshape(-1, 3)
