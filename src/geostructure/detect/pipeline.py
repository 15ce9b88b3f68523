"""The measuring pipeline: filter -> voxel fit -> region growing (and coplanar merge) -> region
planes -> orientation."""

from __future__ import annotations

import time
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np

from geostructure.core.bounds import column_max, column_min, first_bad_coordinates
from geostructure.core.cloud import MAX_COORDINATE, Cloud
from geostructure.core.density import point_spacing
from geostructure.core.orientation import Frame, Orientation, face_side, orientation_from_normals, upward
from geostructure.core.params import Params
from geostructure.core.planes import Planes
from geostructure.detect.facets import MAX_CELL_SCATTER
from geostructure.detect.filter import FilterResult, filter_outliers
from geostructure.detect.regionplanes import absorb_sparse_facets, region_planes, without_ribbons
from geostructure.detect.registry import detector_spec, facet_min_points
from geostructure.detect.roughfacets import FACE_CONE, MIN_FACET_POINTS, mean_directions
from geostructure.detect.surveyplanes import on_survey_planes, survey_min_points, whole_facets
from geostructure.detect.uncertainty import normal_standard_errors
from geostructure.detect.voxel import VoxelPlanes, fit_voxels, voxel_edge
from geostructure.errors import InputError, ParameterError

STAGES = ("filter", "voxel", "regions", "planes", "orientation")


@dataclass
class Measurement:
    """What a run found.

    ``planes`` is the plane table (:class:`~geostructure.core.planes.Planes`), largest first and numbered
    0, 1, ... in that order, with normals pointing upward in ``frame`` and centroids in the
    input's own coordinates; ``labels`` gives each filtered point its plane's number or -1,
    and ``voxel_labels`` each voxel plane's.

    Parameters
    ----------
    cloud, filtered : Cloud
        The input, and the points the outlier filter kept.
    params : Params
    frame : Frame
    filter_result : FilterResult
    voxels : VoxelPlanes
    voxel_labels : (V,) int array
    planes : Planes
    labels : (N,) int array
        Per filtered point.
    seconds, counts : dict
        Seconds per stage; points, voxels, regions and planes counted after each.
    detection : dict
        What the facet detector read from the cloud (its thresholds), for ``run.json``.

    Examples
    --------
    >>> from geostructure.synthetic import observatory_scene
    >>> result = measure(observatory_scene(30_000, seed=2).cloud)
    >>> bool(result.labels.max() == len(result) - 1), result.planes.centroid.shape[1]
    (True, 3)
    """

    cloud: Cloud
    params: Params
    frame: Frame
    filtered: Cloud
    filter_result: FilterResult
    voxels: VoxelPlanes
    voxel_labels: np.ndarray
    planes: Planes
    labels: np.ndarray
    seconds: dict = field(default_factory=dict)
    counts: dict = field(default_factory=dict)
    detection: dict = field(default_factory=dict)  # what the detector read from the cloud

    # Shorthands for the plane table's columns, which the API's users reach for most.
    @property
    def normals(self) -> np.ndarray:
        return self.planes.normal

    @property
    def centroids(self) -> np.ndarray:
        return self.planes.centroid

    @property
    def orientation(self) -> Orientation:
        return self.planes.orientation

    def __len__(self) -> int:
        return len(self.planes)


