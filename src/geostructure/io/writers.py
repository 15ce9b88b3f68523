"""Writers: planes.csv (through :class:`~geostructure.core.planes.Planes`), regions.ply/.laz,
voxel_planes.ply/.laz and run.json.

Each writer writes one file atomically (:mod:`.atomic`); :func:`write_outputs` writes the
whole set through :mod:`.outdir`, so it appears in the folder together or not at all.
"""

from __future__ import annotations

import platform
from pathlib import Path

import numpy as np

from geostructure import __version__
from geostructure.core.threads import finished_pool, preload
from geostructure.io.atomic import atomic_path, write_json, write_table_csv
from geostructure.io.crs import recorded_unit
from geostructure.io.exports import write_dips_csv, write_table
from geostructure.io.gis import write_geojson, write_gpkg
from geostructure.io.laz import (
    POINT_SET_DIMENSIONS,
    point_joints,
    point_sets,
    write_regions_laz,
    write_voxel_planes_laz,
)
from geostructure.io.outdir import EVALUATION_FILES, OutputSet, output_set
from geostructure.io.planetable import write_planes_csv
from geostructure.io.results import PLANE_AREA, SCALAR, in_square_metres


def ply_comment(text: str) -> str:
    """A PLY comment must be ASCII on one line: other characters are written as escapes
    (café -> caf\\xe9, a newline in a file name -> \\n)."""
    text = text.encode("ascii", "backslashreplace").decode("ascii")
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


#: The per-point fields ``regions.ply`` carries after ``--sets``, as CloudCompare's scalar
#: fields (``scalar_set``, ``scalar_face_part``, ``scalar_joint``): the dimensions
#: ``regions.laz`` carries (:data:`~.laz.POINT_SET_DIMENSIONS`), for a CloudCompare that reads
#: no LAS (Debian's 2.11).
POINT_SET_FIELDS = tuple((SCALAR + name, np.dtype(kind).str) for name, kind in POINT_SET_DIMENSIONS)
#: PLY's names of the numpy types the point files hold.
PLY_TYPES = {"f8": "double", "f4": "float", "i4": "int", "i2": "short", "u1": "uchar"}


def regions_dtype(vegetation: bool, point_sets: bool, grey: bool = False) -> np.dtype:
    """The vertex record of ``regions.ply``: x, y, z (double), ``scalar_region_id``, then a
    ``scalar_vegetation`` flag, a ``scalar_grey`` brightness and the :data:`POINT_SET_FIELDS`
    when asked."""
    fields = [("x", "<f8"), ("y", "<f8"), ("z", "<f8"), (SCALAR + "region_id", "<i4")]
    fields += [(SCALAR + "vegetation", "u1")] if vegetation else []
    fields += [(SCALAR + "grey", "<f4")] if grey else []
    return np.dtype(fields + (list(POINT_SET_FIELDS) if point_sets else []))


def ply_header(dtype: np.dtype, n_points: int, comments) -> bytes:
    """A binary little-endian PLY header for ``n_points`` vertices of ``dtype``."""
    lines = ["ply", "format binary_little_endian 1.0", *(f"comment {c}" for c in comments)]
    lines.append(f"element vertex {n_points}")
    lines += [f"property {PLY_TYPES[dtype[name].str[1:]]} {name}" for name in dtype.names]
    return ("\n".join(lines) + "\nend_header\n").encode("ascii")


def regions_comments(source: str) -> list[str]:
    """``regions.ply``'s comments: who wrote it and from which file."""
    return ["written by geostructure", f"source {ply_comment(Path(source).name)}"]


