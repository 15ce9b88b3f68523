"""What in a joint set's row of ``sets.csv`` is not a measurement as it stands: the flags of
its ``flags`` column (:func:`set_flags`), each with its sentence under the tables
(:mod:`.notes`).
"""

from __future__ import annotations

import numpy as np

from geostructure.rockmass.tracelengths import persistence_class

#: Joint traces seen end to end below which a set's mean trace length (the censored
#: exponential's, its standard error the mean over their root) is too loose to give without
#: saying so: at 3 the standard error is 58% of the mean.
FEW_WHOLE_TRACES = 3
#: The flags of ``sets.csv``'s ``flags`` column (:func:`set_flags`), each with its sentence
#: under the tables (:mod:`.setnotes`).
SPACING_NOT_MEASURED = "spacing_not_measured"
TRACES_ALL_CENSORED = "traces_all_censored"
FEW_WHOLE_TRACES_FLAG = "few_whole_traces"
TRACE_BEYOND_EXPOSURE = "trace_longer_than_exposure"
SPACING_FEW_GAPS = "spacing_few_gaps"
TRACES_MOSTLY_CENSORED = "traces_mostly_censored"
FRACTURE_TRACES_MOSTLY_CENSORED = "fracture_traces_mostly_censored"
FRACTURE_TRACES_UNDERCOUNT = "fracture_traces_undercount"
PERSISTENCE_WINDOWS_DIFFER = "persistence_windows_differ"
#: Gaps between a set's planes along the scanlines below which its spacing is a guess: an
#: exponential mean from n gaps has a standard error of mean / sqrt(n), 45% at 5.
MIN_SPACING_GAPS = 5
#: The share of a set's traces running out of sight above which the mean length with
#: censoring rests more on the model than on the traces seen whole.
MOSTLY_CENSORED = 0.5


def set_flags(row: dict) -> list[str]:
    """What in a set's row (:meth:`RockMass.set_rows`) is not a measurement as it stands:
    the spacing no scanline measures (a set along the face), traces that all run out of
    sight (the mean not measured, the length seen a lower bound), a mean resting on
    :data:`FEW_WHOLE_TRACES` or fewer whole traces, a mean longer than the exposure spans, a
    spacing from fewer than :data:`MIN_SPACING_GAPS` gaps, a mean trace from traces more than
    :data:`MOSTLY_CENSORED` of which run out of sight, the same of the fracture traces
    drawn (``trace_censored`` of ``traces``: their mean with censoring leans on its model),
    fracture traces that cross the scanlines less often than the planes do
    (:func:`traces_below_planes`), and a persistence class the circular windows read
    otherwise (:func:`windows_persistence`).

    Examples
    --------
    >>> set_flags({"spacing_m": float("nan"), "joint_traces": 0})
    ['spacing_not_measured']
    >>> set_flags({"spacing_m": 0.4, "joint_traces": 9, "joint_traces_censored": 9,
    ...            "joint_trace_estimate_m": float("nan"), "exposure_span_m": 20.0})
    ['traces_all_censored']
    >>> set_flags({"spacing_m": 8.06, "spacing_n_gaps": 1, "joint_traces": 14, "joint_traces_censored": 10,
    ...            "joint_trace_estimate_m": 5.3, "exposure_span_m": 20.0})
    ['spacing_few_gaps', 'traces_mostly_censored']
    """
    flags = [] if np.isfinite(row["spacing_m"]) else [SPACING_NOT_MEASURED]
    gaps = row.get("spacing_n_gaps")
    if np.isfinite(row["spacing_m"]) and gaps is not None and int(gaps) < MIN_SPACING_GAPS:
        flags.append(SPACING_FEW_GAPS)
    traces, hidden = int(row.get("joint_traces", 0)), int(row.get("joint_traces_censored", 0))
    estimate = float(row.get("joint_trace_estimate_m", np.nan))
    if traces and not np.isfinite(estimate):
        flags.append(TRACES_ALL_CENSORED)
    elif estimate > float(row.get("exposure_span_m", np.inf)):
        flags.append(TRACE_BEYOND_EXPOSURE)
    elif traces and hidden and traces - hidden <= FEW_WHOLE_TRACES:
        flags.append(FEW_WHOLE_TRACES_FLAG)
    elif traces and hidden > MOSTLY_CENSORED * traces:
        flags.append(TRACES_MOSTLY_CENSORED)
    drawn, cut = int(row.get("traces", 0) or 0), int(row.get("trace_censored", 0) or 0)
    if drawn and cut > MOSTLY_CENSORED * drawn:
        flags.append(FRACTURE_TRACES_MOSTLY_CENSORED)
    if traces_below_planes(row):
        flags.append(FRACTURE_TRACES_UNDERCOUNT)
    stated = str(row.get("persistence", "") or "").removesuffix(" or more")
    joints_mean = float(row.get("joint_trace_mean_m", np.nan) or np.nan)
    if stated and np.isfinite(joints_mean) and windows_persistence(row) not in ("", stated):  # both read, and apart
        flags.append(PERSISTENCE_WINDOWS_DIFFER)
    return flags


def windows_persistence(row: dict) -> str:
    """ISRM's persistence class of the mean trace length circular windows read on a set's
    fracture traces (``trace_window_mean_m``), "" where no window fits. Where it is not the
    class of the joints' traces (``persistence``, from the planes' extents along the face),
    the set says so: on the Lastoni SW half the joints read 2.5 to 2.9 m ("low") for every
    set, the windows 0.43 to 0.57 m ("very low"), and the map 0.55 and 0.39 m.

    Examples
    --------
    >>> windows_persistence({"trace_windows": 4, "trace_window_mean_m": 0.57}), windows_persistence({"trace_windows": 0})
    ('very low', '')
    """
    window = float(row.get("trace_window_mean_m", np.nan) or np.nan)
    if not int(float(row.get("trace_windows", 0) or 0)) or not np.isfinite(window):
        return ""
    return persistence_class(window)


def traces_below_planes(row: dict) -> bool:
    """Whether a set's fracture traces cross its scanlines less often than its planes do,
    beyond two standard errors of the difference (each count a Poisson one): the traces then
    miss fractures the planes show, and the traces' P10 and P21 are lower bounds. On the
    Lastoni SW half sets 0 and 1 (traces 1.59 and 0.43 /m, planes 2.28 and 0.93), where the
    hand-drawn map reads 1.8 and 1.6 times the traces' P21.

    Examples
    --------
    >>> traces_below_planes({"trace_p10_per_m": 1.59, "trace_scanline_m": 45.2, "p10_per_m": 2.28,
    ...                      "scanline_length_m": 41.2})
    True
    >>> traces_below_planes({"trace_p10_per_m": 0.62, "trace_scanline_m": 46.5, "p10_per_m": 0.84,
    ...                      "scanline_length_m": 40.4})
    False
    """
    values = [float(row.get(k, np.nan) or np.nan) for k in ("trace_p10_per_m", "trace_scanline_m", "p10_per_m",
                                                            "scanline_length_m")]  # fmt: skip
    traces, trace_line, planes, plane_line = values
    if not (np.isfinite(values).all() and trace_line > 0 and plane_line > 0):
        return False
    error = np.sqrt(traces / trace_line + planes / plane_line)  # var(n / L) = n / L^2 = P10 / L
    return bool(planes - traces > 2.0 * error)
