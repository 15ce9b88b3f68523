"""Measuring a survey larger than memory: the voxel pipeline in passes over chunks.

Every stage of the voxel detector needs from the whole cloud only sums that add over its
parts (``docs/design.md``, "Streaming larger than memory"), so the survey is read once
into a spill file and then swept in chunks, each pass a map over the chunks and a sum:

1. (``--auto``) an order-free sample and the voxel moments at one or two zetas: the same
   choice :func:`~geostructure.detect.auto.choose_params` makes in memory;
2. the filter's voxel moments, then each chunk's kept points (their count and bounds);
3. the fit's voxel moments of the kept points, then region growing and the coplanar merge
   on the voxel planes (far fewer than the points), in memory;
4. each region's plane from its voxels' moments; a pass labels every point, writes the
   point outputs chunk by chunk, and gathers each plane's hull from the chunks' hulls;
5. a last pass adds the standard errors' block sums.

Grids are anchored where the in-memory run anchors them (the cloud's corner, then the kept
points'), so the planes are those of ``measure(..., Params(detector="voxel"))`` on the
whole cloud, to rounding.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field

import numpy as np

from geostructure.core.cloud import Cloud
from geostructure.core.orientation import Frame
from geostructure.core.params import ParameterWarning, Params
from geostructure.core.planes import Planes
from geostructure.core.voxeltable import VoxelTable
from geostructure.detect.auto import SAMPLE_POINTS, Occupancy, choose_from, samples_noise
from geostructure.detect.filter import neighbourhoods
from geostructure.detect.merge import merge_coplanar
from geostructure.detect.pipeline import plane_table
from geostructure.detect.rectangle import bound_plane, plane_from_scatter
from geostructure.detect.regions import grow_regions
from geostructure.detect.registry import STREAMED_DETECTOR, detector_spec, voxel_min_points
from geostructure.detect.uncertainty import errors_from_sums, plane_axes
from geostructure.detect.voxel import VoxelPlanes, voxel_planes_from_moments
from geostructure.errors import InputError, ParameterError
from geostructure.stream import passes
from geostructure.stream.executor import SerialExecutor
from geostructure.stream.source import Spill

#: Points a chunk holds when no memory bound says otherwise.
DEFAULT_CHUNK_POINTS = 2_000_000


@dataclass
class StreamedMeasurement:
    """What a streamed run found: :class:`~geostructure.detect.pipeline.Measurement` less its per-point
    arrays (the point outputs hold them). ``cloud`` holds no points: its offset, CRS and grid.

    Parameters
    ----------
    cloud : Cloud
        No points: the survey's offset, CRS and LAS grid.
    params : Params
        The parameters used (the voxel detector's, the automatic choice's factors).
    frame : Frame
        The frame the orientations are read in.
    voxels : VoxelPlanes
        The voxel planes kept.
    voxel_labels : ndarray
        Each voxel plane's plane (-1: none).
    planes : Planes
        The plane table.
    auto : dict, optional
        The automatic choice's record.
    seconds, counts, detection : dict
        Each pass's seconds, the points and planes counted, the detector's record.
    engine : str
        ``stream`` or ``dask``.
    north : dict, optional
        How the azimuths were turned to true north.

    Examples
    --------
    >>> from geostructure.testing.examples import scene_laz
    >>> from geostructure.stream import stream_planes
    >>> path = scene_laz(40_000)
    >>> result = stream_planes([path], chunk_points=10_000)
    >>> len(result) == len(result.planes), result.params.detector
    (True, 'voxel')
    """

    cloud: Cloud
    params: Params
    frame: Frame
    voxels: VoxelPlanes
    voxel_labels: np.ndarray
    planes: Planes
    auto: dict | None = None
    seconds: dict = field(default_factory=dict)
    counts: dict = field(default_factory=dict)
    detection: dict = field(default_factory=dict)
    engine: str = "stream"
    north: dict | None = None  # what run.json says of north (true_north_frame), when turned

    @property
    def normals(self) -> np.ndarray:
        return self.planes.normal

    def __len__(self) -> int:
        return len(self.planes)


def spill_planes(
    spill: Spill,
    params: Params = Params(detector="voxel"),
    frame: Frame = Frame(),
    *,
    auto: dict | None = None,
    chunk_points: int = DEFAULT_CHUNK_POINTS,
    executor=None,
    progress=None,
    writers=(),
) -> StreamedMeasurement:
    """Measure a spilled survey (:func:`~.source.spill_inputs`) in passes over its chunks.

    Parameters
    ----------
    spill : Spill
    params : Params
        Its detector is taken as ``voxel``: the facet detector needs each point's
        neighbours and runs in memory only.
    frame : Frame
    auto : dict, optional
        Choose zeta, theta and psi from the cloud first (as ``--auto``), keeping the factors
        this dict gives.
    chunk_points : int
        Points a chunk holds: with the tables, what bounds the run's memory.
    executor : SerialExecutor or DaskExecutor
    progress : callable, optional
        ``progress("stream", done, total)`` over all the passes' chunks.
    writers : sequence
        Point outputs, each with ``begin(n_points, lower, upper, cloud)``, ``write(points,
        labels)`` for each chunk's kept points (absolute) in order, and ``end()``.

    Returns
    -------
    StreamedMeasurement

    Examples
    --------
    >>> from geostructure.testing.examples import scene_laz
    >>> from geostructure.stream import spill_inputs
    >>> path = scene_laz(40_000)
    >>> spill = spill_inputs([path], rows=10_000)
    >>> len(spill_planes(spill, chunk_points=10_000)) >= 5
    True
    >>> spill.close()
    """
    if not detector_spec(params.detector).streams:
        with warnings.catch_warnings():  # the user has been told of a zeta outside the paper's range
            warnings.simplefilter("ignore", ParameterWarning)
            params = params.with_(detector=STREAMED_DETECTOR)
    run = _Run(spill, params, executor or SerialExecutor(), chunk_points, progress)
    seconds, counts = {}, {"input": spill.n_points}
    t = time.perf_counter()
    params, choice = run.choose(auto)
    seconds["auto"] = time.perf_counter() - t

    t = time.perf_counter()
    keep = run.filter_context(params)
    keep.path = str(spill.folder / "keep.u1")
    with open(keep.path, "wb") as fh:  # sized first: each chunk writes its own bytes
        fh.truncate(spill.n_points)
    n_kept, kept_lower, kept_upper = run.kept(keep)
    keep.written = True
    counts["filtered"] = n_kept
    if n_kept < 3:
        raise ParameterError(f"{spill.source}: the outlier filter left {n_kept} point(s); try `filter='none'`.")
    seconds["filter"] = time.perf_counter() - t

    t = time.perf_counter()
    edge = params.zeta * float(np.max(kept_upper - kept_lower))
    moments = run.moments(edge, kept_lower, keep)
    voxels, rows = voxel_planes_from_moments(moments, params.min_voxel_points, params.max_curvature)
    counts["voxel_planes"] = len(voxels)
    seconds["voxel"] = time.perf_counter() - t

    t = time.perf_counter()
    region_of_voxel, counts["regions"], counts["merges"] = _grow(voxels, params)
    plane_of_voxel, candidates = _planes_of_voxels(voxels, region_of_voxel, params, n_kept)
    seconds["regions"] = time.perf_counter() - t

    t = time.perf_counter()
    fits = _fits_from_moments(moments, rows, plane_of_voxel, len(candidates))
    label_context = passes.LabelContext(
        spill.offset,
        keep,
        VoxelTable.of(voxels.keys, edge, kept_lower),
        plane_of_voxel,
        np.array([f[0] for f in fits]).reshape(-1, 3),
        np.array([f[2] for f in fits]).reshape(-1, 2, 3),
        spill.has_normals,
    )
    labels_path = str(spill.folder / "labels.i4")
    hulls, normal_sums = run.label(label_context, labels_path, writers, n_kept, kept_lower, kept_upper)
    regions = [
        bound_plane(c, n, axes, r, hulls.get(i, np.zeros((1, 2))), count, params.rectangle)
        for i, (c, n, axes, r, count) in enumerate(fits)
    ]
    counts["planes"] = len(regions)
    counts["labelled_points"] = int(sum(r.n_points for r in regions))
    seconds["planes"] = time.perf_counter() - t

    t = time.perf_counter()
    centroids = np.array([r.centroid for r in regions]).reshape(-1, 3)

    def standard_errors(normals):
        axes = plane_axes(normals, np.array([r.u for r in regions]).reshape(-1, 3))
        ranges = _ranges_from_hulls(hulls, fits, centroids, axes)
        sums = run.total(passes.chunk_block_sums, (spill.offset, labels_path, centroids, axes, ranges))
        return errors_from_sums(sums, axes, up=frame.matrix[2]) if sums is not None else _no_errors(0)

    planes = plane_table(regions, frame, normal_sums, (voxels.normal, plane_of_voxel), spill.offset, standard_errors)
    seconds["orientation"] = time.perf_counter() - t
    return StreamedMeasurement(
        cloud=spill.cloud(),
        params=params,
        frame=frame,
        voxels=voxels,
        voxel_labels=plane_of_voxel,
        planes=planes,
        auto=choice,
        seconds=seconds,
        counts=counts,
        engine=run.executor.name,
    )


class _Run:
    """The passes of one streamed run over one spill, with its progress."""

    def __init__(self, spill: Spill, params: Params, executor, chunk_points: int, progress):
        self.spill, self.params, self.executor = spill, params, executor
        self.chunks = spill.chunks(chunk_points)
        self.offset = spill.offset
        self.lower = spill.lower - self.offset
        self.extent = float(np.max(spill.upper - spill.lower))
        if not self.extent > 0:
            raise InputError(f"{spill.source}: all points lie at one spot; there is no plane to measure.")
        self.report = progress or (lambda stage, done, total: None)
        self.done = 0
        # The passes: the filter's moments and decisions, the fit, the labels, the errors
        # (the automatic choice adds its own as it goes).
        self.total_work = len(self.chunks) * 5
        self.auto_moments = None  # the automatic choice's last fit: the local filter's moments

    def _step(self) -> None:
        self.done += 1
        self.report("stream", min(self.done, self.total_work), self.total_work)

    def map(self, fn, context):
        for part in self.executor.map(fn, self.chunks, context):
            self._step()
            yield part

    def total(self, fn, context):
        whole = None
        for part in self.map(fn, context):
            whole = part if whole is None else whole + part
        return whole

    def moments(self, edge: float, origin, keep=None):
        """The voxel moments on a grid, of all the points or of those ``keep`` keeps."""
        total = passes.MomentsTotal()
        for part in self.map(passes.chunk_moments, (self.offset, edge, origin, keep)):
            total.add(part)
        return total.result()

    def choose(self, auto: dict | None):
        if auto is None:
            return self.params, None
        self.total_work += 2 * len(self.chunks)  # the sample and the first fit
        fits = []
        sample = None
        for part in self.map(passes.hash_sample, (self.offset, self.lower, self.extent, SAMPLE_POINTS)):
            sample = passes.merge_samples(sample, part, SAMPLE_POINTS)
        order = np.argsort(sample[0], kind="stable")
        probe = Occupancy.of_sample(sample[1][order], self.spill.n_points, self.lower, self.extent)

        def fit(zeta: float):
            if fits:  # a second fit: noise made the voxels coarser
                self.total_work += len(self.chunks)
            fits.append(zeta)
            moments = self.moments(zeta * self.extent, self.lower)
            self.auto_moments = moments  # the last fit is on the chosen zeta's grid
            return voxel_planes_from_moments(moments, 5, 1 / 3)[0]

        def noise_fit(zeta: float):  # the voxels auto.noise_sample draws, as in memory
            fits.append(zeta)
            drawn = passes.VoxelDraw(self.lower, zeta * self.extent, self.spill.n_points)
            return voxel_planes_from_moments(self.moments(zeta * self.extent, self.lower, drawn), 5, 1 / 3)[0]

        choice = choose_from(probe, fit, self.params, noise_fit if samples_noise(self.spill.n_points) else None)
        params = choice.params.with_(**auto) if auto else choice.params
        return params, choice.to_dict(auto)

    def filter_context(self, params: Params) -> passes.FilterContext:
        method = params.filter
        context = passes.FilterContext(method, params.filter_sigma)
        if method == "local":
            edge = params.zeta * self.extent
            reuse = self.auto_moments
            if reuse is not None and reuse.edge == edge:  # no pass: the choice summed them
                moments = reuse
                self.total_work -= len(self.chunks)
            else:
                moments = self.moments(edge, self.lower)
            context.blocks = neighbourhoods(moments)
            context.typical = context.blocks.typical_support()
            context.table = VoxelTable.of(moments.keys, edge, self.lower)
        elif method == "global":
            n, s, ss = 0, np.zeros(3), np.zeros((3, 3))
            for part in self.map(passes.chunk_sums, self.offset):
                n, s, ss = n + part[0], s + part[1], ss + part[2]
            context.mean = s / n
            context.cov = (ss - n * np.outer(context.mean, context.mean)) / max(n - 1, 1)
        return context

    def kept(self, keep):
        n, lower, upper = 0, np.full(3, np.inf), np.full(3, -np.inf)
        for count, lo, hi in self.map(passes.kept_bounds, (self.offset, keep)):
            n, lower, upper = n + count, np.minimum(lower, lo), np.maximum(upper, hi)
        return n, lower, upper

    def label(self, context, labels_path, writers, n_kept, lower, upper):
        """The label pass: the label spill and the point outputs written in chunk order,
        the planes' hulls and stored-normal sums gathered."""
        for writer in writers:
            writer.begin(n_kept, lower + self.offset, upper + self.offset, self.spill.cloud())
        hulls, normal_sums = {}, None
        marks = self.spill.vegetation_path
        with open(labels_path, "wb") as spill_out:
            for chunk, (keep, kept, labels, part_hulls, sums) in zip(
                self.chunks, self.map(passes.chunk_labels, context)
            ):
                every = np.full(len(keep), passes.DROPPED, dtype="<i4")
                every[keep] = labels
                every.tofile(spill_out)
                hulls = passes.merge_hulls(hulls, part_hulls)
                if sums is not None:
                    normal_sums = sums if normal_sums is None else normal_sums + sums
                vegetation = None  # the kept points' marks, read here beside the spill
                if marks is not None:
                    vegetation = np.fromfile(marks, np.uint8, len(chunk), offset=chunk.start)[keep].astype(bool)
                for writer in writers:
                    writer.write(kept, labels, vegetation)
        for writer in writers:
            writer.end()
        return hulls, normal_sums


