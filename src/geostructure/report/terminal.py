"""The terminal's tables (rich) of the planes, sets, kinematics, evaluations and sweeps: the
same words and cells as the HTML report (:mod:`geostructure.report.words`), printed by the
command line."""

from __future__ import annotations

import numpy as np
from rich.console import Console
from rich.table import Table

from geostructure.io.crs import cloud_unit, recorded_unit
from geostructure.io.results import in_square_metres
from geostructure.report.words import (
    FAILURE_MODES,
    SECTION_COLUMNS,
    SET_KINEMATIC_COLUMNS,
    SET_KINEMATIC_TITLES,
    azimuth,
    counted,
    failure_mode_cells,
    figure_or_dash,
    kinematic_verdicts,
    left_out_phrase,
    section_cells,
    set_kinematic_cells,
    set_mean_wedge_lines,
    slope_text,
    traces_per_set,
)
from geostructure.rockmass.notes import block_phrase, jv_phrase, off_face_scope, rqd_phrase, set_notes, trace_cell
from geostructure.rockmass.rqd import block_size_class, rqd_from_jv, rqd_range
from geostructure.rockmass.sets import MIN_SET_PLANES

#: A plane's azimuths are printed as ``planes.csv`` holds them: "level" only where the file
#: leaves them blank (:func:`~geostructure.core.orientation.level_blanked`), so that the
#: table and the file never disagree on which planes are level.
NO_UNCERTAINTY = float("nan")


def stdout_console() -> Console:
    """stdout console; wide enough for the tables when stdout is a file or pipe."""
    console = Console()
    return console if console.is_terminal else Console(width=120)


def print_sweep(rows, console: Console | None = None) -> None:
    console = console or stdout_console()
    table = Table(title="Sweep")
    for column in (
        "factor",
        "value",
        "region growing s",
        "total s",
        "z(R)",
        "z wrapped",
        "mean error",
        "found",
        "planes",
    ):
        table.add_column(column, justify="right")
    for r in rows:
        table.add_row(
            r.factor,
            f"{r.value:g}",
            f"{r.regions_s:.2f}",
            f"{r.total_s:.2f}",
            f"{r.z:.3g}",
            f"{r.z_wrapped:.3g}",
            f"{r.mean_error_deg:.2f}",
            f"{r.found}/{r.found + r.missed}",
            str(r.planes),
        )
    console.print(table)


# A rough outcrop gives over a thousand planes: a terminal of them is unreadable, and rich
# takes 1.5 s to lay out 1,500 rows (a third of a 0.7M-point measure). planes.csv has them all.
MAX_TABLE_ROWS = 40


def print_planes(
    result, console: Console | None = None, max_rows: int = MAX_TABLE_ROWS, planes=None, metres_per_unit: float = 1.0
) -> None:
    """The planes with the most points first, at most ``max_rows`` of them, and a line saying
    where the rest are. ``planes``: the table as written, where it differs from
    ``result.planes`` (with the sets, the standard errors carry the joints' correlated tilt).
    Their area in square metres, as ``planes.csv`` holds it (``metres_per_unit``: of the
    cloud's unit)."""
    console = console or stdout_console()
    planes = in_square_metres(result.planes if planes is None else planes, metres_per_unit)
    shown = planes.subset(np.argsort(-planes.n_points, kind="stable")[:max_rows])
    caption = (
        f"the {len(shown)} of {len(planes)} planes with the most points; all in planes.csv"
        if len(shown) < len(planes)
        else None
    )
    table = Table(title=f"Planes in {result.cloud.name} (frame: {result.frame.name})", caption=caption)
    for column in ("id", "points", "area m²", "strike", "dip", "dip dir", "± deg", "centroid"):
        table.add_column(column, justify="right")
    for row in shown.rows():
        table.add_row(
            str(row["region_id"]),
            f"{row['n_points']:,}",
            f"{row['area_m2']:.4g}",
            azimuth(row["strike"], row["dip"], NO_UNCERTAINTY),  # planes.csv's own blank: one rule
            f"{row['dip']:04.1f}",
            azimuth(row["dip_direction"], row["dip"], NO_UNCERTAINTY),
            f"{row['normal_uncertainty_deg']:.2f}",
            f"{row['centroid_x']:.2f}, {row['centroid_y']:.2f}, {row['centroid_z']:.2f}",
        )
    console.print(table)


