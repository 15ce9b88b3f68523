"""Static figures: lower-hemisphere equal-area stereonet and rose diagram of strikes."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from geostructure.core.orientation import drawn_azimuth
from geostructure.core.projection import quiet_mplstereonet, rose_counts, rose_title
from geostructure.io.atomic import write_figure
from geostructure.report.view3d import NO_SET_COLOR, set_color

#: Kamb contours need this many poles (the interactive net's rule too): from three the
#: "density" is three bumps, not a distribution.
MIN_CONTOUR_POLES = 10


def stereonet_figure(strike, dip, *, title: str = "", set_labels=None, sets=()):
    """Poles, great circles and pole density (Kamb contours) on an equal-area net.

    With joint sets (``set_labels`` per plane, ``sets`` the rows of ``sets.csv``), the poles
    are coloured by set and each set's mean great circle and alpha95 cone are drawn instead
    of every plane's great circle.
    """
    # Lazy: matplotlib takes a second to import, and only figures need it.
    from matplotlib.figure import Figure  # a Figure of its own: the caller's pyplot backend is left alone

    strike, dip = drawn_azimuth(strike), np.asarray(dip, float)
    contoured = len(strike) >= MIN_CONTOUR_POLES
    fig = Figure(figsize=(7.2, 6) if contoured else (6, 6))
    with quiet_mplstereonet():  # importing it registers the 'stereonet' projection
        # Axes at a fixed place: mplstereonet draws the azimuth labels on an overlay laid
        # where the net first stood, so a colour bar that shrinks the net afterwards left
        # "0" above the title and "90" beside the bar.
        ax = fig.add_axes((0.06, 0.08, 0.7, 0.8) if contoured else (0.1, 0.08, 0.8, 0.8), projection="stereonet")
    if contoured:
        contours = ax.density_contourf(strike, dip, measurement="poles", cmap="Blues", alpha=0.6)
        bar = fig.add_axes((0.86, 0.25, 0.03, 0.46))
        fig.colorbar(contours, cax=bar, label="pole density (Kamb, σ)")
    if sets and set_labels is not None:
        labels = np.asarray(set_labels)
        for row in sets:
            s, color = int(row["set"]), set_color(int(row["set"]))
            ax.pole(strike[labels == s], dip[labels == s], "o", color=color, markersize=5, label=f"set {s}")
            ax.plane(row["strike"], row["dip"], "-", color=color, linewidth=2.0)
            ax.cone(90.0 - row["dip"], (row["dip_direction"] + 180.0) % 360.0, row["alpha95_deg"],
                    facecolor="none", edgecolor=color, bidirectional=False)  # fmt: skip
        if (labels < 0).any():
            ax.pole(strike[labels < 0], dip[labels < 0], "o", color=NO_SET_COLOR, markersize=4, label="no set")
        ax.legend(loc="lower left", bbox_to_anchor=(-0.1, -0.12), fontsize=8, frameon=False)
    else:
        ax.plane(strike, dip, "k-", linewidth=0.6, alpha=0.7)
        ax.pole(strike, dip, "ro", markersize=5, label="poles")
    ax.grid(True)
    ax.set_title(title or f"{len(strike)} planes (lower hemisphere, equal area)", y=1.08)
    return fig, ax


def rose_figure(strike, dip, *, bin_width: float = 10.0):
    """Rose diagram of the strikes of the planes steep enough to have one
    (:func:`~geostructure.core.projection.rose_counts`), drawn both ways."""
    from matplotlib.figure import Figure

    edges, counts, n_used = rose_counts(strike, dip, bin_width)
    fig = Figure(figsize=(5, 5))
    ax = fig.add_subplot(111, projection="polar")
    ax.set_theta_zero_location("N")
    ax.set_theta_direction(-1)
    ax.bar(np.radians(edges[:-1] + bin_width / 2), counts, width=np.radians(bin_width), edgecolor="k", alpha=0.7)
    ax.set_title(rose_title(n_used), y=1.08)
    return fig, ax


def save(fig, stem, formats=("png", "svg")) -> list[Path]:
    """The static figures as the report folder holds them (130 dpi, tight, no date stamp, so
    the same planes give the same files)."""
    return write_figure(fig, stem, formats, dpi=130, bbox_inches="tight", metadata={"Date": None})
