"""``kinematics.png``: the kinematic tests drawn on the net as a geologist draws them by hand."""

from __future__ import annotations

import numpy as np

from geostructure.core.orientation import drawn_azimuth, whole_azimuth
from geostructure.core.projection import quiet_mplstereonet
from geostructure.report.view3d import TOPPLING_COLOR, set_color

#: Intersection lines drawn at most per kind: an outcrop's 1,500 planes make a million pairs,
#: and a quarter of a million crosses drew a solid band over the envelopes. A random draw of
#: this many shows where they lie; the legend says how many of how many.
MAX_DRAWN_LINES = 4000


def drawn_lines(n: int, seed: int = 0) -> np.ndarray:
    """Which of ``n`` intersection lines the figure draws: all of them, or a seeded random
    :data:`MAX_DRAWN_LINES`, in their order.

    Examples
    --------
    >>> len(drawn_lines(10)), len(drawn_lines(10**6)), bool(np.all(np.diff(drawn_lines(10**6)) > 0))
    (10, 4000, True)
    """
    if n <= MAX_DRAWN_LINES:
        return np.arange(n)
    return np.sort(np.random.default_rng(seed).choice(n, MAX_DRAWN_LINES, replace=False))


def kinematics_figure(
    dip,
    dip_direction,
    *,
    slope,
    friction,
    lateral_limit,
    planar,
    toppling,
    wedge_lines=((), ()),
    toppling_lines=((), ()),
    oblique_lines=((), ()),
    set_means=(),
    set_wedges=(),
    fig=None,
    panel=(0, 1),
    pole_sets=None,
):
    """Poles (critical for planar sliding red, for flexural toppling cyan, the others by their
    set in ``pole_sets``, grey for none), the slope's great
    circle (the wedges' daylight envelope), the planar daylight envelope and lateral limits,
    the friction cones of poles and of lines, the toppling envelope, and the critical wedges'
    intersection lines (crosses), and the intersections in the direct toppling zones (inside the
    circle of lines plunging 90 - slope dip: within the lateral limits, and Dips' secondary
    zone outside them). With joint sets, each set's mean plane (``set_means``: set, dip, dip
    direction) is drawn as a great circle in the set's colour, and the critical wedges their
    means form (``set_wedges``: set, set, trend, plunge) as stars: the set table on the net.

    A face tested in sections draws one net per section side by side: ``panel`` (k, n) is
    the k-th of n, on the ``fig`` the first returned."""
    from matplotlib.figure import Figure

    k, n = panel
    if fig is None:
        fig = Figure(figsize=(7.0 * n, 8.0))
        fig.subplots_adjust(left=0.08 / n, right=1.0 - 0.08 / n, top=0.9, bottom=0.22, wspace=0.3)
    with quiet_mplstereonet():  # importing it registers the projection, with a warning to hush
        import mplstereonet

        ax = fig.add_subplot(1, n, k + 1, projection="stereonet")
    dip, dip_direction = np.asarray(dip, float), drawn_azimuth(dip_direction)
    strike = (dip_direction - 90.0) % 360.0
    alpha_f, psi_f = slope.dip_direction, slope.dip

    def curve(plunge, bearing, *style, **kw):
        lon, lat = mplstereonet.line(np.asarray(plunge, float), np.asarray(bearing, float))
        ax.plot(lon, lat, *style, **kw)

    ax.plane((alpha_f - 90.0) % 360.0, psi_f, "k-", linewidth=2.0, label="slope (wedge daylight envelope)")
    # Planar daylight envelope: the poles of planes dipping at the slope's apparent dip.
    azimuth = np.linspace(alpha_f - 90.0, alpha_f + 90.0, 181)
    apparent = np.degrees(np.arctan(np.tan(np.radians(psi_f)) * np.cos(np.radians(azimuth - alpha_f))))
    curve(90.0 - apparent, (azimuth + 180.0) % 360.0, "b-", linewidth=1.5, label="planar daylight envelope")
    for side in (-1.0, 1.0):  # lateral limits, on the pole side (planar) and the slope side (toppling)
        plunge = np.linspace(0.0, 90.0, 46)
        curve(plunge, np.full_like(plunge, (alpha_f + 180.0 + side * lateral_limit) % 360.0), "b:", linewidth=1.0)
        curve(
            plunge,
            np.full_like(plunge, (alpha_f + side * lateral_limit) % 360.0),
            ":",
            color=TOPPLING_COLOR,
            linewidth=1.0,
        )
    ring = np.linspace(0.0, 360.0, 181)
    curve(np.full_like(ring, 90.0 - friction), ring, "r--", linewidth=1.2, label=f"pole friction cone ({friction:g}°)")
    curve(np.full_like(ring, friction), ring, "m--", linewidth=1.2, label="line friction cone")
    if psi_f - friction > 0:  # toppling envelope: poles plunging less than slope dip - friction
        arc = np.linspace(alpha_f - lateral_limit, alpha_f + lateral_limit, 41) % 360.0
        curve(np.full_like(arc, psi_f - friction), arc, "-", color=TOPPLING_COLOR, linewidth=1.5,
              label="toppling envelope")  # fmt: skip
    if psi_f < 90.0:  # direct toppling: lines steeper than 90 - slope dip lean out of the face
        curve(np.full_like(ring, 90.0 - psi_f), ring, "-.", color="saddlebrown", linewidth=1.0,
              label="direct toppling circle")  # fmt: skip
    other = ~(np.asarray(planar, bool) | np.asarray(toppling, bool))
    labels = np.full(len(dip), -1) if pole_sets is None else np.asarray(pole_sets, dtype=np.int64)
    for s in np.unique(labels[other]):  # the poles not critical, by set as on the report's stereonet
        mine = other & (labels == s)
        ax.pole(strike[mine], dip[mine], "o", color=set_color(int(s)) if s >= 0 else "0.55", markersize=4,
                label=f"poles, set {s}" if s >= 0 else "poles" if pole_sets is None else "poles, no set")  # fmt: skip
    ax.pole(strike[toppling], dip[toppling], "o", color=TOPPLING_COLOR, markersize=5, label="flexural toppling")
    ax.pole(strike[planar], dip[planar], "o", color="red", markersize=5, label="planar sliding")
    for lines, name, style in (
        (wedge_lines, "critical wedges (intersections)", dict(marker="x", color="purple", markersize=3, alpha=0.5)),
        (toppling_lines, "direct toppling intersections", dict(marker="+", color="saddlebrown", markersize=4,
                                                               alpha=0.6)),
        (oblique_lines, "oblique toppling intersections", dict(marker="+", color="goldenrod", markersize=3,
                                                               alpha=0.35)),
    ):  # fmt: skip
        trend, plunge = (np.asarray(v, float) for v in lines)
        if len(trend):  # one artist for all of them (ax.line makes one per line)
            drawn = drawn_lines(len(trend))
            label = name if len(drawn) == len(trend) else f"{name}: {len(drawn):,} of {len(trend):,} drawn"
            curve(plunge[drawn], trend[drawn], linestyle="none", zorder=1, label=label, **style)
    for s, mean_dip, mean_dd in set_means:
        ax.plane((mean_dd - 90.0) % 360.0, mean_dip, "--", color=set_color(s), linewidth=2.0,
                 label=f"set {s} mean {mean_dip:.0f}/{whole_azimuth(mean_dd)}")  # fmt: skip
    for a, b, trend, plunge in set_wedges:
        curve(plunge, trend, marker="*", linestyle="none", color="black", markersize=12, zorder=4,
              label=f"wedge of set means {a} and {b}: {plunge:.0f}° toward {whole_azimuth(trend)}")  # fmt: skip
    ax.grid(True)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.04), fontsize=8, frameon=False, ncol=2)
    name = f"Section {k}" if n > 1 else "Kinematics"
    ax.set_title(f"{name}: slope {psi_f:.0f}/{whole_azimuth(alpha_f)}, friction {friction:g}°", y=1.08)
    return fig