def print_sets(sets, console: Console | None = None, rock=None) -> None:
    """The joint sets (:class:`~geostructure.rockmass.sets.JointSets`), one row each; with ``rock``
    (:class:`~geostructure.rockmass.mass.RockMass`), their spacing and intensity too."""
    console = console or stdout_console()
    if not len(sets):
        n = len(sets.labels)
        console.print(
            (
                f"No joint set: the {n} planes do not share an orientation."
                if n == MIN_SET_PLANES
                else f"No joint set: no {MIN_SET_PLANES} of the {n} planes share an orientation."
            )  # fmt: skip
            if n >= MIN_SET_PLANES
            else f"No joint set: {n} plane{'' if n == 1 else 's'}, and a set needs {MIN_SET_PLANES}."
        )
        return
    title = f"Joint sets ({sets.criterion}; {int((sets.labels < 0).sum())} planes in no set)"
    if rock is not None:
        counts = [0 if flags is None else int(flags.sum()) for flags in (rock.ground, rock.clutter)]
        title = title[:-1] + off_face_scope(*counts) + ")"
    rock_rows = rock.set_rows() if rock is not None else [{}] * len(sets)
    if rock is not None and np.isfinite(rock.jv):
        title += jv_phrase(rock.jv, rock_rows)
        title += block_phrase(rock.block_volume, block_size_class(rock.jv), rock_rows)
        title += rqd_phrase(rqd_from_jv(rock.jv), *rqd_range(sets.mean_normal, rock.spacing),
                            bound=not np.isfinite(rock.block_volume))  # fmt: skip
    table = Table(title=title)
    columns = ["set", "planes", "area m²", "dip", "dip dir", "K", "α95°", "sph. var."]
    for column in columns + (["spacing m", "P32 1/m", "trace m", "persistence"] if rock is not None else []):
        table.add_column(column, justify="right")
    for row, more in zip(sets.rows(), rock_rows):
        extra = (
            [
                figure_or_dash(more["spacing_m"]),
                figure_or_dash(more["p32_per_m"]),
                trace_cell(more) or figure_or_dash(more["joint_trace_mean_m"], 1),
                more["persistence"] or "—",
            ]
            if more
            else []
        )
        table.add_row(
            str(row["set"]),
            str(row["n_planes"]),
            f"{row['area_m2']:.4g}",
            f"{row['dip']:04.1f}",
            azimuth(row["dip_direction"], row["dip"], row["alpha95_deg"]),
            f"{row['fisher_k']:.0f}",
            f"{row['alpha95_deg']:.1f}",
            f"{row['spherical_variance']:.3f}",
            *extra,
        )
    console.print(table)
    for s, more in enumerate(rock_rows):
        for note in set_notes(s, more) if more else ():
            console.print(note)
    if rock is not None and rock.traces is not None:
        console.print(traces_line(rock.traces, rock_rows))


def traces_line(traces, rows: list[dict]) -> str:
    """The face's fracture traces in a sentence: how many, of which kind, and per set their
    areal intensity and median chord (``sets.csv``'s trace columns).

    Examples
    --------
    >>> import numpy as np
    >>> from geostructure.detect.traces import Traces
    >>> t = Traces.from_polylines([np.zeros((2, 3))] * 3, ["plane", "dark line", "dark line"], [0, -1, -1])
    >>> print(traces_line(t, [{"traces": 2, "trace_p21_per_m": 1.234, "trace_chord_median_m": 0.5}]))
    Traces: 3 drawn (2 dark lines, 1 plane's trace); set 0: 2, P21 1.23 /m, median chord 0.50 m.
    """
    dark = int(np.sum(traces.source == "dark line"))
    valleys = int(np.sum(traces.source == "valley"))
    planes = len(traces) - dark - valleys
    kinds = f"{counted(dark, 'dark line')}, " + (f"{counted(valleys, 'valley')}, " if valleys else "")
    kinds += f"{planes:,} " + ("plane's trace" if planes == 1 else "planes' traces")
    per_set = traces_per_set(rows)
    return f"Traces: {len(traces):,} drawn ({kinds})" + (f"; {per_set}." if per_set else ".")


def print_kinematics(summary: dict, console: Console | None = None) -> None:
    """The kinematic tests' summary (``kinematics.json``), one row per failure mode."""
    console = console or stdout_console()
    title = (
        f"Kinematics: {slope_text(summary)}, friction {summary['friction_deg']:g}°, "
        f"lateral limits {summary['lateral_limit_deg']:g}°"
    )
    left_out = {why: count for why, count in summary.get("left_out", {}).items() if count}
    if left_out:
        title += f"; {summary['planes_tested']:,} planes tested, " + left_out_phrase(left_out)
    table = Table(title=title)
    for column in ("failure mode", "planes", "% by count", "% by area", "joints"):
        table.add_column(column, justify="right")
    for key, name in FAILURE_MODES:
        table.add_row(name, *failure_mode_cells(summary, key))
    console.print(table)
    for line in kinematic_verdicts(summary):
        console.print(line)
    if summary.get("sections"):
        table = Table(title="Sections, from left to right as one faces the rock: each plane against its own")
        for column in SECTION_COLUMNS:
            table.add_column(column, justify="right")
        for section in summary["sections"]:
            table.add_row(*section_cells(section))
        console.print(table)
    if summary.get("sets"):
        print_set_kinematics(summary["sets"], console, sectioned=bool(summary.get("sections")))
    for line in set_mean_wedge_lines(summary):
        console.print(line)


