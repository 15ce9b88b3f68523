"""The words and cells of the result tables, the terminal's and the report's alike: a
figure or a dash, a count with its noun, an azimuth or "level", and the kinematic tables'
columns and cells. The command line prints them (:mod:`geostructure.report.terminal`); the
report draws them (:mod:`.kinematic_tables`)."""

from __future__ import annotations

import numpy as np

from geostructure.core.orientation import whole_azimuth
from geostructure.kinematics.catalog import SUMMARY_MODES


def azimuth(value: float, dip: float, uncertainty: float) -> str:
    """A strike or dip direction as the tables print it, or "level" where it is blank (a
    plane's, in planes.csv, where its dip is under two of its standard errors:
    :func:`~geostructure.core.orientation.level_blanked`), or where the dip is within
    ``uncertainty`` (degrees; a set mean's cone of confidence) of level, where no azimuth
    means anything (a level plane printed a dip direction of 075.2 at dip 0.0).

    Examples
    --------
    >>> azimuth(75.2, 0.0, 0.5), azimuth(75.2, 12.0, 0.5), azimuth(5.0, 0.4, float("nan"))
    ('level', '075.2', '005.0')
    >>> azimuth(float("nan"), 0.0007, 0.0006)  # planes.csv leaves a level plane's blank
    'level'
    """
    return "level" if value != value or dip < uncertainty else f"{value:05.1f}"


def counted(n: int, noun: str) -> str:
    """``n`` with thousands separators and ``noun``, plural unless it is one.

    Examples
    --------
    >>> counted(1, "critical pair"), counted(2040, "critical pair")
    ('1 critical pair', '2,040 critical pairs')
    """
    return f"{n:,} {noun}" + ("" if n == 1 else "s")


def figure_or_dash(value, digits: int = 2) -> str:
    """A table's figure to ``digits`` decimals, or a dash where it was not measured (NaN, or
    None as ``run.json`` and ``kinematics.json`` write NaN).

    Examples
    --------
    >>> figure_or_dash(0.456), figure_or_dash(float("nan")), figure_or_dash(None, 1), figure_or_dash(12.0, 0)
    ('0.46', '—', '—', '12')
    """
    return f"{value:.{digits}f}" if value is not None and np.isfinite(value) else "—"


#: The summary tables' failure modes: key, words (:data:`~geostructure.kinematics.catalog.SUMMARY_MODES`).
FAILURE_MODES = tuple((mode.key, mode.words) for mode in SUMMARY_MODES)
#: The per-set kinematics table's columns (:func:`set_kinematic_cells`).
SET_KINEMATIC_COLUMNS = ("set", "mean dip/dd", "mean slides", "% planar", "mean topples", "% toppling",
                         "mean's wedges", "% in wedges")  # fmt: skip


#: The per-section kinematics table's columns (:func:`section_cells`).
SECTION_COLUMNS = ("section", "slope", "planes", "planar sliding", "wedge pairs", "flexural toppling",
                   "direct toppling")  # fmt: skip


def slope_text(summary: dict, whole: bool = False) -> str:
    """The slope a kinematics summary tested against, in words: one, or a face's sections.

    Examples
    --------
    >>> slope_text({"slope": {"dip": 75.4, "dip_direction": 180.2, "source": "given"}})
    'slope 75.4/180.2 (given)'
    >>> slope_text({"slope": {"dip": 75.4, "dip_direction": 180.2, "source": "given"}}, whole=True)
    'slope 75/180 (given)'
    >>> slope_text({"slope": {"dip": 7.7, "dip_direction": 225.0, "source": "fitted", "sections": 2},
    ...             "sections": [{"slope": {"dip": 75.5, "dip_direction": 180.0}},
    ...                          {"slope": {"dip": 74.2, "dip_direction": 271.1}}]})
    'the face in 2 sections, slopes 76/180 and 74/271 (fitted)'
    """
    slope = summary["slope"]
    sections = summary.get("sections") or []
    if len(sections) < 2:
        if whole:  # in whole degrees, as the report gives them
            return f"slope {slope['dip']:.0f}/{whole_azimuth(slope['dip_direction'])} ({slope['source']})"
        return f"slope {slope['dip']:.1f}/{slope['dip_direction']:05.1f} ({slope['source']})"
    parts = [f"{s['slope']['dip']:.0f}/{whole_azimuth(s['slope']['dip_direction'])}" for s in sections]
    return f"the face in {len(sections)} sections, slopes {', '.join(parts[:-1])} and {parts[-1]} ({slope['source']})"


