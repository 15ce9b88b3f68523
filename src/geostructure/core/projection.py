"""Stereonet arithmetic: the lower-hemisphere equal-area net and the density of poles.

Pure functions of angles and vectors, apart from any drawing: the interactive report
(plotly) and the static figures (mplstereonet) both use them, and tests check both put a
pole at the same place. The net has radius 1, north up, east right. The density is
mplstereonet's own (``density_grid``, exponential Kamb after Vollmer 1995), resampled onto
a regular grid of the net so any plotting library can contour it.
"""

from __future__ import annotations

import warnings
from contextlib import contextmanager

import numpy as np

from geostructure.core.orientation import drawn_azimuth


@contextmanager
def quiet_mplstereonet():
    """Import mplstereonet (and matplotlib) without its deprecation warnings, which are its
    concern, not the user's (mplstereonet 0.6 overrides ``Axes.cla``); yields the module."""
    # Lazy: matplotlib takes a second to import, and only figures and densities need it.
    import matplotlib

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", matplotlib.MatplotlibDeprecationWarning)
        warnings.simplefilter("ignore", PendingDeprecationWarning)
        import mplstereonet

        yield mplstereonet


def enu_vectors(trend, plunge) -> np.ndarray:
    """(N, 3) unit (east, north, up) vectors of lines given by trend and plunge (degrees)."""
    t, p = np.radians(np.asarray(trend, float)), np.radians(np.asarray(plunge, float))
    return np.stack([np.sin(t) * np.cos(p), np.cos(t) * np.cos(p), -np.sin(p)], axis=-1)


def equal_area_xy(vectors) -> tuple[np.ndarray, np.ndarray]:
    """Project (..., 3) (east, north, up) vectors onto the lower-hemisphere equal-area net.

    Lines pointing up are reversed first (an axis has no sign); r = sqrt(1 + up) is the
    Lambert radius sqrt(2) sin(theta/2) scaled so that the horizontal maps to 1.
    """
    v = np.asarray(vectors, float)
    v = np.where(v[..., 2:3] > 0, -v, v)
    horizontal = np.hypot(v[..., 0], v[..., 1])
    scale = np.sqrt(np.clip(1.0 + v[..., 2], 0, 1)) / np.where(horizontal > 0, horizontal, 1.0)
    return v[..., 0] * scale, v[..., 1] * scale


def pole_xy(dip_direction, dip):
    """Net position of the poles of planes (dip direction, dip in degrees)."""
    return equal_area_xy(enu_vectors(drawn_azimuth(dip_direction) + 180.0, 90.0 - np.asarray(dip, float)))


def great_circle_xy(dip_direction, dip, segments: int = 61):
    """(segments,) x and y of the plane's great circle, from strike to strike via the dip line."""
    dd, d = np.radians(drawn_azimuth(dip_direction)), np.radians(dip)
    strike = np.array([np.sin(dd - np.pi / 2), np.cos(dd - np.pi / 2), 0.0])
    down_dip = np.array([np.sin(dd) * np.cos(d), np.cos(dd) * np.cos(d), -np.sin(d)])
    a = np.linspace(0, np.pi, segments)[:, None]
    return equal_area_xy(np.cos(a) * strike + np.sin(a) * down_dip)


def small_circle_xy(trend, plunge, radius, segments: int = 73):
    """Net x and y of the cone of half-angle ``radius`` (degrees) about a line (trend and
    plunge in degrees): an alpha95 confidence cone about a mean pole.

    Examples
    --------
    >>> x, y = small_circle_xy(0.0, 90.0, 10.0)  # about the vertical: a circle at the centre
    >>> bool(np.allclose(np.hypot(x, y), np.sqrt(1 - np.cos(np.radians(10)))))
    True
    """
    axis = enu_vectors(trend, plunge)
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(axis, helper)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    a = np.linspace(0, 2 * np.pi, segments)[:, None]
    r = np.radians(radius)
    return equal_area_xy(np.cos(r) * axis + np.sin(r) * (np.cos(a) * e1 + np.sin(a) * e2))


