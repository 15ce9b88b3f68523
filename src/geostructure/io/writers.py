"""Writers: planes.csv, regions.ply, voxel_planes.ply and run.json, each written atomically.

Every file goes to a temporary name in the output folder first and is renamed into place
only when complete, so an interrupted or failed run never leaves a partial file behind.
"""
from __future__ import annotations

import csv
import json
import os
import platform
import tempfile
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from ..errors import GeoStructureError

#: The stable contract other tools and issues read; more columns may follow these.
PLANE_COLUMNS = ("region_id", "n_points", "area_m2", "centroid_x", "centroid_y", "centroid_z",
                 "normal_x", "normal_y", "normal_z", "strike", "dip", "dip_direction")
EXTRA_COLUMNS = ("rect_width", "rect_height", "fit_residual", "n_voxels", "normal_scatter_deg",
                 "normal_uncertainty_deg", "rect_center_x", "rect_center_y", "rect_center_z",
                 "rect_u_x", "rect_u_y", "rect_u_z")


def _file_mode() -> int:
    """The mode an ordinary new file gets under the current umask (mkstemp would give 0600)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return 0o666 & ~mask


@contextmanager
def atomic_path(path):
    """Yield a temporary path beside ``path``; rename it onto ``path`` if the block succeeds."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    os.chmod(tmp, _file_mode())
    try:
        yield Path(tmp)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def prepare_outdir(outdir) -> Path:
    outdir = Path(outdir)
    try:
        outdir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise GeoStructureError(f"{outdir}: cannot create the output folder ({exc.strerror}).") from None
    if not os.access(outdir, os.W_OK):
        raise GeoStructureError(f"{outdir}: the output folder is not writable.")
    return outdir


def plane_rows(result) -> list[dict]:
    """One dict per plane with :data:`PLANE_COLUMNS` then :data:`EXTRA_COLUMNS`."""
    rows = []
    centroids = result.centroids
    o = result.orientation
    for i, plane in enumerate(result.planes):
        values = [i, plane.n_points, plane.area, *centroids[i], *result.normals[i], o.strike[i], o.dip[i],
                  o.dip_direction[i], plane.width, plane.height, plane.residual,
                  int(result.n_voxels[i]), result.scatter[i], result.uncertainty[i],
                  *(plane.center + result.cloud.offset), *plane.u]
        rows.append(dict(zip(PLANE_COLUMNS + EXTRA_COLUMNS, values)))
    return rows


def _format(value) -> str:
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    return f"{float(value):.10g}"


def write_planes_csv(result, path) -> Path:
    """``planes.csv``: one row per plane, largest first, in the input's own coordinates."""
    return write_table_csv(plane_rows(result), path, columns=PLANE_COLUMNS + EXTRA_COLUMNS)


def write_regions_ply(result, path) -> Path:
    """``regions.ply``: the filtered points (double) with an int ``region_id`` (-1 for none).

    CloudCompare shows ``region_id`` as a scalar field.
    """
    from plyfile import PlyData, PlyElement

    points = result.filtered.points
    vertex = np.empty(len(points), dtype=[("x", "f8"), ("y", "f8"), ("z", "f8"), ("region_id", "i4")])
    vertex["x"], vertex["y"], vertex["z"] = points.T
    vertex["region_id"] = result.labels
    with atomic_path(path) as tmp:
        PlyData([PlyElement.describe(vertex, "vertex")], text=False,
                comments=["written by geostructure", f"source {Path(result.cloud.source).name}"]).write(str(tmp))
    return Path(path)


