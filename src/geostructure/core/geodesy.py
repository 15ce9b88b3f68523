"""WGS84 geodetic coordinates and local east-north-up (ENU) metres about an origin.

A reconstruction georeferenced from GPS or WGS84 control points lives in a local ENU frame
(metres, about ``origin`` = latitude, longitude, altitude); these functions take points in
and out of it, so planes can be written in longitude and latitude for GIS.
"""

from __future__ import annotations

import numpy as np

_A, _E2 = 6378137.0, 6.69437999014e-3  # WGS84 semi-major axis (m) and first eccentricity squared


def _ecef(lat, lon, alt) -> np.ndarray:
    lat, lon = np.radians(lat), np.radians(lon)
    n = _A / np.sqrt(1 - _E2 * np.sin(lat) ** 2)
    return np.stack(
        [
            (n + alt) * np.cos(lat) * np.cos(lon),
            (n + alt) * np.cos(lat) * np.sin(lon),
            (n * (1 - _E2) + alt) * np.sin(lat),
        ],
        axis=-1,
    )


def _enu_axes(origin) -> np.ndarray:
    """Rows: east, north, up unit vectors at ``origin``, in ECEF."""
    lat0, lon0 = np.radians(origin[0]), np.radians(origin[1])
    return np.array(
        [
            [-np.sin(lon0), np.cos(lon0), 0.0],
            [-np.sin(lat0) * np.cos(lon0), -np.sin(lat0) * np.sin(lon0), np.cos(lat0)],
            [np.cos(lat0) * np.cos(lon0), np.cos(lat0) * np.sin(lon0), np.sin(lat0)],
        ]
    )


def geodetic_to_enu(lat, lon, alt, origin) -> np.ndarray:
    """WGS84 latitude/longitude (degrees) and altitude (m) to (N, 3) east-north-up metres
    about ``origin`` (lat, lon, alt)."""
    d = _ecef(np.asarray(lat, float), np.asarray(lon, float), np.asarray(alt, float)) - _ecef(*origin)
    return d @ _enu_axes(origin).T


def enu_to_geodetic(enu, origin) -> np.ndarray:
    """(N, 3) east-north-up metres about ``origin`` back to (N, 3) latitude, longitude
    (degrees) and altitude (m); Bowring's latitude, refined twice (sub-millimetre)."""
    xyz = np.asarray(enu, float).reshape(-1, 3) @ _enu_axes(origin) + _ecef(*origin)
    x, y, z = xyz.T
    lon = np.arctan2(y, x)
    p = np.hypot(x, y)
    lat = np.arctan2(z, p * (1 - _E2))
    for _ in range(3):
        n = _A / np.sqrt(1 - _E2 * np.sin(lat) ** 2)
        alt = p / np.cos(lat) - n
        lat = np.arctan2(z, p * (1 - _E2 * n / (n + alt)))
    n = _A / np.sqrt(1 - _E2 * np.sin(lat) ** 2)
    alt = p / np.cos(lat) - n
    return np.c_[np.degrees(lat), np.degrees(lon), alt]
