"""GIS files of the planes: ``planes.geojson`` (RFC 7946) and ``planes.gpkg`` (GeoPackage).

A GIS places a feature on Earth from its coordinate reference system (CRS), so these files
are written only for a cloud that has one: declared by its file (LAS/LAZ), given with
``--crs``, or a reconstruction's local east-north-up frame about a WGS84 origin. Without
one, no file claims a place it does not know (:data:`NO_CRS_NOTE`).

- ``planes.geojson``: RFC 7946 has a single CRS, WGS84 longitude/latitude, and no ``crs``
  member (GDAL, so QGIS, ignores one). The corners are transformed with pyproj from the
  cloud's CRS; heights are the cloud's own, in metres (its vertical datum is not changed).
  Its properties are the plane table's columns, the centroid as ``centroid_lon``,
  ``centroid_lat`` and ``centroid_height_m`` and the sizes in metres (no number in the
  cloud's CRS or unit); ``normal_x/y/z`` are in the cloud's own axes (a projected CRS's
  grid), ``dip_direction`` from true north where the run read it so.
- ``planes.gpkg``: QGIS's own format, in the cloud's native CRS (no loss from a transform),
  with two layers: ``planes``, the region rectangles as 3-D polygons carrying every column
  of the plane table (sets, traces, kinematics when present), and ``centroids``, points
  carrying the same for strike/dip map symbols.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from geostructure.core.geodesy import enu_to_geodetic
from geostructure.io.atomic import atomic_path, json_text
from geostructure.io.crs import metres_per_unit, parse_crs

#: The line a run prints when its cloud has no CRS.
NO_CRS_NOTE = (
    "no GIS files (planes.geojson, planes.gpkg): the cloud declares no coordinate system; "
    "give it with --crs EPSG:XXXX (or a WKT file) to place the planes on a map."
)
#: Plane-table columns a GIS does not need (each feature's geometry holds them).
GEOMETRY_COLUMNS = ("rect_u_x", "rect_u_y", "rect_u_z", "rect_v_x", "rect_v_y", "rect_v_z")


def _lon_lat(points: np.ndarray, crs=None, enu_origin=None) -> np.ndarray:
    """(N, 3) longitude, latitude, height of points in ``crs`` (or about ``enu_origin``)."""
    if enu_origin is not None:
        return enu_to_geodetic(points, enu_origin)[:, [1, 0, 2]]
    from pyproj import Transformer

    source = parse_crs(crs)
    to_wgs84 = Transformer.from_crs(source, "EPSG:4326", always_xy=True)
    lon, lat = to_wgs84.transform(points[:, 0], points[:, 1])
    # RFC 7946 heights are in metres: a cloud in feet (Oregon Lambert) is scaled, not moved
    # (its vertical datum stays the cloud's own).
    return np.column_stack([lon, lat, points[:, 2] * metres_per_unit(crs)])


#: Plane-table columns that are positions in the cloud's CRS: ``planes.geojson`` (WGS84)
#: gives the centroid as longitude, latitude and height in metres instead, so that no
#: number in the file is in another system than its geometry (Oregon feet on a WGS84 map).
CLOUD_POSITION_COLUMNS = ("centroid_x", "centroid_y", "centroid_z", "rect_center_x", "rect_center_y", "rect_center_z")


def _properties(planes, drop=GEOMETRY_COLUMNS) -> list[dict]:
    return [{k: v for k, v in row.items() if k not in drop} for row in planes.rows()]


#: Plane-table sizes in the cloud's unit: ``planes.geojson`` gives them in metres, named so.
CLOUD_SIZE_COLUMNS = ("rect_width", "rect_height", "fit_residual")


def _wgs84_properties(planes, crs, enu_origin) -> list[dict]:
    """The plane table's columns for ``planes.geojson``: positions as WGS84 longitude and
    latitude and height in metres (``centroid_lon``, ``centroid_lat``, ``centroid_height_m``)
    in place of the cloud's coordinates, its sizes in metres (``rect_width_m``,
    ``rect_height_m``, ``fit_residual_m``; a survey in feet gave them in feet beside metres),
    and no column that is empty for every plane (GDAL types such a column as text)."""
    rows = _properties(planes, GEOMETRY_COLUMNS + CLOUD_POSITION_COLUMNS)
    if not rows:
        return rows
    centres = _lon_lat(planes.centroid, crs, enu_origin)
    metres = 1.0 if enu_origin is not None else metres_per_unit(crs)
    named = ("centroid_lon", "centroid_lat", "centroid_height_m")
    out = []
    for centre, row in zip(centres.tolist(), rows):
        row = {**dict(zip(named, centre)), **row}
        for name in CLOUD_SIZE_COLUMNS:
            if name in row:
                value = row.pop(name)
                row[f"{name}_m"] = None if value is None else float(value) * metres
        out.append(row)
    empty = [name for name in out[0] if all(_blank(row.get(name)) for row in out)]
    return [{k: v for k, v in row.items() if k not in empty} for row in out]


def _blank(value) -> bool:
    return value is None or value == "" or (isinstance(value, float) and not np.isfinite(value))


def geojson(planes, crs: str | None = None, enu_origin=None) -> dict:
    """The region rectangles as RFC 7946 polygons (longitude, latitude, height) with every
    column of the plane table as properties, its positions in WGS84 too
    (:func:`_wgs84_properties`)."""
    corners = planes.corners.reshape(-1, 3)
    lon_lat = _lon_lat(corners, crs, enu_origin).reshape(-1, 4, 3) if len(corners) else np.zeros((0, 4, 3))
    features = []
    for ring, properties in zip(lon_lat.tolist(), _wgs84_properties(planes, crs, enu_origin)):
        # RFC 7946: exterior rings counter-clockwise seen from above
        x, y = np.array(ring)[:, 0], np.array(ring)[:, 1]
        if np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y) < 0:
            ring = ring[::-1]
        features.append(
            {
                "type": "Feature",
                "geometry": {"type": "Polygon", "coordinates": [ring + [ring[0]]]},
                "properties": properties,
            }
        )
    return {"type": "FeatureCollection", "features": features}


def write_geojson(planes, path, crs: str | None = None, enu_origin=None) -> Path:
    """``planes.geojson``: :func:`geojson`, written atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(json_text(geojson(planes, crs, enu_origin), indent=None), encoding="utf-8")
    return Path(path)


