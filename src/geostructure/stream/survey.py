"""A survey larger than memory, spilled and thinned to what fits: the cloud the rock mass is
measured on (one point a cell) and the writer that labels every point of the survey after
(``measure --sets`` or ``--kinematics`` on a survey that does not fit). The command line
spills and thins it (:mod:`geostructure.cli.thinned`)."""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from geostructure.core.cloud import Cloud
from geostructure.errors import GeoStructureNote
from geostructure.io.crs import cloud_unit
from geostructure.io.laz import POINT_SET_DIMENSIONS, point_joints, point_sets
from geostructure.stream.output import RegionsLaz, RegionsPly
from geostructure.stream.passes import DROPPED
from geostructure.stream.source import Spill
from geostructure.stream.thin import Thinned, label_survey


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
