"""What a cloud's coordinate reference system says beyond where it is: whether its axes can
be measured at all (:func:`check_cloud_crs`: not in degrees, one length unit on all three),
their unit (:func:`metres_per_unit`, :func:`unit_symbol`: the rock mass is in metres, the
plane table in the cloud's own unit), and which way true north lies on its grid
(:func:`grid_convergence`, :func:`true_north_frame`). pyproj is imported only when a cloud
has a CRS.
"""

from __future__ import annotations

import warnings
from functools import lru_cache
from pathlib import Path

import numpy as np

from geostructure.errors import GeoStructureError, GeoStructureNote, GeoStructureWarning, InputError
from geostructure.io.usercsv import user_text

#: The longest WKT a CRS file holds: EPSG's longest definitions run to some 10 kB; a 50 MB
#: "WKT" took 2.7 GB.
MAX_WKT_BYTES = 1024 * 1024


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
        text = user_text(path, "WKT", limit=MAX_WKT_BYTES)
        source = str(path)
    try:
        return CRS.from_user_input(text)
    except CRSError:
        raise GeoStructureError(
            f"{source}: not a coordinate reference system PROJ knows (give EPSG:XXXX or WKT)."
        ) from None


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


def given_crs(given: str | None, declared: str | None, source: str) -> str | None:
    """The CRS a cloud is measured in: ``--crs`` (``given``) when there is one, over the one
    its file ``declared``, with a warning where they differ (a mislabelled file is fixed
    this way, but its coordinates are not reprojected: a file in feet given a CRS in metres
    would have every size off by 3.28); else the declared one.

    Examples
    --------
    >>> given_crs("EPSG:32633", None, "scan.ply")
    'EPSG:32633'
    >>> given_crs(None, "EPSG:32633", "scan.las")
    'EPSG:32633'
    """
    if declared is None:
        return given
    try:
        parsed = parse_crs(declared, source)
    except GeoStructureError:
        if given is None:  # said here, naming the file: a writer that needed it named none
            raise InputError(
                f"{source}: declares a CRS that PROJ cannot read; give the cloud's CRS with --crs EPSG:XXXX."
            ) from None
        return given  # --crs stands for a declaration that cannot be read
    if given is None:
        return declared
    if not parse_crs(given).equals(parsed, ignore_axis_order=True):
        warnings.warn(
            f"{source}: declares {parse_crs(declared, source).name}, but --crs gives {parse_crs(given).name}; "
            f"measured in the latter, as asked, with the coordinates as they are (not reprojected).",
            GeoStructureWarning,
            stacklevel=2,
        )
    return given


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
    >>> from geostructure.core.orientation import Frame
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


#: A spread of the convergence over the cloud (degrees) worth saying: one frame reads it all.
WIDE_CONVERGENCE = 0.05


def describe_north(north: dict) -> str:
    """A line on the north a run read azimuths against (:func:`true_north_frame`'s record).

    Examples
    --------
    >>> describe_north({"grid_convergence_deg": 1.4145, "grid_convergence_range_deg": [1.41, 1.42]})
    "azimuths read against true north: the grid convergence at the cloud's centre is +1.41 deg (--grid-north for grid azimuths)"
    >>> describe_north({"grid_convergence_deg": 1.4, "grid_convergence_range_deg": [1.2, 1.6]}).split("; ")[1]
    'it varies across the cloud, so azimuths near its edges are up to 0.20 deg off'
    """
    gamma, (low, high) = north["grid_convergence_deg"], north["grid_convergence_range_deg"]
    text = (
        f"azimuths read against true north: the grid convergence at the cloud's centre is "
        f"{gamma:+.2f} deg (--grid-north for grid azimuths)"
    )
    if high - low > WIDE_CONVERGENCE:  # one frame for the whole survey
        text += f"; it varies across the cloud, so azimuths near its edges are up to {max(high - gamma, gamma - low):.2f} deg off"
    return text


#: Symbols of the linear units clouds come in, by metres per unit.
UNIT_SYMBOLS = {1.0: "m", 0.3048: "ft", 1200.0 / 3937.0: "US ft", 0.01: "cm", 0.001: "mm"}
#: The units ``--unit`` names for a cloud without a CRS, by metres per unit.
UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001, "ft": 0.3048, "us-ft": 1200.0 / 3937.0}


def cloud_unit(crs: str | None, unit: str | None = None) -> dict:
    """A cloud's length unit as ``run.json`` records it, ``{"symbol", "metres"}``: the unit
    named (:data:`UNITS`, for a cloud without a CRS), else its CRS's, else metres.

    Examples
    --------
    >>> cloud_unit(None, "mm"), cloud_unit("EPSG:2992")
    ({'symbol': 'mm', 'metres': 0.001}, {'symbol': 'ft', 'metres': 0.3048})
    """
    if unit is not None:
        metres = UNITS[unit]
        return {"symbol": UNIT_SYMBOLS[metres], "metres": metres}
    return {"symbol": unit_symbol(crs), "metres": metres_per_unit(crs)}


def recorded_unit(record: dict) -> dict:
    """The unit a measured folder's ``run.json`` gives its cloud (:func:`cloud_unit`): its
    ``unit`` entry, or, in a folder written before there was one, its CRS's.

    Examples
    --------
    >>> recorded_unit({"unit": {"symbol": "mm", "metres": 0.001}})["metres"], recorded_unit({})["symbol"]
    (0.001, 'm')
    """
    return dict(record["unit"]) if record.get("unit") else cloud_unit(record.get("crs"))


#: A cloud with neither a CRS nor a stated unit is taken in metres; its points this far
#: apart (a point spacing in its units) are more likely millimetres or centimetres.
SUSPECT_SPACING = 5.0


def note_unstated_unit(spacing: float | None, source) -> None:
    """A note (:class:`~.errors.GeoStructureNote`) where a cloud taken to be in metres has
    points over :data:`SUSPECT_SPACING` apart: its rock mass would be off by the unit's
    factor (a cloud in millimetres: spacings a thousand times too long)."""
    if spacing is not None and spacing > SUSPECT_SPACING:
        warnings.warn(
            f"{source}: its points lie {spacing:.3g} units apart, and with no CRS and no --unit its unit is taken "
            f"to be the metre; if the cloud is in millimetres or centimetres, measure it with --unit mm (or cm), "
            f"so that its spacings and intensities are in metres.",
            GeoStructureNote,
            stacklevel=2,
        )


def check_unit(unit: str | None, crs: str | None, source) -> None:
    """Refuse ``--unit`` that contradicts the CRS: the CRS gives the unit.

    Examples
    --------
    >>> check_unit("ft", "EPSG:32633", "scan.las")
    Traceback (most recent call last):
    ...
    geostructure.errors.InputError: scan.las: its CRS is in m, not ft; the CRS gives the unit: drop --unit.
    """
    if unit is None or crs is None:
        return
    declared = cloud_unit(crs)
    if abs(declared["metres"] - UNITS[unit]) > 1e-9 * UNITS[unit]:
        raise InputError(
            f"{source}: its CRS is in {declared['symbol']}, not {unit}; the CRS gives the unit: drop --unit."
        )


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


def in_metres(points: np.ndarray, metres_per_unit: float) -> np.ndarray:
    """``points`` scaled to metres (the same array when they are in metres already).

    Examples
    --------
    >>> in_metres(np.array([[10.0, 0.0, 1.0]]), 0.3048).tolist()
    [[3.048, 0.0, 0.3048]]
    """
    return points if metres_per_unit == 1.0 else np.asarray(points, dtype=np.float64) * metres_per_unit