def _grow(voxels: VoxelPlanes, params: Params):
    """Region growing and the coplanar merge over the voxel planes, as
    :func:`~geostructure.detect.pipeline.measure` runs them for the voxel detector."""
    growth = grow_regions(
        voxels, params.theta, params.psi, params.k, reference=params.reference, max_gap=params.max_gap
    )
    labels, merges = growth.labels, 0
    if params.merge:
        labels, merges = merge_coplanar(voxels, growth.labels, params.theta, params.psi * voxels.edge)
    return labels, growth.n_regions, merges


def _planes_of_voxels(voxels: VoxelPlanes, region_of_voxel, params: Params, n_kept: int):
    """Each voxel's plane number (largest first; -1 for none) and the regions kept: those of
    ``min_points`` points and three voxels (the in-memory rule), sized from the voxels' counts."""
    n_regions = int(region_of_voxel.max(initial=-1)) + 1
    labelled = region_of_voxel >= 0
    sizes = np.bincount(region_of_voxel[labelled], voxels.count[labelled], n_regions)
    n_voxels = np.bincount(region_of_voxel[labelled], minlength=n_regions)
    min_points = params.min_points or voxel_min_points(n_kept)
    candidates = np.flatnonzero((sizes >= min_points) & (n_voxels >= 3))
    candidates = candidates[np.argsort(-sizes[candidates], kind="stable")]
    renumber = np.full(n_regions + 1, -1, dtype=np.int64)
    renumber[candidates] = np.arange(len(candidates))
    return renumber[region_of_voxel], candidates