def write_gpkg(planes, path, crs: str | None = None, enu_origin=None, traces=None) -> Path:
    """``planes.gpkg``: layers ``planes`` (rectangles) and ``centroids`` (points), and with
    ``traces`` (:class:`~geostructure.detect.traces.Traces`, in the planes' local
    coordinates) a layer ``traces`` of 3-D lines (``trace_id``, ``set``, ``source``,
    ``length``, ``chord`` in the cloud's unit, ``censored_ends``), in the cloud's CRS (WGS84 for a frame about a
    GPS origin)."""
    import shapely
    from pyogrio.raw import write as write_layer

    if enu_origin is not None:
        rings = _lon_lat(planes.corners.reshape(-1, 3), enu_origin=enu_origin).reshape(-1, 4, 3)
        centres = _lon_lat(planes.centroid, enu_origin=enu_origin)
        wkt = "EPSG:4979"
    else:
        rings, centres, wkt = planes.corners, planes.centroid, parse_crs(crs).to_wkt()
    properties = _properties(planes)
    names = list(properties[0]) if properties else ["region_id"]
    fields = [np.array([row[n] for row in properties]) if properties else np.zeros(0) for n in names]
    closed = np.concatenate([rings, rings[:, :1]], axis=1) if len(rings) else np.zeros((0, 5, 3))
    polygons = shapely.to_wkb(shapely.polygons(closed), output_dimension=3)
    points = shapely.to_wkb(shapely.points(centres), output_dimension=3)
    with atomic_path(path) as tmp, warnings.catch_warnings():
        # GDAL would note that the temporary name does not end in .gpkg; the final one does.
        warnings.simplefilter("ignore", RuntimeWarning)
        tmp.unlink()  # a new GeoPackage, not one appended to
        for layer, geometry, kind in (("planes", polygons, "Polygon Z"), ("centroids", points, "Point Z")):
            write_layer(tmp, geometry, fields, names, layer=layer, driver="GPKG", geometry_type=kind, crs=wkt)
        if traces is not None and len(traces):
            lines = [line + planes.offset for line in traces.polylines()]
            if enu_origin is not None:
                lines = [_lon_lat(line, enu_origin=enu_origin) for line in lines]
            geometry = shapely.to_wkb(np.array([shapely.LineString(line) for line in lines]), output_dimension=3)
            columns = {"trace_id": np.arange(len(traces)), "set": traces.set.astype(np.int64),
                       "source": np.asarray(traces.source, dtype=str), "length": traces.length,
                       "chord": traces.chord, "censored_ends": traces.censored_ends.astype(np.int64)}  # fmt: skip
            write_layer(tmp, geometry, list(columns.values()), list(columns), layer="traces", driver="GPKG",
                        geometry_type="LineString Z", crs=wkt)  # fmt: skip
    return Path(path)