def check_measurable(cloud: Cloud) -> None:
    """Refuse clouds no plane can be measured in: not a Cloud, NaN, too few points, one spot, one line."""
    if not isinstance(cloud, Cloud):
        raise ParameterError(
            f"measure needs a Cloud (Cloud.from_points(array) for an (N, 3) array, or "
            f"read_cloud(path)), not {type(cloud).__name__}."
        )
    if len(cloud) == 0:
        raise InputError(f"{cloud.source}: holds 0 point(s); a plane needs at least 3.")
    problem = first_bad_coordinates(cloud.local, MAX_COORDINATE)
    if problem is not None and problem[0] == "not finite":
        raise InputError(
            f"{cloud.source}: {problem[1]:,} point(s) have NaN or infinite coordinates (the first is point number "
            f"{problem[2] + 1:,}, counting from 1)."
        )
    if len(cloud) < 3:
        raise InputError(f"{cloud.source}: holds {len(cloud)} point(s); a plane needs at least 3.")
    if problem is not None:
        raise InputError(
            f"{cloud.source}: a coordinate lies beyond {MAX_COORDINATE:.0e} of the cloud's centre, which "
            f"no survey uses; the data may be damaged."
        )
    extent = column_max(cloud.local) - column_min(cloud.local)
    if extent.max() <= 0:
        raise InputError(f"{cloud.source}: all points lie at one spot; there is no plane to measure.")
    if (
        np.linalg.matrix_rank(
            np.cov(cloud.local[:: max(1, len(cloud) // 100_000)], rowvar=False), tol=1e-12 * extent.max() ** 2
        )
        < 2
    ):
        raise InputError(f"{cloud.source}: all points lie on one line; there is no plane to measure.")


def measure(
    cloud: Cloud, params: Params = Params(), frame: Frame = Frame(), progress=None, *, moments=None, facets=None
) -> Measurement:
    """Find the planar regions of a cloud and measure their strike, dip and dip direction.

    Parameters
    ----------
    cloud : Cloud
    params : Params
    frame : Frame
        Which way east, north and up point in the cloud.
    progress : callable, optional
        ``progress(stage, done, total)``, called as the work goes on.
    moments : :class:`~geostructure.detect.voxel.CloudMoments`, optional
        The cloud's voxel moments at ``params.zeta``, as :func:`~geostructure.detect.auto.choose_params`
        keeps them (``AutoChoice.moments``): the local filter then does not sum them again.
    facets : callable, optional
        ``facets(filtered, keep, progress)``, the facet detection of the filtered cloud
        (a :class:`~geostructure.detect.facets.FacetDetection`) found elsewhere, given the
        filtered cloud and the filter's decisions: a survey larger than memory, measured on
        a thinned cloud, has its facets found on every point, in tiles
        (:meth:`~geostructure.stream.thinnedsurvey.ThinnedSurvey.full_resolution_facets`).

    Returns
    -------
    Measurement
        The plane table (``planes``), each filtered point's region (``labels``), the
        parameters and frame used, the counts and the stages' seconds.

    Examples
    --------
    >>> from geostructure.synthetic import observatory_scene
    >>> scene = observatory_scene(n_points=60_000, seed=1)
    >>> result = measure(scene.cloud)
    >>> len(result) >= 6
    True
    """
    report = progress or (lambda stage, done, total: None)
    seconds: dict[str, float] = {}
    counts = {"input": len(cloud)}
    check_measurable(cloud)

    with _stage(seconds, "filter", report):
        edge = voxel_edge(cloud.local, params.zeta)
        filt = filter_outliers(cloud.local, params.filter, edge=edge, threshold=params.filter_sigma, moments=moments)
        filtered = cloud.subset(filt.keep)
        counts["filtered"] = len(filtered)
    if len(filtered) < 3:
        raise ParameterError(f"{cloud.source}: the outlier filter left {len(filtered)} point(s); try `filter='none'`.")

    with _stage(seconds, "voxel", report):
        voxels = fit_voxels(
            filtered.local, params.zeta, min_points=params.min_voxel_points, max_curvature=params.max_curvature
        )
        counts["voxel_planes"] = len(voxels)

    with _stage(seconds, "regions"):  # each detector announces the stage and its progress
        growth = detector_spec(params.detector).grow(filtered, voxels, params, report, counts, facets, filt.keep)
    point_region, region_of_voxel, facet_record = growth.point_region, growth.region_of_voxel, growth.facet_record
    facet_region, envelope, found = growth.facet_region, growth.envelope, growth.found

    with _stage(seconds, "planes"):
        # Facets grown on the points need min_points only; regions grown over voxel planes
        # (all of them with the voxel detector) also need 3 voxels and the detector's own
        # size rule: the facet detector's holds whatever the cloud's size (0.1% of the points
        # lost a sixth of an outcrop's planes inside a survey of four copies of it).
        n_facets = facet_record.get("planar_facets", 0)
        n_regions = max(int(region_of_voxel.max(initial=-1)), int(point_region.max(initial=-1))) + 1
        is_facet = np.zeros(n_regions, dtype=bool)
        is_facet[: len(facet_region)] = facet_region[:n_regions]
        rough = envelope is not None  # the facets were grown on rough rock's own points
        facet_rule = params.min_points or (MIN_FACET_POINTS if rough else facet_min_points(len(filtered)))
        region_rule = params.min_points or detector_spec(params.detector).default_min_points(len(filtered))
        min_points = np.where(is_facet, facet_rule, region_rule)
        survey = None if found is None else found.survey  # a thinned survey's facets, on all its points
        if found is not None and survey is not None:
            min_points = survey_min_points(min_points, whole_facets(point_region, found.labels, n_regions), survey,
                                           facet_rule)  # fmt: skip
        regions, kept = region_planes(
            filtered.local,
            point_region,
            region_of_voxel,
            min_points,
            params.rectangle,
            report,
            min_voxels=np.where(is_facet, 0, 3),
        )
        alias = {}
        if facet_record:
            # Every region, facet or grown over voxels, where the grid was trusted: a strip
            # one cell wide is no plane (points along a line, a pole, gave four when the
            # voxels no facet took were grown). Where it was not, its cells are no measure.
            trusted = facet_record["far_scatter_deg"] <= MAX_CELL_SCATTER
            # Rough rock's facets are steps a few points wide, never a grid's cells.
            narrow_checked = np.ones(n_regions, dtype=bool) if trusted else is_facet & ~rough
            regions, kept, counts["ribbons"] = without_ribbons(regions, kept, narrow_checked, facet_record["cell_edge"])
            if n_facets and params.merge and not rough:  # rough rock's facets are steps, not sparse pieces of a plane
                # A facet is sparse against the cloud its regions were counted on: a thinned
                # survey's facets hold thinned points, and against the survey's own spacing
                # (the facets' thresholds) every one read sparse. On a 100M-point face 444
                # were absorbed, into planes of 26 cm RMS facing out of the face (a 4th set).
                spacing = (
                    facet_record["facet_thresholds"]["spacing"] if survey is None else point_spacing(filtered.local)
                )
                regions, kept, alias = absorb_sparse_facets(
                    filtered.local, point_region, regions, kept, params.theta, params.psi * voxels.edge, spacing,
                    params.rectangle,
                )  # fmt: skip
                counts["absorbed"] = len(alias)
        # Old region id -> plane number (largest first); -1 (the table's last entry) stays -1.
        renumber = np.full(max(int(region_of_voxel.max(initial=-1)), int(point_region.max(initial=-1))) + 2, -1)
        renumber[kept] = np.arange(len(kept))
        for piece, taker in alias.items():
            renumber[piece] = renumber[taker]
        labels, voxel_labels = renumber[point_region], renumber[region_of_voxel]
        counts["planes"] = len(regions)
        counts["labelled_points"] = int((labels >= 0).sum())

    with _stage(seconds, "orientation", report):
        if (
            found is not None and survey is not None
        ):  # a plane that is one whole facet: on all the survey's points of it
            regions = on_survey_planes(regions, whole_facets(labels, found.labels, len(regions)), survey)
        outward = _outward(filtered, labels, len(regions))
        planes = plane_table(
            regions,
            frame,
            outward,
            (voxels.normal, voxel_labels),
            cloud.offset,
            lambda normals: normal_standard_errors(
                filtered.local,
                labels,
                normals,
                np.array([r.centroid for r in regions]).reshape(-1, 3),
                np.array([r.u for r in regions]).reshape(-1, 3),
                up=frame.matrix[2],
            ),
        )
        if envelope is not None:
            planes = planes.with_columns(face_surface=face_surface(labels, planes.normal, envelope))
    return Measurement(
        cloud=cloud,
        params=params,
        frame=frame,
        filtered=filtered,
        filter_result=filt,
        voxels=voxels,
        voxel_labels=voxel_labels,
        planes=planes,
        labels=labels,
        seconds=seconds,
        counts=counts,
        detection=facet_record,
    )


@contextmanager
def _stage(seconds: dict, name: str, report=None):
    """Time one stage into ``seconds[name]``; with ``report``, announce it first."""
    if report is not None:
        report(name, 0, None)
    start = time.perf_counter()
    try:
        yield
    finally:
        seconds[name] = time.perf_counter() - start


def face_surface(labels: np.ndarray, normals: np.ndarray, envelope: np.ndarray) -> np.ndarray:
    """Per plane, 1 where it lies along the face's own surface (its normal within
    :data:`~geostructure.detect.roughfacets.FACE_CONE` of the face's over its points, ``envelope`` (N, 3) in the
    cloud's coordinates) and 0 elsewhere: on rough rock those are pieces of the exposure,
    measured, but no discontinuity, and they join no set."""
    face = mean_directions(labels, envelope, len(normals))
    along = np.abs(np.einsum("ij,ij->i", normals, face))
    return (along >= np.cos(np.radians(FACE_CONE))).astype(np.int64)


def plane_table(regions, frame: Frame, outward, voxels, offset, standard_errors) -> Planes:
    """The plane table of region planes: normals turned upward (``outward``, the planes'
    summed stored normals or None, settles vertical ones) in ``frame``, their orientation,
    their voxels' spread (``voxels``: the voxel normals and each voxel's plane) and
    ``standard_errors(normals)`` (:func:`~geostructure.detect.uncertainty.normal_standard_errors`'s dict)."""
    raw = np.array([r.normal for r in regions]).reshape(-1, 3)
    normals = upward(frame.to_enu(raw), None if outward is None else frame.to_enu(outward)) @ frame.matrix
    voxel_normals, voxel_planes = voxels
    n_voxels, scatter = normal_spread(voxel_normals, voxel_planes, normals)
    return Planes.from_regions(
        regions,
        normals,
        orientation_from_normals(normals, frame, outward),
        offset=offset,
        n_voxels=n_voxels,
        scatter=scatter,
        uncertainty=standard_errors(normals),
        face=(None, None) if outward is None else face_side(outward, frame),
    )


def normal_spread(voxel_normals, voxel_labels, plane_normals):
    """Voxel count and RMS angle (deg) of voxel normals about each plane's normal: the plane's scatter."""
    n = len(plane_normals)
    mask = voxel_labels >= 0
    lab = voxel_labels[mask]
    cos = np.abs(np.einsum("ij,ij->i", voxel_normals[mask], plane_normals[lab])) if n else np.zeros(0)
    angle2 = np.degrees(np.arccos(np.clip(cos, 0.0, 1.0))) ** 2
    count = np.bincount(lab, minlength=n)
    scatter = np.sqrt(np.bincount(lab, angle2, minlength=n) / np.maximum(count, 1))
    return count, scatter


def _outward(cloud: Cloud, labels: np.ndarray, n_planes: int) -> np.ndarray | None:
    """Mean stored normal of each plane's points: the side its face is seen from."""
    if cloud.normals is None or n_planes == 0:
        return None
    mask = labels >= 0
    out = np.stack([np.bincount(labels[mask], cloud.normals[mask, a], n_planes) for a in range(3)], axis=1)
    return out
