"""A measured folder scored against a ground-truth CSV: the evaluation files, as one set.

The scores themselves are :mod:`.evaluate`'s; this module reads the folder and the truth
through :func:`~geostructure.io.outdir.output_set` and writes what they give, with the
frame fitted to the truth first for an unreferenced cloud (:mod:`.framefit`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .evaluate import Evaluation, evaluate
from .framefit import fit_frame_to_truth, fitted_frame, pairwise_angle_error
from .io.outdir import EVALUATION_FILES, OutputSet, output_set
from .io.results import read_planes
from .io.truth import GroundTruth, read_truth
from .io.writers import write_evaluation_files
from .orientation import Frame
from .planes import Planes, reoriented


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
    >>> from geostructure.runs import save_measurement
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
        paths = stage_evaluation(outputs, evaluation, extra)
    return evaluation, extra, paths


def refit_frame(planes: Planes, truth: GroundTruth, frame: Frame, truth_path):
    """Planes and truth re-expressed in the frame fitted from the truth itself (see framefit)."""
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


def stage_evaluation(outputs: OutputSet, evaluation: Evaluation, extra: dict | None) -> dict[str, Path]:
    write_evaluation_files(evaluation, outputs.staging, extra)
    return {"evaluation_csv": outputs.final("evaluation.csv"), "evaluation_json": outputs.final("evaluation.json")}
