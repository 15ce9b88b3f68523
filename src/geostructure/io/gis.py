"""GIS files of the planes: ``planes.geojson`` (RFC 7946) and ``planes.gpkg`` (GeoPackage).

A GIS places a feature on Earth from its coordinate reference system (CRS), so these files
are written only for a cloud that has one: declared by its file (LAS/LAZ), given with
``--crs``, or a reconstruction's local east-north-up frame about a WGS84 origin. Without
one, no file claims a place it does not know (:data:`NO_CRS_NOTE`).

- ``planes.geojson``: RFC 7946 has a single CRS, WGS84 longitude/latitude, and no ``crs``
  member (GDAL, so QGIS, ignores one). The corners are transformed with pyproj from the
  cloud's CRS; heights are the cloud's own, in metres (its vertical datum is not changed).
- ``planes.gpkg``: QGIS's own format, in the cloud's native CRS (no loss from a transform),
  with two layers: ``planes``, the region rectangles as 3-D polygons carrying every column
  of the plane table (sets, traces, kinematics when present), and ``centroids``, points
  carrying the same for strike/dip map symbols.
"""

from __future__ import annotations

import warnings
from functools import lru_cache
from pathlib import Path

import numpy as np

from ..errors import GeoStructureError, InputError
from ..geodesy import enu_to_geodetic
from .atomic import atomic_path, json_text

#: The line a run prints when its cloud has no CRS.
NO_CRS_NOTE = (
    "no GIS files (planes.geojson, planes.gpkg): the cloud declares no coordinate system; "
    "give it with --crs EPSG:XXXX (or a WKT file) to place the planes on a map."
)
#: Plane-table columns a GIS does not need (each feature's geometry holds them).
GEOMETRY_COLUMNS = ("rect_u_x", "rect_u_y", "rect_u_z", "rect_v_x", "rect_v_y", "rect_v_z")


@lru_cache(maxsize=16)
def parse_crs(text: str, source: str = "--crs"):
    """A ``pyproj.CRS`` from ``EPSG:XXXX``, a WKT/PROJ string or a file holding WKT.

    Kept for the texts seen last: a run's GeoJSON, GeoPackage and two LAZ files ask it of
    the same CRS, and PROJ parses a long WKT in milliseconds each time.

    Examples
    --------
    >>> parse_crs("EPSG:32633").name
    'WGS 84 / UTM zone 33N'
    """
    from pyproj import CRS
    from pyproj.exceptions import CRSError

    looks_like_crs = text.lstrip().upper().startswith(("EPSG:", "ESRI:", "+PROJ")) or "[" in text
    if not looks_like_crs:
        path = Path(text)
        if not path.is_file():
            raise GeoStructureError(f"{source}: {text}: neither EPSG:XXXX nor a file holding WKT.")
        text = path.read_text(encoding="utf-8", errors="replace")
        source = str(path)
    try:
        return CRS.from_user_input(text)
    except CRSError:
        raise GeoStructureError(
            f"{source}: not a coordinate reference system PROJ knows (give EPSG:XXXX or WKT)."
        ) from None


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