def section_cells(section: dict) -> list[str]:
    """A row of the per-section kinematics table (``kinematics.json``'s ``sections``).

    Examples
    --------
    >>> section = {"section": 1, "slope": {"dip": 74.2, "dip_direction": 271.1}, "planes": 174,
    ...            "planar_sliding": {"planes": 57, "percent_by_count": 32.8}, "wedge_sliding": {"critical_pairs": 3300},
    ...            "flexural_toppling": {"planes": 60, "percent_by_count": 34.5}, "direct_toppling": {"critical": True}}
    >>> section_cells(section)
    ['1', '74/271', '174', '57 (33%)', '3,300', '60 (34%)', 'critical']
    """

    def share(mode: dict) -> str:
        return f"{mode['planes']:,} ({figure_or_dash(mode['percent_by_count'], 0)}%)"

    return [
        str(section["section"]),
        f"{section['slope']['dip']:.0f}/{whole_azimuth(section['slope']['dip_direction'])}",
        f"{section['planes']:,}",
        share(section["planar_sliding"]),
        f"{section['wedge_sliding']['critical_pairs']:,}",
        share(section["flexural_toppling"]),
        "critical" if section["direct_toppling"]["critical"] else "—",
    ]


def failure_mode_cells(summary: dict, key: str) -> list[str]:
    """One failure mode's planes critical, their share by count and by area, and the joints
    it takes with their share (a dash without joints: no sets, none grouped, or a run
    before them).

    Examples
    --------
    >>> mode = {"planes": 120, "percent_by_count": 28.17, "percent_by_area": 30.9, "joints": 9, "percent_of_joints": 18.4}
    >>> failure_mode_cells({"planar_sliding": mode}, "planar_sliding")
    ['120', '28.2', '30.9', '9 (18%)']
    >>> failure_mode_cells({"planar_sliding": {**mode, "joints": 0, "percent_of_joints": None}}, "planar_sliding")[3]
    '—'
    """
    mode = summary[key]
    share = figure_or_dash(mode.get("percent_of_joints"), 0)
    joints = f"{mode['joints']:,} ({share}%)" if share != "—" else "—"
    return [
        f"{mode['planes']:,}",
        figure_or_dash(mode["percent_by_count"], 1),
        figure_or_dash(mode["percent_by_area"], 1),
        joints,
    ]


def set_kinematic_cells(row: dict) -> list[str]:
    """A row of the per-set kinematics table (``kinematics.json``'s ``sets``): the set, its
    mean plane's dip/dip direction, whether that plane slides or topples, the share of the
    set's planes critical in each mode, and the sets its mean forms a critical wedge with.

    Examples
    --------
    >>> row = {"set": 2, "mean_dip": 41.3, "mean_dip_direction": 359.7, "mean_planar_sliding": True,
    ...        "planar_percent_by_count": 99.4, "mean_flexural_toppling": False, "toppling_percent_by_count": 0.0,
    ...        "mean_wedges_with_sets": [0, 1], "wedge_percent_by_count": float("nan")}
    >>> set_kinematic_cells(row)
    ['2', '41/000', 'critical', '99', '—', '0', 'with sets 0, 1', '—']
    """

    def critical(flag: bool) -> str:
        return "critical" if flag else "—"

    return [
        str(row["set"]),
        f"{row['mean_dip']:.0f}/{whole_azimuth(row['mean_dip_direction'])}",
        critical(row["mean_planar_sliding"]),
        figure_or_dash(row["planar_percent_by_count"], 0),
        critical(row["mean_flexural_toppling"]),
        figure_or_dash(row["toppling_percent_by_count"], 0),
        with_sets(row["mean_wedges_with_sets"]),
        figure_or_dash(row["wedge_percent_by_count"], 0),
    ]