def write_regions_ply(result, path, point_sets: dict | None = None) -> Path:
    """``regions.ply``: the filtered points (double) with an int ``scalar_region_id`` (-1 for
    none), a ``scalar_vegetation`` flag (1 for a point the input classifies as vegetation)
    when the input classifies any so and a ``scalar_grey`` (0 to 1) when it has colour, for
    ``geostructure sets`` to read back, and with
    ``point_sets`` (``set``, ``face_part``, ``joint`` per point, as :func:`~.laz.write_regions_laz`
    takes them) the :data:`POINT_SET_FIELDS`.

    The ``scalar_`` prefix is what CloudCompare's PLY reader asks, in its command-line mode
    (no dialog), to load a property as a scalar field (named ``region_id`` there).
    """
    filtered = result.filtered
    dtype = regions_dtype(filtered.vegetation is not None, point_sets is not None, filtered.grey is not None)
    vertex = np.empty(len(filtered), dtype=dtype)
    for axis, name in enumerate("xyz"):  # Cloud.points column by column, into the record itself
        np.add(filtered.local[:, axis], filtered.offset[axis], out=vertex[name])
    vertex[SCALAR + "region_id"] = result.labels
    if filtered.vegetation is not None:
        vertex[SCALAR + "vegetation"] = filtered.vegetation
    if filtered.grey is not None:  # for the traces' dark lines when ``sets`` reads the folder again
        vertex[SCALAR + "grey"] = filtered.grey
    for name, value in (point_sets or {}).items():
        vertex[SCALAR + name] = value
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        fh.write(ply_header(vertex.dtype, len(vertex), regions_comments(result.cloud.source)))
        vertex.tofile(fh)
    return Path(path)


def rewrite_regions_ply(source, path, values, rows: int) -> Path:
    """Write ``source`` (a ``regions.ply``) again to ``path``, ``rows`` points at a time, each
    with its fields as they were and the :data:`POINT_SET_FIELDS` from ``values`` (an
    iterable of dicts, name -> array, per ``rows`` points, in the file's order): ``sets``
    on a measured folder, whose point files gain the sets it found."""
    from plyfile import PlyData

    data = PlyData.read(str(source), mmap=True)
    vertex = data["vertex"].data
    kept = [n for n in vertex.dtype.names if n not in dict(POINT_SET_FIELDS)]
    dtype = np.dtype([(n, vertex.dtype[n].newbyteorder("<")) for n in kept] + list(POINT_SET_FIELDS))
    values = iter(values)
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        fh.write(ply_header(dtype, len(vertex), data.comments))
        for start in range(0, len(vertex), rows):
            part = vertex[start : start + rows]
            out = np.empty(len(part), dtype=dtype)
            for name in kept:
                out[name] = part[name]
            fields = next(values)
            for name, value in fields.items():
                out[SCALAR + name] = value
            out.tofile(fh)
    return Path(path)


def write_vertex_ply(path, vertex: np.ndarray, comments: list[str]) -> Path:
    """A binary PLY of one ``vertex`` element (a structured array), atomically."""
    from plyfile import PlyData, PlyElement

    with atomic_path(path) as tmp:
        PlyData([PlyElement.describe(vertex, "vertex")], text=False, comments=comments).write(str(tmp))
    return Path(path)


def write_voxel_planes_ply(result, path) -> Path:
    """``voxel_planes.ply``: each fitted voxel's centroid (double) with its unit normal, point
    count and region id (-1 for none), as CloudCompare's scalar fields: the paper's "voxel planes" stage, as a cloud with
    normals that CloudCompare shows as such."""
    voxels = result.voxels
    vertex = np.empty(
        len(voxels),
        dtype=[
            ("x", "f8"),
            ("y", "f8"),
            ("z", "f8"),
            ("nx", "f4"),
            ("ny", "f4"),
            ("nz", "f4"),
            (SCALAR + "count", "i4"),
            (SCALAR + "region_id", "i4"),
        ],
    )
    centroids = voxels.centroid + result.cloud.offset
    vertex["x"], vertex["y"], vertex["z"] = centroids.T
    vertex["nx"], vertex["ny"], vertex["nz"] = voxels.normal.T
    vertex[SCALAR + "count"] = voxels.count
    vertex[SCALAR + "region_id"] = result.voxel_labels
    return write_vertex_ply(path, vertex, ["written by geostructure", f"voxel_edge {voxels.edge!r}"])