def pole_density(dip_direction, dip, gridsize: int = 81, sigma: float = 3.0, weights=None):
    """Exponential Kamb density of poles on a regular (x, y) grid over the net.

    mplstereonet's ``density_grid`` counts on its own longitude-latitude grid; the counts
    are carried to the net with :func:`equal_area_xy` and interpolated linearly onto the
    regular grid, so the report's contours are the static stereonet's.

    Returns
    -------
    x, y : (G,) arrays
        The grid's axes.
    density : (G, G) array
        In standard deviations from a uniform distribution (mplstereonet's unit); NaN
        outside the primitive circle.

    Examples
    --------
    >>> x, y, density = pole_density([90, 92, 88, 91], [40, 42, 39, 41], gridsize=41)
    >>> row, column = np.unravel_index(np.nanargmax(density), density.shape)
    >>> px, py = pole_xy(90, 40)  # the pole of a plane dipping 40 to the east plots to the west
    >>> bool(abs(x[column] - px) < 0.1 and abs(y[row] - py) < 0.1)
    True
    """
    from scipy.interpolate import griddata

    dip_direction, dip = drawn_azimuth(dip_direction), np.asarray(dip, float)
    x = y = np.linspace(-1, 1, gridsize)
    gx, gy = np.meshgrid(x, y)
    density = np.full(gx.shape, np.nan)
    if not len(dip):
        return x, y, density
    with quiet_mplstereonet() as mplstereonet:
        lon, lat, counts = mplstereonet.density_grid(
            (dip_direction - 90.0) % 360.0, dip, measurement="poles", sigma=sigma, gridsize=gridsize, weights=weights
        )
        plunge, bearing = mplstereonet.geographic2plunge_bearing(lon.ravel(), lat.ravel())
    sx, sy = equal_area_xy(enu_vectors(bearing, plunge))
    inside = gx**2 + gy**2 <= 1
    density[inside] = griddata((sx, sy), counts.ravel(), (gx[inside], gy[inside]), method="linear")
    return x, y, density


#: Planes gentler than this (degrees) are left out of a rose diagram of strikes: a flat
#: plane's strike is set by its noise, and a level ground's fragments would fill every petal.
ROSE_MIN_DIP = 10.0


def rose_counts(strike, dip, bin_width: float = 10.0, min_dip: float = ROSE_MIN_DIP):
    """Bin edges (degrees), counts per bin, and the number of planes counted, for a rose
    diagram of the strikes of the planes dipping ``min_dip`` or more. Each strike counts both
    ways (a strike is a line, not a direction).

    Examples
    --------
    >>> edges, counts, n = rose_counts([10.0, 95.0, 40.0], [60.0, 70.0, 2.0], bin_width=90.0)
    >>> counts.tolist(), n  # the 2-degree plane is left out
    ([1, 1, 1, 1], 2)
    """
    strike, dip = np.asarray(strike, dtype=np.float64), np.asarray(dip, dtype=np.float64)
    used = strike[dip >= min_dip]
    edges = np.arange(0.0, 360.0 + bin_width, bin_width)
    counts, _ = np.histogram(np.concatenate([used, (used + 180.0) % 360.0]), edges)
    return edges, counts, len(used)


def rose_title(n_planes: int, min_dip: float = ROSE_MIN_DIP) -> str:
    """The rose diagram's title: what it counts."""
    return " ".join(rose_title_lines(n_planes, min_dip))


def rose_title_lines(n_planes: int, min_dip: float = ROSE_MIN_DIP) -> list[str]:
    """:func:`rose_title` in two lines, for a narrow panel."""
    return [f"Strikes of {n_planes} planes", f"dipping {min_dip:g}° or more (rose diagram)"]
