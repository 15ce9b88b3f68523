"""Static figures: lower-hemisphere equal-area stereonet and rose diagram of strikes."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..io.atomic import write_figure


def stereonet_figure(strike, dip, *, title: str = ""):
    """Poles, great circles and pole density (Kamb contours) on an equal-area net."""
    import warnings

    import matplotlib  # lazy: a second to import, and only figures need it
    from matplotlib.figure import Figure  # a Figure of its own: the caller's pyplot backend is left alone

    fig = Figure(figsize=(6, 6))
    with warnings.catch_warnings():  # mplstereonet 0.6's Axes.cla override: its concern, not the user's
        warnings.simplefilter("ignore", matplotlib.MatplotlibDeprecationWarning)
        warnings.simplefilter("ignore", PendingDeprecationWarning)
        import mplstereonet  # noqa: F401  (registers the 'stereonet' projection)

        ax = fig.add_subplot(111, projection="stereonet")
    strike, dip = np.asarray(strike, float), np.asarray(dip, float)
    if len(strike) >= 3:
        ax.density_contourf(strike, dip, measurement="poles", cmap="Blues", alpha=0.6)
    ax.plane(strike, dip, "k-", linewidth=0.6, alpha=0.7)
    ax.pole(strike, dip, "ro", markersize=5, label="poles")
    ax.grid(True)
    ax.set_title(title or f"{len(strike)} planes (lower hemisphere, equal area)", y=1.08)
    return fig, ax


def rose_figure(strike, *, bin_width: float = 10.0):
    """Rose diagram of strikes, drawn both ways (a strike is a line, not a direction)."""
    from matplotlib.figure import Figure

    both = np.concatenate([np.asarray(strike, float), (np.asarray(strike, float) + 180) % 360])
    edges = np.arange(0, 360 + bin_width, bin_width)
    counts, _ = np.histogram(both, edges)
    fig = Figure(figsize=(5, 5))
    ax = fig.add_subplot(111, projection="polar")
    ax.set_theta_zero_location("N")
    ax.set_theta_direction(-1)
    ax.bar(np.radians(edges[:-1] + bin_width / 2), counts, width=np.radians(bin_width), edgecolor="k", alpha=0.7)
    ax.set_title("Strikes (rose diagram)", y=1.08)
    return fig, ax


def save(fig, stem, formats=("png", "svg")) -> list[Path]:
    """The static figures as the report folder holds them (130 dpi, tight)."""
    return write_figure(fig, stem, formats, dpi=130, bbox_inches="tight")


# --- Projection arithmetic for the interactive report (drawn by plotly, not matplotlib) ---
# Lower-hemisphere Lambert equal-area net of radius 1, north up, east right. The static
# figures above come from mplstereonet; tests check both put a pole at the same place.


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
    return equal_area_xy(enu_vectors(np.asarray(dip_direction, float) + 180.0, 90.0 - np.asarray(dip, float)))


def great_circle_xy(dip_direction, dip, segments: int = 61):
    """(segments,) x and y of the plane's great circle, from strike to strike via the dip line."""
    dd, d = np.radians(dip_direction), np.radians(dip)
    strike = np.array([np.sin(dd - np.pi / 2), np.cos(dd - np.pi / 2), 0.0])
    down_dip = np.array([np.sin(dd) * np.cos(d), np.cos(dd) * np.cos(d), -np.sin(d)])
    a = np.linspace(0, np.pi, segments)[:, None]
    return equal_area_xy(np.cos(a) * strike + np.sin(a) * down_dip)


def pole_density(dip_direction, dip, gridsize: int = 81, sigma: float = 3.0):
    """Exponential Kamb density of poles (Vollmer 1995) on a regular grid over the net.

    Returns x (G,), y (G,) and density (G, G) in multiples of a uniform distribution
    (NaN outside the primitive circle). The kernel's width follows the number of poles:
    k = 2 (1 + N / sigma^2), as in mplstereonet's ``exponential_kamb``.
    """
    poles = enu_vectors(np.asarray(dip_direction, float) + 180.0, 90.0 - np.asarray(dip, float))
    n = len(poles)
    x = y = np.linspace(-1, 1, gridsize)
    gx, gy = np.meshgrid(x, y)
    r2 = gx**2 + gy**2
    inside = r2 <= 1
    up = r2 - 1  # inverse of r = sqrt(1 + up)
    horizontal = np.sqrt(np.clip(1 - up**2, 0, 1)) / np.where(r2 > 0, np.sqrt(r2), 1)
    grid = np.stack([gx * horizontal, gy * horizontal, up], axis=-1)[inside]
    k = 2.0 * (1.0 + n / sigma**2)
    density = np.full(gx.shape, np.nan)
    if n:
        density[inside] = np.exp(k * (np.abs(grid @ poles.T) - 1)).sum(axis=1) * k / n
    return x, y, density