def kinematics_result_figure(tested):
    """``kinematics.png`` of the kinematic tests' result
    (:class:`~geostructure.kinematics.summary.KinematicResult`): one net a section of the
    face, side by side.

    Examples
    --------
    >>> from geostructure.core.planes import Planes
    >>> from geostructure.kinematics.modes import Slope
    >>> from geostructure.kinematics.summary import kinematics_of
    >>> planes = Planes(normal=[[0.0, -0.5, 0.866], [0.0, 0.94, 0.342]], area=[2.0, 3.0])
    >>> figure = kinematics_result_figure(kinematics_of(planes, [], Slope(65.0, 180.0), 30.0))
    >>> len(figure.axes) >= 1
    True
    """
    fig = None
    for k, panel in enumerate(tested.panels):
        fig = kinematics_figure(
            panel.dip, panel.dip_direction, slope=panel.slope, friction=tested.friction,
            lateral_limit=tested.lateral_limit, planar=panel.planar, toppling=panel.toppling,
            wedge_lines=panel.wedge_lines, toppling_lines=panel.toppling_lines, oblique_lines=panel.oblique_lines,
            set_means=panel.set_means, set_wedges=panel.set_wedges, fig=fig, panel=(k, len(tested.panels)),
            pole_sets=panel.pole_sets,
        )  # fmt: skip
    return fig