def check_cloud_crs(crs: str | None, source: str) -> None:
    """Refuse a cloud whose axes do not share one length unit, where no dip, area or spacing
    means anything: a geographic CRS (x and y longitude and latitude in degrees, z in metres),
    or a compound one whose heights are in another unit than its positions (a State Plane in
    feet with NAVD88 heights in metres: every dip would be off). International and US survey
    feet (2 ppm apart) pass. A CRS PROJ cannot read is left to the writers that need it.

    Examples
    --------
    >>> check_cloud_crs("EPSG:32633", "cloud.laz"), check_cloud_crs("EPSG:2992+6360", "cloud.laz")
    (None, None)
    >>> check_cloud_crs("EPSG:2992+5703", "cloud.laz")
    Traceback (most recent call last):
    ...
    geostructure.errors.InputError: cloud.laz: the CRS NAD83 / Oregon GIC Lambert (ft) + NAVD88 height gives heights in metre and positions in foot; dips need one unit on all three axes: convert the heights to the positions' unit first.
    >>> check_cloud_crs("EPSG:4326", "cloud.laz")
    Traceback (most recent call last):
    ...
    geostructure.errors.InputError: cloud.laz: the CRS WGS 84 is geographic (longitude and latitude in degrees); reproject the cloud to a projected CRS in metres or feet (a UTM zone, a State Plane) first.
    """
    if crs is None:
        return
    try:
        parsed = parse_crs(crs, source)
    except GeoStructureError:
        return
    if parsed.is_geographic:
        raise InputError(
            f"{source}: the CRS {parsed.name} is geographic (longitude and latitude in degrees); reproject "
            f"the cloud to a projected CRS in metres or feet (a UTM zone, a State Plane) first."
        )
    axes = [a for a in parsed.axis_info if a.unit_conversion_factor]
    if len(axes) == 3 and abs(axes[2].unit_conversion_factor / axes[0].unit_conversion_factor - 1.0) > 1e-4:
        raise InputError(
            f"{source}: the CRS {parsed.name} gives heights in {axes[2].unit_name} and positions in "
            f"{axes[0].unit_name}; dips need one unit on all three axes: convert the heights to the "
            f"positions' unit first."
        )


def grid_convergence(crs: str, xy) -> np.ndarray:
    """The grid convergence (degrees) at points ``xy`` (n, 2) of a projected CRS: the true
    azimuth of grid north, east positive (a true azimuth is the grid one plus it). 0 where
    the CRS is not projected. Read from the projection itself: the grid direction of a step
    north along the meridian, through the CRS's own geodetic datum.

    Examples
    --------
    >>> round(float(grid_convergence("EPSG:32633", [[500000.0, 5000000.0]])[0]), 6) + 0.0  # on the central meridian
    0.0
    >>> x = 500000.0 + 157_500.0  # about 2 degrees east of it, at 45 N: Delta lambda sin(phi)
    >>> round(float(grid_convergence("EPSG:32633", [[x, 4984000.0]])[0]), 2)
    1.41
    """
    from pyproj import Transformer

    xy = np.atleast_2d(np.asarray(xy, dtype=np.float64))
    parsed = parse_crs(crs)
    horizontal = parsed.sub_crs_list[0] if parsed.is_compound else parsed
    if not horizontal.is_projected:
        return np.zeros(len(xy))
    geodetic = horizontal.geodetic_crs
    lon, lat = Transformer.from_crs(horizontal, geodetic, always_xy=True).transform(xy[:, 0], xy[:, 1])
    x, y = Transformer.from_crs(geodetic, horizontal, always_xy=True).transform(lon, np.asarray(lat) + 1e-5)
    return -np.degrees(np.arctan2(np.asarray(x) - xy[:, 0], np.asarray(y) - xy[:, 1]))


def true_north_frame(frame, crs: str | None, lower, upper):
    """The frame that reads a projected cloud's azimuths against true north, and what
    ``run.json`` says of it.

    A projected CRS's y axis is grid north, which leans from true north by the grid
    convergence (up to about 3 degrees at a UTM zone's edge, more in a wide Lambert zone):
    a compass, and every dip direction a geologist has taken by hand, read true (or
    magnetic) north. The frame (``enu``, the axes of a projected CRS) is turned by the
    convergence at the middle of the cloud's bounds (``lower``, ``upper``, absolute); the
    record gives it and its least and greatest over the bounds' corners, as one frame reads
    the whole cloud. Other frames, and clouds without a projected CRS, are left as they are
    (None for the record).

    Examples
    --------
    >>> from geostructure.orientation import Frame
    >>> frame, north = true_north_frame(Frame(), "EPSG:32633", [657000.0, 4983000, 0], [658000.0, 4985000, 50])
    >>> frame.name, round(north["grid_convergence_deg"], 2), north["reference"]
    ('enu, true north', 1.41, 'true north')
    """
    try:
        projected = crs is not None and parse_crs(crs).is_projected
    except GeoStructureError:  # a CRS PROJ cannot read: left as it is, as for the other checks
        projected = False
    if not projected or frame.name != "enu":
        return frame, None
    lower, upper = np.asarray(lower, dtype=np.float64), np.asarray(upper, dtype=np.float64)
    corners = np.array([[x, y] for x in (lower[0], upper[0]) for y in (lower[1], upper[1])])
    middle = (lower[:2] + upper[:2]) / 2
    gamma = grid_convergence(crs, np.vstack([middle, corners]))
    record = {
        "reference": "true north",
        "grid_convergence_deg": float(gamma[0]),
        "grid_convergence_range_deg": [float(gamma.min()), float(gamma.max())],
    }
    return frame.turned(float(gamma[0]), "enu, true north"), record


