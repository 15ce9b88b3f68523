"""Exports for other tools: Dips/Stereonet CSV and GeoJSON of the region rectangles."""

from __future__ import annotations

from pathlib import Path

from ..geodesy import enu_to_geodetic
from .atomic import atomic_path, json_text, write_table_csv


def write_dips_csv(planes, path) -> Path:
    """``planes_dips.csv``: Dip Direction, Dip first (the layout Rocscience Dips and
    Allmendinger's Stereonet import), then the region id and its point count, and its joint
    set (-1 for none) when the planes have one."""
    columns = ["Dip Direction", "Dip", "Region", "Points"]
    values = [
        [round(v, 2) for v in planes.dip_direction.tolist()],
        [round(v, 2) for v in planes.dip.tolist()],
        planes.region_id.tolist(),
        planes.n_points.tolist(),
    ]
    if "set" in planes.extra:
        columns.append("Set")
        values.append(planes.extra["set"].astype(int).tolist())
    rows = [dict(zip(columns, row)) for row in zip(*values)]
    return write_table_csv(rows, path, columns=columns)


def geojson(planes, crs: str | None = None, enu_origin=None) -> dict:
    """The region rectangles of a :class:`~geostructure.planes.Planes` table as 3-D
    polygons with their orientation as properties.

    Coordinates are the input's own, and the CRS is named when the input declared one;
    a cloud in local east-north-up metres about a WGS84 origin (a GPS-referenced
    reconstruction) is written as GeoJSON proper: longitude, latitude, altitude.
    """
    features = []
    for i, (corners, row) in enumerate(zip(planes.corners, planes.rows())):
        if enu_origin is not None:
            corners = enu_to_geodetic(corners, enu_origin)[:, [1, 0, 2]]
        ring = corners.tolist()
        features.append(
            {
                "type": "Feature",
                "geometry": {"type": "Polygon", "coordinates": [ring + [ring[0]]]},
                "properties": {
                    "region_id": row["region_id"],
                    "strike": row["strike"],
                    "dip": row["dip"],
                    "dip_direction": row["dip_direction"],
                    "n_points": row["n_points"],
                    "area": row["area_m2"],
                    "rect_width": row["rect_width"],
                    "rect_height": row["rect_height"],
                    "normal_uncertainty_deg": row["normal_uncertainty_deg"],
                },
            }
        )
    data = {"type": "FeatureCollection", "features": features}
    if crs and crs.startswith("EPSG:"):
        data["crs"] = {"type": "name", "properties": {"name": f"urn:ogc:def:crs:EPSG::{crs[5:]}"}}
    elif crs:
        data["crs_wkt"] = crs  # a foreign member: GeoJSON has no place for WKT
    return data


def write_geojson(planes, path, crs: str | None = None, enu_origin=None) -> Path:
    """``planes.geojson``: :func:`geojson` written atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(json_text(geojson(planes, crs, enu_origin), indent=None), encoding="utf-8")
    return Path(path)