#: The failure modes of a kinematics summary (``kinematics.json``), in table order.
def print_set_kinematics(sets: list[dict], console: Console, sectioned: bool = False) -> None:
    """Per set: what its mean plane does, alone and with the other sets' means, and the share
    of its planes critical in each mode."""
    table = Table(title=SET_KINEMATIC_TITLES[sectioned])
    for column in SET_KINEMATIC_COLUMNS:
        table.add_column(column, justify="right")
    for row in sets:
        table.add_row(*set_kinematic_cells(row))
    console.print(table)


def print_evaluation(evaluation, console: Console | None = None) -> None:
    console = console or stdout_console()
    table = Table(title="Against the ground truth")
    for column in (
        "surface",
        "region",
        "true strike/dip/dd",
        "measured strike/dip/dd",
        "z(R_i)",
        "z wrapped",
        "normal error",
    ):
        table.add_column(column, justify="right")
    for s in evaluation.surfaces:
        measured = (
            f"{azimuth(s.strike, s.dip, NO_UNCERTAINTY)}/{s.dip:04.1f}/{azimuth(s.dip_direction, s.dip, NO_UNCERTAINTY)}"
            if s.found
            else "missed"
        )
        table.add_row(
            s.surface,
            str(s.region) if s.found else "-",
            f"{s.true_strike:05.1f}/{s.true_dip:04.1f}/{s.true_dip_direction:05.1f}",
            measured,
            f"{s.z_region:.4f}",
            f"{s.z_region_wrapped:.4f}",
            f"{s.normal_error_deg:.2f} deg" if s.found else "-",
        )
    console.print(table)
    errors = (
        f"normal error mean {evaluation.mean_error:.2f} deg, max {evaluation.max_error:.2f} deg; "
        if evaluation.n_found
        else ""  # no surface found: no error to average
    )
    console.print(
        f"z(R) = {evaluation.z:.4f} as printed in the paper, {evaluation.z_wrapped:.4f} wrap-aware; "
        f"{errors}{evaluation.n_found} of {len(evaluation.surfaces)} surfaces found"
    )


def frame_fit_line(fit: dict) -> str:
    """The frame fitted to a ground truth (``run.json``'s ``frame_fit``), in a line."""
    residuals = ", ".join(f"{r:.1f}" for r in fit["residuals_deg"])
    return (
        f"frame fitted to the ground truth: turned {fit['rotation_deg']:.1f} deg; residuals {residuals} deg (mean "
        f"{fit['mean_residual_deg']:.2f}); angles between surfaces off by {fit['pairwise_mean_deg']:.2f} deg on "
        f"average (frame-free)"
    )


def print_match(match, console: Console | None = None) -> None:
    console = console or stdout_console()
    table = Table(title="Against the scene's ground truth")
    for column in ("surface", "region", "true dd/dip", "measured dd/dip", "normal error (deg)"):
        table.add_column(column, justify="right")
    for row in match.surfaces:
        found = row.found
        table.add_row(
            row.surface,
            str(row.region) if found else "missed",
            f"{row.true_dip_direction:05.1f}/{row.true_dip:04.1f}",
            f"{azimuth(row.dip_direction, row.dip, NO_UNCERTAINTY)}/{row.dip:04.1f}" if found else "-",
            f"{row.normal_error_deg:.3f}" if found else "-",
        )
    console.print(table)
    console.print(
        f"mean normal error {match.mean_error:.3f} deg, max {match.max_error:.3f} deg, "
        f"{match.n_found} of {len(match.surfaces)} surfaces found"
    )