def with_sets(sets: list) -> str:
    """The sets a set's mean forms critical wedges with, as words: a set number is no count.

    Examples
    --------
    >>> with_sets([0]), with_sets([0, 2]), with_sets([])
    ('with set 0', 'with sets 0, 2', '—')
    """
    if not sets:
        return "—"
    return ("with set " if len(sets) == 1 else "with sets ") + ", ".join(str(s) for s in sets)


def set_mean_wedge_line(wedge: dict) -> str:
    """One critical wedge of two sets' means (``kinematics.json``'s ``set_mean_wedges``).

    Examples
    --------
    >>> set_mean_wedge_line({"sets": [0, 2], "trend": 168.9, "plunge": 41.2, "wedge_fs": 0.636})
    'The means of sets 0 and 2 form a critical wedge: its line plunges 41° toward 169, factor of safety 0.64.'
    """
    a, b = wedge["sets"]
    where = f" in section {wedge['section']}" if "section" in wedge else ""
    return (
        f"The means of sets {a} and {b} form a critical wedge{where}: its line plunges {wedge['plunge']:.0f}° "
        f"toward {whole_azimuth(wedge['trend'])}, factor of safety {figure_or_dash(wedge['wedge_fs'])}."
    )


#: The per-set kinematics table's title, for one slope and for a face tested in sections.
SET_KINEMATIC_TITLES = (
    "Sets against the slope: the mean plane's tests, and the set's planes critical",
    "Sets against the sections' slopes: a mean is critical where it is in any section (kinematics.json has each), "
    "and the set's planes critical in their own section",
)


#: What each left-out reason of the kinematic tests reads as.
LEFT_OUT_WORDS = {"ground": "on the ground", "clutter": "in clutter (vegetation, debris)",
                  "face_surface": "of the face's own surface"}  # fmt: skip


def left_out_phrase(left_out: dict) -> str:
    """The planes the kinematic tests left out, in words.

    Examples
    --------
    >>> print(left_out_phrase({"clutter": 52, "face_surface": 33}))
    left out: 52 in clutter (vegetation, debris), 33 of the face's own surface
    """
    return "left out: " + ", ".join(f"{count:,} {LEFT_OUT_WORDS.get(why, why)}" for why, count in left_out.items())


def planar_fs_line(planar: dict, basis: str) -> str:
    """The planar factors of safety's sentence: from planes large enough to carry it.

    Examples
    --------
    >>> print(planar_fs_line({"min_fs": 0.8, "median_fs": 0.9, "headline_min_points": 100, "headline_planes": 3,
    ...                       "planes": 5, "min_fs_any_size": 0.2}, "dry, frictional"))
    Planar FS (dry, frictional): 0.80 at least, 0.90 median, on the 3 critical planes of 100 points or more (2 smaller, down to 0.20).
    """
    fewest, large = planar.get("headline_min_points", 0), planar.get("headline_planes", planar["planes"])
    if not fewest:
        return f"Planar FS ({basis}): {planar['min_fs']:.2f} at least, {planar['median_fs']:.2f} median."
    smaller = planar["planes"] - large
    rest = f" ({smaller:,} smaller, down to {planar['min_fs_any_size']:.2f})" if smaller else ""
    if not large:
        return (f"Planar FS ({basis}): no critical plane holds {fewest} points or more; "
                f"{smaller:,} smaller, down to {planar['min_fs_any_size']:.2f}.")  # fmt: skip
    return (f"Planar FS ({basis}): {planar['min_fs']:.2f} at least, {planar['median_fs']:.2f} median, on the "
            f"{counted(large, 'critical plane')} of {fewest} points or more{rest}.")  # fmt: skip


