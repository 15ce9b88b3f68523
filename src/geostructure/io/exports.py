"""Exports for other tools: Dips/Stereonet CSV and GeoJSON of the region rectangles."""

from __future__ import annotations

from pathlib import Path

from ..geodesy import enu_to_geodetic
from .atomic import atomic_path, json_text, write_table_csv


def write_dips_csv(result, path) -> Path:
    """``planes_dips.csv``: Dip Direction, Dip first (the layout Rocscience Dips and
    Allmendinger's Stereonet import), then the region id and its point count."""
    o = result.orientation
    rows = [
        {
            "Dip Direction": round(float(o.dip_direction[i]), 2),
            "Dip": round(float(o.dip[i]), 2),
            "Region": i,
            "Points": p.n_points,
        }
        for i, p in enumerate(result.planes)
    ]
    return write_table_csv(rows, path, columns=("Dip Direction", "Dip", "Region", "Points"))


def geojson(result) -> dict:
    """The region rectangles as 3-D polygons with their orientation as properties.

    Coordinates are the input's own, and the CRS is named when the input declared one;
    a cloud in local east-north-up metres about a WGS84 origin (a GPS-referenced
    reconstruction) is written as GeoJSON proper: longitude, latitude, altitude.
    """
    o = result.orientation
    origin = result.cloud.enu_origin
    features = []
    for i, plane in enumerate(result.planes):
        corners = plane.corners + result.cloud.offset
        if origin is not None:
            corners = enu_to_geodetic(corners, origin)[:, [1, 0, 2]]
        ring = corners.tolist()
        features.append(
            {
                "type": "Feature",
                "geometry": {"type": "Polygon", "coordinates": [ring + [ring[0]]]},
                "properties": {
                    "region_id": i,
                    "strike": float(o.strike[i]),
                    "dip": float(o.dip[i]),
                    "dip_direction": float(o.dip_direction[i]),
                    "n_points": plane.n_points,
                    "area": plane.area,
                    "rect_width": plane.width,
                    "rect_height": plane.height,
                    "normal_uncertainty_deg": float(result.uncertainty[i]),
                },
            }
        )
    data = {"type": "FeatureCollection", "features": features}
    crs = result.cloud.crs
    if crs and crs.startswith("EPSG:"):
        data["crs"] = {"type": "name", "properties": {"name": f"urn:ogc:def:crs:EPSG::{crs[5:]}"}}
    elif crs:
        data["crs_wkt"] = crs  # a foreign member: GeoJSON has no place for WKT
    return data


def write_geojson(result, path) -> Path:
    with atomic_path(path) as tmp:
        tmp.write_text(json_text(geojson(result), indent=None), encoding="utf-8")
    return Path(path)