def validation_lines(summary: dict) -> str:
    """The scores against a field map (``validation.json``'s) as sentences.

    Examples
    --------
    >>> print(validation_lines({"mapped": 4, "matched": 1, "planes": 2, "planes_matching": 1, "precision": 0.5,
    ...     "max_distance": 0.6, "max_angle_deg": 10.0, "set_errors_deg": {"1": 3.04}, "set_means_from": "field map"}))
    1 of 4 mapped planes matched (25%): a measured plane's centroid within 0.6 and its normal within 10 degrees.
    1 of the 2 measured planes (50%) match a mapped one.
    Set 1 (field map): 3.0 degrees from the nearest measured set.
    """
    mapped, matched = summary["mapped"], summary["matched"]
    lines = [
        f"{matched} of {mapped} mapped planes matched ({matched / max(mapped, 1):.0%}): a measured plane's "
        f"centroid within {summary['max_distance']:g} and its normal within {summary['max_angle_deg']:g} degrees.",
        f"{summary['planes_matching']} of the {summary['planes']} measured planes "
        f"({summary['precision']:.0%}) match a mapped one."
        if summary["planes"]
        else "No plane was measured.",
    ]
    traces = summary.get("traces")
    if traces and "traced" in traces:
        lines.append(
            f"{traces['traced']} of {mapped} mapped fractures traced ({traces['traced'] / max(mapped, 1):.0%}) by "
            f"{traces['found']} traces, trace precision {traces['trace_precision']:.2f}; for nothing (as many random "
            f"segments of the same chords): {traces['null_traced']} at {traces['null_precision']:.2f}."
        )
        lines.append(f"{traces['found_by_plane_or_trace']} of {mapped} found by a plane or a trace.")
        for label, s in traces.get("sets", {}).items():
            measured = f"set {s['measured_set']}" if s["measured_set"] >= 0 else "no measured set"
            lines.append(
                f"Set {label} ({measured}): {s['found_traces']} traces, {s['found_chord_sum']:.1f} m of chords, median "
                f"{s['found_chord_median']:.2f} m; mapped {s['mapped_traces']}, {s['mapped_chord_sum']:.1f} m, median "
                f"{s['mapped_chord_median']:.2f} m."
            )
            if s.get("windows"):
                lines.append(
                    f"  In {s['windows']} circular windows of {s['window_radius_m']:.2f} m (censoring-free): mean trace "
                    f"length {s['found_window_mean_m']:.2f} m, P21 {s['found_window_p21_per_m']:.2f} /m; mapped "
                    f"{s['mapped_window_mean_m']:.2f} m, {s['mapped_window_p21_per_m']:.2f} /m; for nothing "
                    f"{s['null_window_mean_m']:.2f} m, {s['null_window_p21_per_m']:.2f} /m. P10 on scanlines across "
                    f"the map's traces: {s['found_p10_per_m']:.2f} /m; mapped {s['mapped_p10_per_m']:.2f}; for nothing "
                    f"{s['null_p10_per_m']:.2f}."
                )
    elif traces:
        lines.append(f"Traces: {traces['note']}.")
    errors = summary.get("set_errors_deg")
    if errors is None:
        lines.append("No sets to score: run 'geostructure sets OUTDIR' (or measure --sets) first.")
    for label, error in (errors or {}).items():
        source = summary["set_means_from"]
        lines.append(f"Set {label} ({source}): " + (f"{error:.1f} degrees from the nearest measured set."
                     if error == error else "no measured set."))  # fmt: skip
    return "\n".join(lines)


def print_run(run, took: float, unit: str | None = None) -> None:
    """What a measure prints when done (a :class:`~geostructure.workflows.survey.SurveyRun`):
    the planes, sets, kinematics and evaluation, and what it took (``took``, seconds) and
    wrote; ``unit``: the length unit given for a cloud without a CRS."""
    result, outcrop = run.result, run.outcrop
    cloud = result.cloud
    if outcrop is None:  # streamed
        print_planes(result, metres_per_unit=recorded_unit({"crs": cloud.crs, **run.record})["metres"])
        if run.evaluation is not None:
            print_evaluation(run.evaluation)
        print(f"{counted(len(result), 'plane')} from {result.counts['input']:,} points ({run.engine} engine) in "
              f"{took:.1f} s; wrote {', '.join(str(p) for p in run.paths.values())}")  # fmt: skip
        return
    sets, rock = outcrop.sets, outcrop.rock
    print_planes(result, planes=None if sets is None else outcrop.planes,  # as written
                 metres_per_unit=cloud_unit(cloud.crs, unit)["metres"])  # fmt: skip
    if sets is not None:
        print_sets(sets, rock=rock)
    if outcrop.kinematic_options is not None:
        print_kinematics(outcrop.kinematics)
    if run.evaluation is not None:
        print_evaluation(run.evaluation)
    thinned = run.record.get("thinned") or {}
    of_survey = f" of the survey's {thinned['survey_points']:,}" if thinned.get("cell") else ""
    joints = f" ({len(rock.joints)} joints)" if rock is not None and rock.joints is not None else ""
    print(
        f"{counted(len(result), 'plane')}{joints} from {len(cloud):,} points{of_survey} in {took:{'.2f' if took < 1 else '.1f'}} s; "
        f"wrote {', '.join(str(p) for p in run.paths.values())}"
    )