def kinematic_verdicts(summary: dict) -> list[str]:
    """The kinematic tests' verdicts in sentences (``kinematics.json``'s summary), as the
    terminal prints them under its table and the report under its own: the planar factors
    of safety, the wedges, direct and oblique toppling.

    Examples
    --------
    >>> summary = {"planar_sliding": {"planes": 0}, "wedge_sliding": {"critical_pairs": 2, "pairs_tested": 10},
    ...            "direct_toppling": {"intersections_in_zone": 0, "base_planes": 1, "sliding_base_planes": 0,
    ...                                "critical": False}}
    >>> for line in kinematic_verdicts(summary): print(line)
    Wedges: 2 critical pairs of 10 tested.
    Direct toppling: 0 intersections in the zone, 1 base plane (0 steeper than friction): not critical.
    """
    lines = []
    planar, strength = summary["planar_sliding"], summary.get("strength", {})
    if planar["planes"]:
        basis = (
            f"cohesion {strength['cohesion_kpa']:g} kPa, unit weight {strength['unit_weight_kn_m3']:g} kN/m³, "
            f"height {strength['height_m']:.1f} m ({strength['height_source']})"
            if strength.get("cohesion_kpa")
            else "dry, frictional"
        )
        lines.append(planar_fs_line(planar, basis))
    wedge, direct = summary["wedge_sliding"], summary["direct_toppling"]
    of_joints = (
        f"; of the joints' planes, {wedge['critical_joint_pairs']:,} of {wedge['joint_pairs_tested']:,}"
        if wedge.get("joint_pairs_tested")  # none without joints: nothing to say of them
        else ""
    )
    lines.append(
        f"Wedges: {counted(wedge['critical_pairs'], 'critical pair')} of {wedge['pairs_tested']:,} tested{of_joints}."
    )
    lines.append(
        f"Direct toppling: {counted(direct['intersections_in_zone'], 'intersection')} in the zone, "
        f"{counted(direct['base_planes'], 'base plane')} ({direct['sliding_base_planes']:,} steeper than friction): "
        + ("critical." if direct["critical"] else "not critical.")
    )
    oblique = direct.get("oblique")
    if oblique and oblique["intersections_in_zone"]:
        lines.append(
            f"Oblique toppling (Dips' secondary zone): {counted(oblique['intersections_in_zone'], 'intersection')}, "
            f"{counted(oblique['base_planes'], 'oblique base plane')}: "
            + ("critical." if oblique["critical"] else "not critical.")
        )
    return lines


def set_mean_wedge_lines(summary: dict) -> list[str]:
    """A sentence per critical wedge the sets' means form (:func:`set_mean_wedge_line`)."""
    return [set_mean_wedge_line(wedge) for wedge in summary.get("set_mean_wedges", [])]


def window_words(row: dict) -> str:
    """The circular windows' reading of a set's traces (``sets.csv``'s ``trace_window_*``),
    as a clause: "" where no window was laid or no trace end lies in one.

    Examples
    --------
    >>> window_words({"trace_windows": 6, "trace_window_radius_m": 0.9, "trace_window_mean_m": 0.571})
    ', mean length 0.57 m in 6 windows of 0.90 m (censoring-free)'
    >>> window_words({"trace_windows": 0})
    ''
    """
    mean = float(row.get("trace_window_mean_m", float("nan")) or float("nan"))
    if not int(row.get("trace_windows", 0) or 0) or mean != mean:
        return ""
    return (
        f", mean length {mean:.2f} m in {int(row['trace_windows'])} windows of "
        f"{float(row['trace_window_radius_m']):.2f} m (censoring-free)"
    )


def traces_per_set(rows: list[dict]) -> str:
    """The traces' figures per set (``sets.csv``'s trace columns), for the terminal and the
    report: how many, their areal intensity and median chord; "" without traces.

    Examples
    --------
    >>> traces_per_set([{"set": 0, "traces": 2, "trace_p21_per_m": 1.234, "trace_chord_median_m": 0.5}, {"traces": 0}])
    'set 0: 2, P21 1.23 /m, median chord 0.50 m'
    """
    return "; ".join(
        f"set {int(row.get('set', s))}: {int(row['traces']):,}, P21 {float(row['trace_p21_per_m']):.2f} /m, "
        f"median chord {float(row['trace_chord_median_m']):.2f} m" + window_words(row)
        for s, row in enumerate(rows)
        if row.get("traces") and float(row["traces"]) > 0
    )