def _fits_from_moments(moments, rows, plane_of_voxel, n_planes: int):
    """Each plane's (centroid, normal, axes, residual, count) from its voxels' moments: the
    least-squares plane of all its points, added about each voxel's own centroid."""
    mine = plane_of_voxel >= 0
    rows, plane = rows[mine], plane_of_voxel[mine]
    count = moments.count[rows]
    mean_rel = moments.sums[rows] / count[:, None]
    centre = moments.origin + moments.keys[rows] * moments.edge + mean_rel
    second = np.zeros((len(rows), 3, 3))
    iu = np.triu_indices(3)
    second[:, iu[0], iu[1]] = moments.products[rows]
    second[:, iu[1], iu[0]] = second[:, iu[0], iu[1]]
    scatter_own = second - count[:, None, None] * mean_rel[:, :, None] * mean_rel[:, None, :]
    total = np.bincount(plane, count, n_planes)
    centroid = np.stack([np.bincount(plane, count * centre[:, a], n_planes) for a in range(3)], 1) / total[:, None]
    d = centre - centroid[plane]
    scatter_all = scatter_own + count[:, None, None] * d[:, :, None] * d[:, None, :]
    scatter = np.zeros((n_planes, 3, 3))
    np.add.at(scatter, plane, scatter_all)
    return [(*plane_from_scatter(total[p], centroid[p], scatter[p]), int(total[p])) for p in range(n_planes)]


def _ranges_from_hulls(hulls, fits, centroids, axes) -> np.ndarray:
    """Each plane's least and greatest u and v along its rectangle's axes (the extent its
    standard errors' blocks divide), from its hull: a linear function's extremes over the
    points lie on their hull."""
    _, u_axis, v_axis = axes
    out = np.column_stack([np.full(len(fits), np.inf), np.full(len(fits), -np.inf)] * 2)
    for p, fit in enumerate(fits):
        if p not in hulls:
            continue
        offsets = fit[0] + hulls[p] @ fit[2] - centroids[p]
        u, v = offsets @ u_axis[p], offsets @ v_axis[p]
        out[p] = [u.min(), u.max(), v.min(), v.max()]
    return out


def _no_errors(n: int) -> dict:
    nan = np.full(n, np.nan)
    return {"normal": nan, "dip": nan, "dip_direction": nan, "planarity": nan}
