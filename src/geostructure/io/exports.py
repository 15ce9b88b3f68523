"""Exports for other tools: the Dips/Stereonet CSV and the traces' DXF (the GIS files: :mod:`.gis`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from geostructure.io.atomic import atomic_path, write_columns_csv, write_table_csv

#: The columns of ``planes_dips.csv`` always written; ``Set`` follows the orientation pair
#: when the planes have sets.
DIPS_COLUMNS = ("Dip Direction", "Dip", "X (East)", "Y (North)", "Z (Elev.)", "Region", "Points")


#: What a plane is when it is no discontinuity, by the plane table's flag column, in the
#: order a plane is named by (a plane flagged twice takes the first).
KINDS = {"ground": "ground", "clutter": "clutter", "face_surface": "face surface"}


def plane_kinds(planes) -> list[str]:
    """Each plane's ``Kind`` in ``planes_dips.csv``: ``ground``, ``clutter`` (vegetation,
    debris) or ``face surface`` (the face's own surface on rough rock), else ``discontinuity``.

    Examples
    --------
    >>> from geostructure.core.planes import Planes
    >>> planes = Planes(normal=[[0, 0, 1.0]] * 3).with_columns(clutter=[0, 1, 0], face_surface=[0, 0, 1])
    >>> plane_kinds(planes)
    ['discontinuity', 'clutter', 'face surface']
    """
    kinds = ["discontinuity"] * len(planes)
    for flag, word in reversed(list(KINDS.items())):
        marked = np.asarray(planes.extra.get(flag, np.zeros(len(planes))), dtype=np.float64) > 0
        for i in np.flatnonzero(marked):
            kinds[i] = word
    return kinds


def write_dips_csv(planes, path, rotation=None) -> Path:
    """``planes_dips.csv``, for Rocscience Dips and Allmendinger's Stereonet.

    Dip Direction and Dip first (the orientation pair, as field notebooks write it), then
    ``Set`` when the planes have sets, then Dips' location columns and, as extra columns, the region id, its point count and, with
    the rock mass, its joint (``joints.csv``'s number, blank for a plane in no set) and its
    ``Kind`` (:func:`plane_kinds`: a Dips filter keeps the discontinuities, where the ground,
    the clutter and the face's own surface would read as poles in no set). Dips
    numbers its sets from 1 and leaves a pole in no set blank: ``Set`` is the run's set
    number plus one (set 0 of ``sets.csv`` is Set 1 here), empty for a plane in no set.

    The location columns hold east, north and elevation: the centroid turned by
    ``rotation`` (3 x 3, rows the frame's unit east, north and up in the cloud's axes, as
    :class:`~geostructure.core.orientation.Frame` holds them), or the centroid as it is when
    ``rotation`` is None (a cloud in a coordinate system, whose x and y are its eastings
    and northings). In the ``paper`` frame (x north, y west) Dips would otherwise place
    every plane a quarter turn away.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from geostructure.core.planes import Planes
    >>> planes = Planes(normal=[[0, 0.5, 0.866], [1.0, 0, 0.01]]).with_columns(set=[0, -1])
    >>> path = write_dips_csv(planes, pathlib.Path(tempfile.mkdtemp()) / "planes_dips.csv")
    >>> print(path.read_text().splitlines()[0])
    Dip Direction,Dip,Set,X (East),Y (North),Z (Elev.),Region,Points
    >>> [line.split(",")[:3] for line in path.read_text().splitlines()[1:]]
    [['0.0', '30.0', '1'], ['90.0', '89.43', '']]
    """
    # A level plane has no dip direction (blank in planes.csv); Dips needs a number, and at
    # a dip of 0 any direction puts its pole at the centre.
    values = {
        "Dip Direction": [round(v, 2) if v == v else 0.0 for v in planes.dip_direction.tolist()],
        "Dip": [round(v, 2) for v in planes.dip.tolist()],
    }
    if "set" in planes.extra:
        values["Set"] = ["" if s < 0 else str(s + 1) for s in planes.extra["set"].astype(int).tolist()]
    centroid = planes.centroid if rotation is None else planes.centroid @ np.asarray(rotation, dtype=np.float64).T
    for axis, name in enumerate(DIPS_COLUMNS[2:5]):
        values[name] = centroid[:, axis].tolist()
    values["Region"] = planes.region_id.tolist()
    values["Points"] = planes.n_points.tolist()
    if "joint" in planes.extra:  # the discontinuity it is a facet of (joints.csv), blank for none
        values["Joint"] = ["" if j < 0 else str(j) for j in planes.extra["joint"].astype(int).tolist()]
    if any(k in planes.extra for k in KINDS):  # a column Dips filters on: no joint looks like one in no set
        values["Kind"] = plane_kinds(planes)
    rows = [dict(zip(values, row)) for row in zip(*values.values())]
    return write_table_csv(rows, path, columns=list(values))


def write_traces_dxf(polylines, sets, path) -> Path:
    """``traces.dxf``: each fracture trace a 3D polyline (DXF R12, ezdxf's stream writer) in
    the cloud's own coordinates to the micrometre, on a layer per set (``set_0``, ``set_1``,
    ..., ``no_set``) and in its set's colour (:data:`SET_ACI`), as DICE, CloudCompare and CAD
    programs read them. R12 needs no layer table (a program makes each layer it meets); its
    stream writer writes the ODM Brighton survey's 2,458 traces in 0.2 s, where ezdxf's
    document model took 1.7 s.

    Examples
    --------
    >>> import tempfile, pathlib, ezdxf
    >>> path = write_traces_dxf([np.array([[276774.0, 5151643.0, 2388.0], [276774.5, 5151643.2, 2387.9]])], [1],
    ...                         pathlib.Path(tempfile.mkdtemp()) / "traces.dxf")
    >>> line = next(iter(ezdxf.readfile(path).modelspace()))
    >>> line.dxftype(), line.dxf.layer, line.dxf.color, line.is_3d_polyline, [round(v, 1) for v in list(line.points())[1]]
    ('POLYLINE', 'set_1', 30, True, [276774.5, 5151643.2, 2387.9])
    """
    from ezdxf.addons import r12writer  # lazy: read only when traces are written

    with atomic_path(path) as tmp:
        with r12writer(str(tmp), fixed_tables=True) as drawing:
            for line, s in zip(polylines, sets):
                layer = f"set_{int(s)}" if s >= 0 else "no_set"
                colour = SET_ACI[int(s) % len(SET_ACI)] if s >= 0 else NO_SET_ACI
                drawing.add_polyline([tuple(map(float, p)) for p in line], layer=layer, color=colour)
    return Path(path)


#: The traces' colours in the DXF, AutoCAD's colour indices: sets 0, 1, 2, ... blue, orange,
#: green, magenta, cyan, yellow, red, as the report's 3D view and stereonet begin; no set grey.
SET_ACI = (5, 30, 3, 6, 4, 2, 1)
NO_SET_ACI = 8


def write_table(rows, path, columns=None) -> Path:
    """A table as CSV: rows (:func:`~.atomic.write_table_csv`) or columns (a dict of name -> array,
    :func:`~.atomic.write_columns_csv`, in the order of ``columns``); for a ``.dxf`` path,
    polylines and their sets (:func:`write_traces_dxf`)."""
    if Path(path).suffix == ".dxf":
        return write_traces_dxf(*rows, path)
    if isinstance(rows, dict):
        return write_columns_csv({name: rows[name] for name in (columns or rows)}, path)
    return write_table_csv(rows, path, columns=columns)