def describe_north(north: dict) -> str:
    """A line on the north a run read azimuths against (:func:`true_north_frame`'s record).

    Examples
    --------
    >>> describe_north({"grid_convergence_deg": 1.4145, "grid_convergence_range_deg": [1.41, 1.42]})
    "azimuths read against true north: the grid convergence at the cloud's centre is +1.41 deg (--grid-north for grid azimuths)"
    """
    return (
        f"azimuths read against true north: the grid convergence at the cloud's centre is "
        f"{north['grid_convergence_deg']:+.2f} deg (--grid-north for grid azimuths)"
    )


#: Symbols of the linear units clouds come in, by metres per unit.
UNIT_SYMBOLS = {1.0: "m", 0.3048: "ft", 1200.0 / 3937.0: "US ft"}


def unit_symbol(crs: str | None) -> str:
    """The symbol of a cloud's length unit, for the labels of figures in its own unit.

    Examples
    --------
    >>> unit_symbol("EPSG:2992"), unit_symbol("EPSG:2227"), unit_symbol(None)
    ('ft', 'US ft', 'm')
    """
    factor = metres_per_unit(crs)
    # PROJ's US survey foot differs from 1200 / 3937 in the last bit.
    return next((symbol for f, symbol in UNIT_SYMBOLS.items() if abs(f - factor) <= 1e-12 * f), f"{factor:g} m")


def metres_per_unit(crs: str | None) -> float:
    """Metres in one unit of a cloud's coordinates: its CRS's linear unit (0.3048 for a State
    Plane in international feet), 1 for a cloud without a CRS (taken to be in metres). The
    vertical is taken in the same unit, as LAS files in feet hold it.

    Examples
    --------
    >>> metres_per_unit("EPSG:2992"), metres_per_unit("EPSG:32633"), metres_per_unit(None)
    (0.3048, 1.0, 1.0)
    """
    if crs is None:
        return 1.0
    axes = parse_crs(crs).axis_info
    factor = axes[0].unit_conversion_factor if axes and axes[0].unit_name not in ("degree", "radian") else None
    return float(factor) if factor else 1.0


def _properties(planes) -> list[dict]:
    return [{k: v for k, v in row.items() if k not in GEOMETRY_COLUMNS} for row in planes.rows()]


def geojson(planes, crs: str | None = None, enu_origin=None) -> dict:
    """The region rectangles as RFC 7946 polygons (longitude, latitude, height) with every
    column of the plane table as properties."""
    corners = planes.corners.reshape(-1, 3)
    lon_lat = _lon_lat(corners, crs, enu_origin).reshape(-1, 4, 3) if len(corners) else np.zeros((0, 4, 3))
    features = []
    for ring, properties in zip(lon_lat.tolist(), _properties(planes)):
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


def write_gpkg(planes, path, crs: str | None = None, enu_origin=None) -> Path:
    """``planes.gpkg``: layers ``planes`` (rectangles) and ``centroids`` (points), in the
    cloud's CRS (WGS84 for a frame about a GPS origin)."""
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
    return Path(path)
