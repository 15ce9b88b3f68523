"""The report's kinematic tables (``kinematics.json``): the failure modes, the sections of a
face that turns, and the sets against the slope."""

from __future__ import annotations

from html import escape

from geostructure.report.view3d import set_color
from geostructure.report.words import (
    FAILURE_MODES,
    SECTION_COLUMNS,
    SET_KINEMATIC_COLUMNS,
    SET_KINEMATIC_TITLES,
    failure_mode_cells,
    kinematic_verdicts,
    left_out_phrase,
    section_cells,
    set_kinematic_cells,
    set_mean_wedge_lines,
    slope_text,
)
from geostructure.rockmass.notes import bent_slope, sectioned_slope


def kinematic_table(scene) -> str:
    """The kinematic tests as an HTML table (empty before ``geostructure kinematics``): a
    row per failure mode, the planes critical and their share, and, with sets, a row per set
    (its mean plane's tests, the sets it forms a critical wedge with, its planes' shares)."""
    kinematics = scene.kinematics
    if not kinematics:
        return ""
    slope = kinematics["slope"]
    caption = (
        f"Kinematics: {slope_text(kinematics, whole=True)}, friction {kinematics['friction_deg']:g}°, "
        f"lateral limits {kinematics['lateral_limit_deg']:g}°"
    )
    rows = "".join(
        f"<tr><td>{name.capitalize()}</td>"
        + "".join(f"<td>{c}</td>" for c in failure_mode_cells(kinematics, key))
        + "</tr>"
        for key, name in FAILURE_MODES
    )
    html = (
        f'<table id="kinematics"><caption>{caption}</caption><thead><tr><th>Failure mode</th><th>Planes critical</th>'
        f"<th>% by count</th><th>% by area</th><th>Joints critical</th></tr></thead><tbody>{rows}</tbody></table>"
    ) + "".join(f'<p class="note">{escape(n)}</p>' for n in [bent_slope(slope), sectioned_slope(kinematics)] if n)
    # the terminal's verdicts, word for word: one summary, printed and drawn
    left_out = {why: count for why, count in kinematics.get("left_out", {}).items() if count}
    verdicts = ([f"{kinematics['planes_tested']:,} planes tested, " + left_out_phrase(left_out) + "."]
                if left_out else []) + kinematic_verdicts(kinematics)  # fmt: skip
    html += "".join(f'<p class="verdict">{escape(line)}</p>' for line in verdicts)
    html += section_table(kinematics.get("sections") or [])
    # kinematics.json of an older run lacks the set means' orientation: no per-set table then
    sets = [row for row in kinematics.get("sets") or [] if "mean_dip" in row]
    if not sets:
        return html
    rows = "".join(
        "<tr>"
        + "".join(
            f"<td>{set_swatch(int(row['set'])) if i == 0 else ''}{cell}</td>"
            for i, cell in enumerate(set_kinematic_cells(row))
        )
        + "</tr>"
        for row in sets
    )
    head = "".join(f"<th>{column.capitalize()}</th>" for column in SET_KINEMATIC_COLUMNS)
    return (
        f'{html}<table id="kinematic-sets"><caption>{escape(SET_KINEMATIC_TITLES[bool(kinematics.get("sections"))])}'
        f"</caption><thead><tr>{head}</tr></thead><tbody>{rows}</tbody></table>"
    ) + "".join(f'<p class="verdict">{escape(line)}</p>' for line in set_mean_wedge_lines(kinematics))


def section_table(sections: list[dict]) -> str:
    """The sections of a face tested in sections, a row each; empty for one slope."""
    if not sections:
        return ""
    head = "".join(f"<th>{column.capitalize()}</th>" for column in SECTION_COLUMNS)
    rows = "".join("<tr>" + "".join(f"<td>{c}</td>" for c in section_cells(s)) + "</tr>" for s in sections)
    return (
        '<table id="kinematic-sections"><caption>Sections, from left to right as one faces the rock: each plane '
        f"tested against its own section's slope</caption><thead><tr>{head}</tr></thead><tbody>{rows}</tbody></table>"
    )


def set_swatch(number: int) -> str:
    return f'<span class="swatch" style="background:{set_color(number)}"></span>'