def write_voxel_planes_ply(result, path) -> Path:
    """``voxel_planes.ply``: each fitted voxel's centroid (double) with its unit normal, point
    count and ``region_id`` (-1 for none): the paper's "voxel planes" stage, as a cloud with
    normals that CloudCompare shows as such."""
    from plyfile import PlyData, PlyElement

    voxels = result.voxels
    vertex = np.empty(len(voxels), dtype=[("x", "f8"), ("y", "f8"), ("z", "f8"), ("nx", "f4"), ("ny", "f4"),
                                          ("nz", "f4"), ("count", "i4"), ("region_id", "i4")])
    centroids = voxels.centroid + result.cloud.offset
    vertex["x"], vertex["y"], vertex["z"] = centroids.T
    vertex["nx"], vertex["ny"], vertex["nz"] = voxels.normal.T
    vertex["count"] = voxels.count
    vertex["region_id"] = result.voxel_labels
    with atomic_path(path) as tmp:
        PlyData([PlyElement.describe(vertex, "vertex")], text=False,
                comments=["written by geostructure", f"voxel_edge {voxels.edge!r}"]).write(str(tmp))
    return Path(path)


def run_record(result, extra: dict | None = None) -> dict:
    """Parameters, frame, versions, point counts and seconds per stage, as plain JSON values."""
    import scipy

    from .. import __version__

    record = {
        "input": str(result.cloud.source),
        "offset": result.cloud.offset.tolist(),
        "crs": result.cloud.crs,
        "enu_origin": None if result.cloud.enu_origin is None else list(result.cloud.enu_origin),
        "params": result.params.to_dict(),
        "frame": {"name": result.frame.name, "rotation": [list(r) for r in result.frame.rotation],
                  "declination": result.frame.declination},
        "voxel_edge": result.voxels.edge,
        "counts": {k: int(v) for k, v in result.counts.items()},
        "seconds": {k: round(float(v), 4) for k, v in result.seconds.items()},
        "versions": {"geostructure": __version__, "python": platform.python_version(),
                     "numpy": np.__version__, "scipy": scipy.__version__},
    }
    record.update(extra or {})
    return record


def write_json(data: dict, path) -> Path:
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(data, indent=2, default=_json_default) + "\n")
    return Path(path)


def _json_default(value):
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")


def write_outputs(result, outdir, extra: dict | None = None) -> dict[str, Path]:
    """Write planes.csv, planes_dips.csv, planes.geojson, regions.ply, voxel_planes.ply and
    run.json into ``outdir``; returns their paths."""
    from ..report.exports import write_dips_csv, write_geojson

    outdir = prepare_outdir(outdir)
    return {
        "planes": write_planes_csv(result, outdir / "planes.csv"),
        "dips": write_dips_csv(result, outdir / "planes_dips.csv"),
        "geojson": write_geojson(result, outdir / "planes.geojson"),
        "regions": write_regions_ply(result, outdir / "regions.ply"),
        "voxels": write_voxel_planes_ply(result, outdir / "voxel_planes.ply"),
        "run": write_json(run_record(result, extra), outdir / "run.json"),
    }


def write_table_csv(rows: list[dict], path, columns=None) -> Path:
    """A list of same-keyed dicts as CSV; the header is ``columns`` or the first row's keys,
    so a table with no rows still has its header when ``columns`` is given."""
    header = list(columns) if columns is not None else (list(rows[0]) if rows else [])
    with atomic_path(path) as tmp:
        with open(tmp, "w", newline="") as fh:
            writer = csv.writer(fh)
            if header:
                writer.writerow(header)
            for row in rows:
                writer.writerow([v if isinstance(v, str) else _format(v) for v in row.values()])
    return Path(path)


def write_evaluation(evaluation, outdir, extra: dict | None = None) -> dict[str, Path]:
    """``evaluation.csv`` (one row per ground-truth surface) and ``evaluation.json`` (scores)."""
    from dataclasses import asdict

    outdir = prepare_outdir(outdir)
    return {"evaluation_csv": write_table_csv([asdict(s) for s in evaluation.surfaces], outdir / "evaluation.csv"),
            "evaluation_json": write_json({**evaluation.summary(), **(extra or {})}, outdir / "evaluation.json")}
