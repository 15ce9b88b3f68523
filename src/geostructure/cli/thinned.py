"""``measure --sets`` (or ``--kinematics``, or ``--detector facets``) on a survey larger than
memory: read chunk by chunk, thinned to a cloud that fits (:mod:`geostructure.stream.thin`),
measured in memory, and every point of the survey labelled in ``regions.ply`` and
``regions.laz`` by the point that stood for its cell."""

from __future__ import annotations

import warnings
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

from geostructure.cli.engine import MEMORY_BASE_BYTES, chunk_points, default_max_memory, memory_bytes_per_point
from geostructure.cli.progress import StageProgress
from geostructure.core.cloud import Cloud
from geostructure.errors import GeoStructureNote, ParameterError
from geostructure.io.crs import cloud_unit
from geostructure.io.laz import POINT_SET_DIMENSIONS, point_joints, point_sets
from geostructure.stream import DaskExecutor, SerialExecutor, spill_inputs
from geostructure.stream.output import RegionsLaz, RegionsPly
from geostructure.stream.passes import DROPPED
from geostructure.stream.source import Spill
from geostructure.stream.thin import Thinned, label_survey, thin_spill

#: The fewest points a rock mass is measured on: fewer cannot show joints of a metre.
MIN_THINNED_POINTS = 20_000


def thinned_points(args) -> int:
    """The points a thinned survey may keep: what ``--max-memory`` holds in memory."""
    limit = args.max_memory or default_max_memory()
    points = (limit - MEMORY_BASE_BYTES) // memory_bytes_per_point(args)
    if points < MIN_THINNED_POINTS:
        raise ParameterError(
            f"--max-memory {limit >> 20}M holds too few points to measure a rock mass in: give at least "
            f"{(MEMORY_BASE_BYTES + MIN_THINNED_POINTS * memory_bytes_per_point(args)) >> 20}M."
        )
    return int(points)


@dataclass
class ThinnedSurvey:
    """A survey spilled and thinned: the cloud to measure, and the writer of every point."""

    spill: Spill
    thinned: Thinned
    executor: object
    chunk_points: int

    def cloud(self) -> Cloud:
        """The thinned points on the survey's offset, with what its files declared."""
        spill, rows = self.spill, self.thinned.rows
        normals = vegetation = None
        if spill.has_normals:
            normals = np.memmap(spill.normals_path, dtype="<f8", mode="r", shape=(spill.n_points, 3))[rows]
        if spill.has_vegetation:
            vegetation = np.memmap(spill.vegetation_path, dtype=np.uint8, mode="r")[rows].astype(bool)
        return Cloud(
            self.thinned.points - spill.offset,
            spill.offset,
            crs=spill.crs,
            normals=normals,
            source=spill.source,
            las_grid=spill.las_grid,
            left_out=spill.left_out,
            vegetation=vegetation,
        )

    def record(self) -> dict:
        """What ``run.json`` says of the thinning."""
        grid = self.thinned.grid
        return {
            "survey_points": self.spill.n_points,
            "points": len(self.thinned),
            **({"cell": None} if grid is None else grid.to_record()),
        }

    def note(self, limit: int, unit: str | None = None) -> None:
        grid, n = self.thinned.grid, self.spill.n_points
        if grid is None:
            return
        warnings.warn(
            f"{self.spill.source}: its {n:,} points do not fit in {limit / 2**30:.3g} GiB (--max-memory); "
            f"measured on {len(self.thinned):,} of them, the first in each cell of {grid.edge:.3g} {cloud_unit(self.spill.crs, unit)['symbol']} on a side, "
            f"and every point labelled in regions.ply and regions.laz.",
            GeoStructureNote,
            stacklevel=2,
        )

    def write_points(self, outputs, result, planes, rock, progress=None) -> None:
        """Stage ``regions.ply`` and ``regions.laz`` of every point of the survey whose cell's
        point the filter kept, each with that point's region (and set and face part)."""
        thinned, spill = self.thinned, self.spill
        keep = result.filter_result.keep
        region_of = np.full(len(thinned), DROPPED, dtype=np.int32)
        region_of[keep] = result.labels
        extra, set_of, part_of, joint_of = {}, None, None, None
        if planes is not None:
            extra = dict(POINT_SET_DIMENSIONS)
            set_of = np.full(len(thinned), -1, dtype=np.int16)
            set_of[keep] = point_sets(result.labels, planes)
            joint_of = np.full(len(thinned), -1, dtype=np.int32)
            joint_of[keep] = point_joints(result.labels, planes)
            part_of = np.zeros(len(thinned), dtype=np.uint8)
            if rock is not None and rock.point_part is not None:
                part_of[keep] = rock.point_part
        writers = [RegionsPly(outputs.path("regions.ply"), bool(extra)), RegionsLaz(outputs.path("regions.laz"), extra)]
        n_kept = int(thinned.counts[keep].sum())
        for writer in writers:
            writer.begin(n_kept, spill.lower, spill.upper, spill.cloud())
        marks = spill.vegetation_path
        for chunk, points, found in label_survey(spill, thinned, self.chunk_points, self.executor, progress):
            region = region_of[found]
            kept = region != DROPPED
            vegetation = None
            if marks is not None:
                vegetation = np.fromfile(marks, np.uint8, len(chunk), offset=chunk.start)[kept].astype(bool)
            fields = None
            if set_of is not None:
                fields = {"set": set_of[found][kept], "face_part": part_of[found][kept], "joint": joint_of[found][kept]}
            for writer in writers:
                writer.write(points[kept], region[kept], vegetation, fields)
        for writer in writers:
            writer.end()


@contextmanager
def thinned_survey(args, paths, engine: str):
    """Spill ``paths`` and thin them to what ``--max-memory`` holds; the spill is removed
    when the block ends, however it ends."""
    target = thinned_points(args)  # a bound too small is refused before any work
    executor = DaskExecutor(args.scheduler, args.workers) if engine == "dask" else SerialExecutor()
    spill = None
    rows = chunk_points(args)
    try:
        with StageProgress(enabled=not args.quiet) as progress:
            spill = spill_inputs(paths, rows, mesh_samples=args.mesh_samples or None, progress=progress,
                                 folder=args.spill_dir)  # fmt: skip
            thinned = thin_spill(spill, target, rows, executor, progress)
        survey = ThinnedSurvey(spill, thinned, executor, rows)
        survey.note(args.max_memory or default_max_memory(), args.unit)
        yield survey
    finally:
        if spill is not None:
            spill.close()
        executor.close()
