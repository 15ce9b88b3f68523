"""A survey larger than memory, spilled and thinned to what fits: the cloud the rock mass is
measured on (one point a cell), its facets found on every point in tiles with halos
(:meth:`ThinnedSurvey.full_resolution_facets`), and the writer that labels every point of
the survey after (``measure --sets`` or ``--kinematics`` on a survey that does not fit). The
workflow spills and thins it (:mod:`geostructure.workflows.thinned`).

The facets are the survey's own, at full resolution: a joint a few thinned cells across is
found as a facet of its points, and each thinned point carries the facet of the survey's
point it is. The rest of the measure (the voxel growing where no facet holds the points,
the planes' rectangles, the sets, the rock mass and the kinematics) runs on the thinned
cloud, in memory, and every point of a facet is written with its facet's plane.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from geostructure.core.cloud import Cloud
from geostructure.core.density import point_spacing
from geostructure.detect.facets import FacetDetection, voxel_majority
from geostructure.detect.roughfacets import RoughFacets, envelope_normals
from geostructure.errors import GeoStructureNote
from geostructure.io.crs import cloud_unit
from geostructure.io.laz import POINT_SET_DIMENSIONS, point_joints, point_sets
from geostructure.stream.output import RegionsLaz, RegionsPly
from geostructure.stream.passes import DROPPED, FilterContext
from geostructure.stream.source import Spill
from geostructure.stream.thin import Thinned, label_survey
from geostructure.stream.tiledfacets import StreamedFacets, detect_facets_spilled


@dataclass
class ThinnedSurvey:
    """A survey spilled and thinned: the cloud to measure, and the writer of every point."""

    spill: Spill
    thinned: Thinned
    executor: object
    chunk_points: int
    #: Points a facet tile's core holds, about (a chunk's by default), or cells on its side.
    tile_points: int | None = None
    tile_cells: int | None = None
    #: The facets found on every point, once :meth:`full_resolution_facets` ran.
    facets: StreamedFacets | None = None

    def cloud(self) -> Cloud:
        """The thinned points on the survey's offset, with what its files declared."""
        spill, rows = self.spill, self.thinned.rows
        normals = vegetation = grey = None
        if spill.has_normals:
            normals = np.memmap(spill.normals_path, dtype="<f8", mode="r", shape=(spill.n_points, 3))[rows]
        if spill.has_vegetation:
            vegetation = np.memmap(spill.vegetation_path, dtype=np.uint8, mode="r")[rows].astype(bool)
        if spill.has_grey:  # the traces' dark lines, drawn on the thinned points
            grey = np.asarray(np.memmap(spill.grey_path, dtype="<f4", mode="r")[rows])
        return Cloud(
            self.thinned.points - spill.offset,
            spill.offset,
            crs=spill.crs,
            normals=normals,
            source=spill.source,
            las_grid=spill.las_grid,
            left_out=spill.left_out,
            vegetation=vegetation,
            grey=grey,
        )

    def record(self) -> dict:
        """What ``run.json`` says of the thinning."""
        grid = self.thinned.grid
        return {
            "survey_points": self.spill.n_points,
            "points": len(self.thinned),
            **({"cell": None} if grid is None else grid.to_record()),
        }

    def note(self, limit: int, unit: str | None = None, full_resolution: bool = True) -> None:
        """Tell the user the survey was thinned (and how), when it was."""
        grid, n = self.thinned.grid, self.spill.n_points
        if grid is None:
            return
        facets = "its facets found on every point, in tiles, " if full_resolution else ""
        warnings.warn(
            f"{self.spill.source}: its {n:,} points do not fit in {limit / 2**30:.3g} GiB (--max-memory); "
            f"measured on {len(self.thinned):,} of them, the first in each cell of {grid.edge:.3g} {cloud_unit(self.spill.crs, unit)['symbol']} on a side, "
            f"{facets}and every point labelled in regions.ply and regions.laz.",
            GeoStructureNote,
            stacklevel=2,
        )

    def full_resolution_facets(self, filtered: Cloud, keep: np.ndarray, progress=None) -> FacetDetection:
        """The facets of every point of the survey (:func:`~.tiledfacets.detect_facets_spilled`),
        each of the survey's points kept where its cell's thinned point is (``keep``, the
        filter's decisions on the thinned cloud), as the facet detection of the ``filtered``
        thinned cloud: each of its points carries its own facet, and each facet its plane from
        all the survey's points of it (:mod:`geostructure.detect.surveyplanes`). Where nothing
        was thinned, these are the in-memory detector's facets."""
        report = progress or (lambda stage, done, total: None)
        spill, keep = self.spill, np.asarray(keep, dtype=bool)
        path = spill.folder / "keep.u1"
        with open(path, "wb") as out:  # each point kept where its cell's point is
            told = lambda stage, done, total: report("keep", done, total)  # noqa: E731
            for _, _, found in label_survey(spill, self.thinned, self.chunk_points, self.executor, told):
                keep[found].tofile(out)
        context = FilterContext("none", 0.0, path=str(path), written=True)
        self.facets = found = detect_facets_spilled(spill, self.chunk_points, self.executor, keep=context,
                                                    tile_points=self.tile_points, tile_cells=self.tile_cells,
                                                    progress=report)  # fmt: skip
        every = np.memmap(found.labels_path, dtype="<i4", mode="r", shape=(spill.n_points,))
        labels = np.asarray(every[self.thinned.rows[keep]], dtype=np.int64)
        del every
        curved = labels == -2
        present = np.unique(labels[labels >= 0])  # facets with a thinned point, in order
        labels = np.where(labels >= 0, np.searchsorted(present, labels), -1)
        rough = None
        if found.rough is not None:
            rough = RoughFacets(labels, np.zeros(len(labels), dtype=bool),
                                envelope_normals(filtered.local, point_spacing(filtered.local)),
                                found.rough["rough_join_angle_deg"])  # fmt: skip
        record = found.record()
        extra = {"full_resolution": {"survey_points": spill.n_points, "planar_facets": record["planar_facets"],
                                     "curved_points": record["curved_points"], "tiles": found.n_tiles,
                                     "tile_cells": found.tile_cells}}  # fmt: skip
        if rough is not None:
            extra["face_points"] = found.rough["face_points"]  # of the survey's points
        return FacetDetection(labels, curved, found.thresholds, found.cell_edge, found.far_scatter, rough, extra,
                              survey=None if self.thinned.grid is None else found.planes.take(present))  # fmt: skip

    def plane_of_facet(self, result) -> np.ndarray | None:
        """Each full-resolution facet's plane (the plane most of its thinned points are in),
        -1 for a facet with none, with one entry more (-1) for the points of no facet."""
        if self.facets is None or self.facets.labels_path is None:
            return None
        every = np.memmap(self.facets.labels_path, dtype="<i4", mode="r", shape=(self.spill.n_points,))
        facet = np.asarray(every[self.thinned.rows[result.filter_result.keep]], dtype=np.int64)
        del every
        on = facet >= 0
        plane = np.full(self.facets.n_facets + 1, -1, dtype=np.int64)
        plane[:-1] = voxel_majority(facet[on], result.labels[on], self.facets.n_facets)
        return plane

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
        plane_of_facet = self.plane_of_facet(result)
        for chunk, points, found in label_survey(spill, thinned, self.chunk_points, self.executor, progress):
            region = region_of[found]
            kept = region != DROPPED
            if plane_of_facet is not None:  # a point of a facet: its facet's plane, not its cell's
                facet = np.fromfile(self.facets.labels_path, dtype="<i4", count=len(chunk), offset=4 * chunk.start)
                own = plane_of_facet[np.where(facet >= 0, facet, -1)]
                region = np.where(kept & (own >= 0), own, region)
            vegetation = None
            if marks is not None:
                vegetation = np.fromfile(marks, np.uint8, len(chunk), offset=chunk.start)[kept].astype(bool)
            fields = None
            if set_of is not None:
                fields = {"set": set_of[found][kept], "face_part": part_of[found][kept], "joint": joint_of[found][kept]}
                if plane_of_facet is not None:  # the set and joint of the point's own plane
                    fields["set"] = point_sets(region[kept], planes).astype(np.int16)
                    fields["joint"] = point_joints(region[kept], planes).astype(np.int32)
            for writer in writers:
                writer.write(points[kept], region[kept], vegetation, fields)
        for writer in writers:
            writer.end()