def run_record(result, extra: dict | None = None) -> dict:
    """Parameters, frame, versions, point counts and seconds per stage, as plain JSON values."""
    import scipy

    record = {
        "input": str(result.cloud.source),
        "offset": result.cloud.offset.tolist(),
        "crs": result.cloud.crs,
        "enu_origin": None if result.cloud.enu_origin is None else list(result.cloud.enu_origin),
        "params": result.params.to_dict(),
        "frame": result.frame.to_dict(),
        "voxel_edge": result.voxels.edge,
        "counts": {k: int(v) for k, v in result.counts.items()},
        "seconds": {k: round(float(v), 4) for k, v in result.seconds.items()},
        "versions": {
            "geostructure": __version__,
            "python": platform.python_version(),
            "numpy": np.__version__,
            "scipy": scipy.__version__,
        },
    }
    if result.detection:
        record["detection"] = result.detection
    if result.cloud.left_out:  # points the file marked to be left out, not in counts.input
        record["left_out"] = dict(result.cloud.left_out)
    record.update(extra or {})
    return record


def write_plane_tables(planes, outputs: OutputSet, crs=None, enu_origin=None, traces=None) -> list[str]:
    """Stage ``planes.csv`` and ``planes_dips.csv`` of a plane table and, for a cloud with a
    coordinate system, ``planes.geojson`` and ``planes.gpkg`` (with the fracture ``traces``,
    :class:`~geostructure.detect.traces.Traces` in the planes' local coordinates, as its
    ``traces`` layer of lines); returns the names staged.
    Their ``area_m2`` is square metres, from the cloud's unit the set's record names
    (:func:`~.crs.recorded_unit`), and the record says so (:data:`~.results.PLANE_AREA`)."""
    planes = in_square_metres(planes, recorded_unit(outputs.record)["metres"])
    outputs.record.update(PLANE_AREA)
    write_planes_csv(planes, outputs.path("planes.csv"))
    # East, north and elevation for Dips: a CRS's own eastings and northings as they are;
    # otherwise the centroids turned into the measuring frame (identity for ENU clouds).
    frame = outputs.record.get("frame") or {}
    write_dips_csv(planes, outputs.path("planes_dips.csv"), None if crs else frame.get("rotation"))
    names = ["planes.csv", "planes_dips.csv"]
    if crs or enu_origin is not None:
        write_geojson(planes, outputs.path("planes.geojson"), crs=crs, enu_origin=enu_origin)
        write_gpkg(planes, outputs.path("planes.gpkg"), crs=crs, enu_origin=enu_origin, traces=traces)
        names += ["planes.geojson", "planes.gpkg"]
    return names


