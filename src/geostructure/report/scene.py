"""What the interactive report shows, read back from a measured output folder.

The report is built from the files ``measure`` writes (``planes.csv``, ``regions.ply``,
``voxel_planes.ply``, ``run.json`` and, after ``evaluate``, ``evaluation.csv``), so
``geostructure report OUTDIR`` and ``measure --report`` draw exactly the same thing.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from geostructure.core.orientation import Frame
from geostructure.core.planes import Planes
from geostructure.errors import OutputError
from geostructure.io.crs import metres_per_unit, unit_symbol
from geostructure.io.results import ply_field, read_planes, read_run, read_sets, read_spacings, read_traces
from geostructure.kinematics.catalog import PLANE_MODES

#: Points drawn in 3D at most: enough to read the outcrop's shape, few enough for WebGL
#: to turn it fluently and for the file to stay small whatever the input's size.
MAX_DISPLAY_POINTS = 100_000
#: Voxel planes drawn at most (each is a small square: two triangles).
MAX_DISPLAY_VOXELS = 30_000


@dataclass
class ReportScene:
    """Coordinates are local (absolute minus ``offset``) so float32 keeps millimetres."""

    points: np.ndarray  # (M, 3) decimated filtered points, float32, local
    point_region: np.ndarray  # (M,) region id or -1
    n_points_total: int
    voxel_centroids: np.ndarray  # (V, 3) local
    voxel_normals: np.ndarray  # (V, 3)
    voxel_region: np.ndarray  # (V,)
    voxel_edge: float
    planes: Planes  # planes.csv, positions relative to ``offset``
    frame: Frame
    offset: np.ndarray
    crs: str | None
    source: str
    truth: dict = field(default_factory=dict)  # region id -> evaluation row
    inputs: list = field(default_factory=list)  # run.json's files, when the run read several
    sets: list = field(default_factory=list)  # sets.csv rows (numbers), when the sets were found
    spacings: dict = field(default_factory=dict)  # set -> normal spacings along the scanlines (m)
    rock_mass: dict = field(default_factory=dict)  # run.json's totals: Jv, block volume
    kinematics: dict = field(default_factory=dict)  # kinematics.json, when the tests were run
    plane_kinematics: dict = field(default_factory=dict)  # region_id -> what it fails by (kinematics.csv)
    georeference: dict | None = None  # how a reconstruction was tied to the world
    north: dict | None = None  # run.json's north: the grid convergence the azimuths were turned by
    length_unit: dict | None = None  # run.json's unit ({"symbol", "metres"}), when it gives one
    traces: list = field(default_factory=list)  # traces.csv's polylines, local, when the sets were found

    @property
    def unit(self) -> str:
        """The symbol of the cloud's length unit (``"m"``, ``"ft"``): the plane table's sizes
        are in it, the rock mass's in metres."""
        return self.length_unit["symbol"] if self.length_unit else unit_symbol(self.crs)

    @property
    def metres_per_unit(self) -> float:
        """Metres in the cloud's length unit: the page gives every area in square metres."""
        return float(self.length_unit["metres"]) if self.length_unit else metres_per_unit(self.crs)


#: kinematics.csv's per-plane tests, as the report's plane table words them.
FAILURE_WORDS = tuple((mode.key, mode.words) for mode in PLANE_MODES)


def plane_failures(path: Path) -> dict:
    """Each plane's kinematic result from ``kinematics.csv`` (region id -> words: the modes
    it is critical for, with the planar factor of safety, or "not critical"); {} without the file."""
    import csv

    if not path.is_file():
        return {}
    found = {}
    with open(path, newline="", encoding="utf-8") as fh:
        for row in csv.DictReader(fh):
            modes = [words for key, words in FAILURE_WORDS if str(row.get(key, "")).lower() == "true"]
            fs = row.get("planar_fs", "nan")
            if "planar sliding" in modes and fs not in ("", "nan"):
                modes[modes.index("planar sliding")] = f"planar sliding (FS {float(fs):.2f})"
            found[int(float(row["region_id"]))] = ", ".join(modes) or "not critical"
    return found


