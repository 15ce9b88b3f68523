"""The report's spacing histograms: each set's normal spacings along the scanlines, with
the fitted exponential and lognormal densities (:func:`~geostructure.rockmass.spacing_statistics`)."""

from __future__ import annotations

import numpy as np
from scipy import stats

from ..spacing import spacing_statistics
from .scene import ReportScene
from .view3d import figure_json, panel_title, set_color


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
    x = np.linspace(top / 200.0, top, 200)
    for s, gaps in sorted(scene.spacings.items()):
        if len(gaps) == 0:
            continue
        color = set_color(s)
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
    title, margin_top = panel_title(["Normal spacing per set", "scanlines; solid line: the better fit"], height)
    fig.update_layout(
        barmode="overlay",
        height=height,
        margin=dict(l=50, r=20, t=margin_top, b=40),
        title=title,
        xaxis=dict(title="spacing (m)", range=[0, top]),
        yaxis=dict(title="density (1/m)"),
        legend=dict(font=dict(size=9), orientation="h", yanchor="top", y=-0.22, x=0),
    )
    return figure_json(fig)