def write_result(
    result,
    outputs: OutputSet,
    extra: dict | None = None,
    *,
    planes=None,
    rock=None,
    tables=(),
    sets_record: dict | None = None,
    point_files=True,
) -> dict[str, Path]:
    """Stage the measure's files and its run record in an open :class:`~.outdir.OutputSet`.
    ``planes``: the plane table as written, with its sets' and rock mass's columns when
    measured (``result.planes`` when None); its ``set`` and ``joint`` columns label the
    points, and ``rock.point_part`` their part of the face. ``tables``: the rock mass's
    tables, (kind, file name, rows, columns) each (:func:`~geostructure.rockmass.tables.rock_mass_tables`),
    and ``sets_record`` what ``run.json`` says of the sets. Without ``point_files``,
    ``regions.ply`` and ``regions.laz`` are taken as staged already (a streamed run writes
    them chunk by chunk); a callable ``point_files(outputs, result, planes, rock)`` stages
    them itself (a thinned survey's, every point of the survey)."""
    files = {
        "planes": "planes.csv",
        "dips": "planes_dips.csv",
        "regions": "regions.ply",
        "regions_laz": "regions.laz",
        "voxels": "voxel_planes.ply",
        "voxels_laz": "voxel_planes.laz",
    }
    labelled_sets = planes is not None and "set" in planes.extra
    planes = result.planes if planes is None else planes
    # The two point files in threads while the tables are written here: the PLY is mostly
    # the kernel's copy into the page cache, the LAZ lazrs's compression, the tables Python's.
    # Leaving the pool waits for both, so an error or an interrupt finds them finished. The
    # libraries both sides import are imported first, here (threads.preload says why).
    outputs.record = run_record(result, extra)  # write_plane_tables reads the unit there, adds the area's
    preload("plyfile", "laspy", "lazrs")
    if callable(point_files):
        point_files(outputs, result, planes if labelled_sets else None, rock)
    with finished_pool(2) as pool:
        point_writes = []
        if point_files is True:
            labelled = point_sets(result.labels, planes) if labelled_sets else None
            joint = point_joints(result.labels, planes) if labelled_sets else None
            part = None if rock is None else rock.point_part
            point_fields = None
            if labelled_sets:
                point_fields = {"set": labelled, "joint": joint,
                                "face_part": np.zeros(len(labelled), np.uint8) if part is None else part}  # fmt: skip

            def written(write, name, *args) -> Path:  # hashed for the manifest in its thread, once written
                return outputs.hash_staged(write(result, outputs.path(files[name]), *args))

            point_writes = [
                pool.submit(written, write_regions_ply, "regions", point_fields),
                pool.submit(written, write_regions_laz, "regions_laz", labelled, part, joint),
            ]
        crs, enu_origin = result.cloud.crs, result.cloud.enu_origin
        traces = None if rock is None else rock.traces
        if "planes.gpkg" in write_plane_tables(planes, outputs, crs=crs, enu_origin=enu_origin, traces=traces):
            files.update(geojson="planes.geojson", gpkg="planes.gpkg")
        write_voxel_planes_ply(result, outputs.path(files["voxels"]))
        write_voxel_planes_laz(result, outputs.path(files["voxels_laz"]))
    for write in point_writes:
        write.result()
    for kind, name, rows, columns in tables:
        write_table(rows, outputs.path(name), columns=columns)
        files[kind] = name
        if kind == "sets" and sets_record is not None:  # run.json's order: right after the sets
            outputs.record["sets"] = sets_record
    outputs.write_record()
    return {key: outputs.final(name) for key, name in {**files, "run": "run.json"}.items()}


def write_outputs(result, outdir, extra: dict | None = None, *, inputs=()) -> dict[str, Path]:
    """Write planes.csv, planes_dips.csv, regions.ply and .laz, voxel_planes.ply and .laz,
    run.json and, with a coordinate system, planes.geojson and planes.gpkg into ``outdir``,
    all or none, replacing the folder's previous set.

    Parameters
    ----------
    result : Measurement
    outdir : str or Path
    extra : dict, optional
        More entries for ``run.json``.
    inputs : sequence of paths
        Files the run read, refused if they are among the outputs.

    Returns
    -------
    dict
        Output kind -> final path. :func:`geostructure.save_measurement` adds the evaluation
        and the report to the same set.

    Examples
    --------
    >>> import tempfile
    >>> from geostructure import measure
    >>> from geostructure.synthetic import observatory_scene
    >>> paths = write_outputs(measure(observatory_scene(30_000, seed=1).cloud), tempfile.mkdtemp())
    >>> paths["planes"].name, paths["run"].name
    ('planes.csv', 'run.json')
    """
    with output_set(outdir, inputs=inputs) as outputs:
        paths = write_result(result, outputs, extra)
    return paths


def write_evaluation_files(evaluation, folder, extra: dict | None = None) -> dict[str, Path]:
    """``evaluation.csv`` (one row per ground-truth surface) and ``evaluation.json`` (scores)
    in ``folder``, as they are (see :func:`write_evaluation` for an output folder)."""
    from dataclasses import asdict

    folder = Path(folder)
    return {
        "evaluation_csv": write_table_csv([asdict(s) for s in evaluation.surfaces], folder / "evaluation.csv"),
        "evaluation_json": write_json({**evaluation.summary(), **(extra or {})}, folder / "evaluation.json"),
    }


def write_evaluation(evaluation, outdir, extra: dict | None = None) -> dict[str, Path]:
    """Add the evaluation files to a measured output folder, as one set with its outputs."""
    with output_set(outdir, replace=False, rewrites=EVALUATION_FILES) as outputs:
        write_evaluation_files(evaluation, outputs.staging, extra)
    return {"evaluation_csv": outputs.final("evaluation.csv"), "evaluation_json": outputs.final("evaluation.json")}
