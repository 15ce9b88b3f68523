"""The report's spacing histograms: each set's normal spacings along the scanlines, with
the fitted exponential and lognormal densities (:func:`~geostructure.rockmass.mass.spacing_statistics`),
and the set's spacing as its table gives it (``sets.csv``'s ``spacing_m``: the lines' length
over the joints they meet) as a dotted line, so that the one headline number is on the
plot too. Where the joints show only over short stretches, the gaps between neighbouring
crossings are far shorter than that headline (the observatory: 0.41 against 6.16 m); the
histogram says which is which."""

from __future__ import annotations

import numpy as np
from scipy import stats

from geostructure.report.scene import ReportScene
from geostructure.report.view3d import figure_json, panel_title, set_color
from geostructure.rockmass.spacing import spacing_statistics


def figure_spacing(scene: ReportScene) -> dict | None:
    """One histogram per set (probability density) and its two fits; None without spacings."""
    import plotly.graph_objects as go

    if not scene.spacings:
        return None
    fig = go.Figure()
    top = (
        max(float(np.percentile(g, 98)) for g in scene.spacings.values() if len(g))
        if any(len(g) for g in scene.spacings.values())
        else 1.0
    )
    headline = {int(row["set"]): float(row.get("spacing_m", np.nan)) for row in scene.sets}
    # The axis reaches a headline a little past the gaps; one far past them stays off the
    # axis, named in the legend, so that the gaps' shape is not squeezed to its left edge.
    near = [v for s, v in headline.items() if np.isfinite(v) and len(scene.spacings.get(s, ())) and v < 1.5 * top]
    top = max([top, *(1.05 * v for v in near)])
    x = np.linspace(top / 200.0, top, 200)
    for s, gaps in sorted(scene.spacings.items()):
        if len(gaps) == 0:
            continue
        color = set_color(s)
        spacing = headline.get(s, np.nan)
        if np.isfinite(spacing):
            if spacing <= top:
                fig.add_vline(x=spacing, line=dict(color=color, width=2, dash="dot"))
            where = "the table's" if spacing <= top else "the table's, off the axis"
            legend = go.Scatter(x=[None], y=[None], mode="lines", line=dict(color=color, width=2, dash="dot"),
                                name=f"set {s}: spacing {spacing:.2f} m ({where})")  # fmt: skip
            fig.add_trace(legend)  # the dotted line's legend entry
        fit = spacing_statistics(gaps)
        fig.add_trace(
            go.Histogram(
                x=gaps,
                histnorm="probability density",
                name=f"set {s}: {len(gaps)} gaps",
                marker=dict(color=color),
                opacity=0.45,
                xbins=dict(start=0.0, end=top, size=top / 25.0),
                hovertemplate=f"set {s}: %{{x}} m<extra></extra>",
            )
        )
        if fit["best_fit"]:
            fig.add_trace(
                go.Scatter(
                    x=x,
                    y=stats.expon.pdf(x, scale=fit["exp_mean"]),
                    mode="lines",
                    line=dict(color=color, width=2, dash="dash" if fit["best_fit"] != "exponential" else "solid"),
                    name=f"exponential, mean {fit['exp_mean']:.2f} m",
                    hoverinfo="skip",
                )
            )
            fig.add_trace(
                go.Scatter(
                    x=x,
                    y=stats.lognorm.pdf(x, fit["lognorm_sigma"], scale=np.exp(fit["lognorm_mu"])),
                    mode="lines",
                    line=dict(color=color, width=2, dash="dash" if fit["best_fit"] != "lognormal" else "solid"),
                    name=f"lognormal, median {np.exp(fit['lognorm_mu']):.2f} m",
                    hoverinfo="skip",
                )
            )
    height = 460
    title, margin_top = panel_title(
        ["Normal spacing per set", "bars: gaps between neighbouring joints on the scanlines, solid: their better fit",
         "dotted: the set's spacing, the scanlines' length over the joints met"], height)  # fmt: skip
    # The legend below the plot, one entry a line in a narrow panel: room for every entry,
    # so that it never covers the axis.
    plot, below = 260, 70 + 19 * len(fig.data)
    fig.update_layout(
        barmode="overlay",
        height=margin_top + plot + below,
        margin=dict(l=50, r=20, t=margin_top, b=below),
        title=title,
        xaxis=dict(title="spacing (m)", range=[0, top]),
        yaxis=dict(title="density (1/m)"),
        legend=dict(font=dict(size=9), orientation="h", yanchor="top", y=-60 / plot, x=0),
    )
    return figure_json(fig)