def load_scene(
    outdir, max_points: int = MAX_DISPLAY_POINTS, max_voxels: int = MAX_DISPLAY_VOXELS, seed: int = 0
) -> ReportScene:
    """Read a measured output folder into a :class:`ReportScene`, decimated for display.

    Decimation is a seeded uniform sample, so dense and sparse parts keep their proportions.
    """
    outdir = Path(outdir)
    run = read_run(outdir)
    offset = np.asarray(run.get("offset", [0, 0, 0]), dtype=np.float64)
    rng = np.random.default_rng(seed)
    points, point_region, total = _read_ply_sample(outdir / "regions.ply", ("region_id",), offset, max_points, rng)
    voxel_path = outdir / "voxel_planes.ply"
    if voxel_path.exists():
        vox, extra, _ = _read_ply_sample(voxel_path, ("nx", "ny", "nz", "region_id"), offset, max_voxels, rng)
        voxel_normals, voxel_region = np.stack(extra[:3], axis=1), extra[3]
    else:  # folders written before voxel_planes.ply existed: no voxel layer
        vox, voxel_normals, voxel_region = np.zeros((0, 3), np.float32), np.zeros((0, 3)), np.zeros(0, int)
    planes = read_planes(outdir, offset)
    return ReportScene(
        points=points,
        point_region=point_region[0],
        n_points_total=total,
        voxel_centroids=vox,
        voxel_normals=voxel_normals,
        voxel_region=voxel_region,
        voxel_edge=float(run.get("voxel_edge", 0.0)),
        planes=planes,
        frame=Frame.from_dict(run["frame"]),
        offset=offset,
        crs=run.get("crs"),
        length_unit=run.get("unit"),
        source=str(run.get("input", "")),
        inputs=list(run.get("inputs") or []),
        truth=_read_truth(outdir / "evaluation.csv"),
        sets=read_sets(outdir) if "set" in planes.extra else [],
        spacings=read_spacings(outdir) if "set" in planes.extra else {},
        rock_mass=(run.get("sets") or {}).get("rock_mass") or {},
        kinematics=_read_json(outdir / "kinematics.json"),
        plane_kinematics=plane_failures(outdir / "kinematics.csv"),
        georeference=run.get("reconstruction", {}).get("georef"),
        north=run.get("north"),
        traces=[line - offset for line in (read_traces(outdir) or ([], None))[0]],
    )


def _read_ply_sample(path: Path, names, offset, limit, rng):
    from plyfile import PlyData, PlyParseError

    try:
        vertex = PlyData.read(str(path), mmap="r")["vertex"].data
        columns = [vertex[n] for n in ("x", "y", "z")] + [ply_field(vertex, n) for n in names]
    except FileNotFoundError:
        raise OutputError(f"{path}: no such file; run 'geostructure measure' first.") from None
    except (PlyParseError, KeyError, ValueError) as exc:
        raise OutputError(f"{path}: not a GeoStructure PLY ({exc}).") from None
    total = len(vertex)
    pick = np.sort(rng.choice(total, limit, replace=False)) if total > limit else slice(None)
    # The sample first, then the columns: a memory-mapped file of a streamed survey's
    # hundreds of millions of points is read only where the sample falls.
    columns = [np.asarray(c[pick]) for c in columns]
    xyz = (np.stack(columns[:3], axis=1).astype(np.float64) - offset).astype(np.float32)
    return xyz, columns[3:], total


def _read_json(path: Path) -> dict:
    """A JSON file of the folder as a dict; {} when it is not there."""
    import json

    if not path.is_file():
        return {}
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (ValueError, UnicodeDecodeError):
        raise OutputError(f"{path}: not a GeoStructure JSON file.") from None


def _read_truth(path: Path) -> dict:
    """Region id -> its evaluation row (surface name, truth angles, errors), if evaluated."""
    if not path.exists():
        return {}
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    return {int(r["region"]): r for r in rows if r.get("region") not in (None, "", "-1")}
