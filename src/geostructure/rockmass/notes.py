"""What a table of joint sets leaves out, in words.

The sentences under the table (the terminal's and the report's) each take a set's row of
``sets.csv`` (:meth:`~geostructure.rockmass.mass.RockMass.set_rows`, or the file read back): a spacing that
no scanline can measure, a spacing counted on the joints' traces, traces that all run out
of sight, the sets Jv leaves out and the planes in no set that are not the rock's, a face
that turns. The notes and warnings a sets run prints say what of the cloud it left out or
could not see: the points classified as vegetation, the joints a voxel detector misses, a
face that turns.
"""

from __future__ import annotations

import warnings

import numpy as np

from geostructure.detect.registry import detector_spec
from geostructure.detect.uncertainty import MIN_TILT_FACETS
from geostructure.errors import GeoStructureNote, GeoStructureWarning
from geostructure.rockmass.exposure import BENT_FACE
from geostructure.rockmass.face import CLUTTER
from geostructure.rockmass.mass import BLOCK_SETS, RockMass
from geostructure.rockmass.setflags import (
    FEW_WHOLE_TRACES,
    FRACTURE_TRACES_MOSTLY_CENSORED,
    FRACTURE_TRACES_UNDERCOUNT,
    MIN_SPACING_GAPS,
    PERSISTENCE_WINDOWS_DIFFER,
    SPACING_FEW_GAPS,
    TRACE_BEYOND_EXPOSURE,
    TRACES_MOSTLY_CENSORED,
)
from geostructure.rockmass.spacing import MIN_SCANLINE_COSINE
from geostructure.rockmass.tracelengths import persistence_class


def set_notes(set_id: int, row: dict) -> list[str]:
    """Every sentence due under set ``set_id``'s row (``sets.csv``), in the tables' order.

    Examples
    --------
    >>> set_notes(2, {"spacing_m": 0.4, "spacing_basis": "persistent", "joint_traces": 5, "joint_trace_mean_m": 2.1})
    []
    """
    notes = (
        unmeasured_spacing(set_id, row),
        persistence_note(set_id, row),
        censored_traces_note(set_id, row),
        trace_beyond_exposure_note(set_id, row),
        few_gaps_note(set_id, row),
        mostly_censored_note(set_id, row),
        censored_fracture_traces_note(set_id, row),
        undercount_note(set_id, row),
        windows_persistence_note(set_id, row),
    )
    return [note for note in notes if note]


def _flagged(row: dict, flag: str) -> bool:
    return flag in str(row.get("flags", "")).split(";")


def few_gaps_note(set_id: int, row: dict) -> str | None:
    """A sentence when set ``set_id``'s spacing rests on fewer than :data:`MIN_SPACING_GAPS`
    gaps between its planes (``spacing_few_gaps``): a figure no exposure this size supports.

    Examples
    --------
    >>> few_gaps_note(0, {"flags": "spacing_few_gaps", "spacing_m": 8.06, "spacing_n_gaps": 1})
    "Set 0's spacing, 8.06 m, rests on 1 gap between its planes (fewer than 5): read it as a guess, not a measurement."
    """
    if not _flagged(row, SPACING_FEW_GAPS):
        return None
    gaps = int(float(row["spacing_n_gaps"]))
    return (
        f"Set {set_id}'s spacing, {float(row['spacing_m']):.2f} m, rests on {gaps} gap{'' if gaps == 1 else 's'} "
        f"between its planes (fewer than {MIN_SPACING_GAPS}): read it as a guess, not a measurement."
    )


def mostly_censored_note(set_id: int, row: dict) -> str | None:
    """A sentence when most of set ``set_id``'s joint traces run out of sight
    (``traces_mostly_censored``): their mean length with censoring leans on its model.

    Examples
    --------
    >>> mostly_censored_note(0, {"flags": "traces_mostly_censored", "joint_traces": 14, "joint_traces_censored": 10,
    ...                          "joint_trace_mean_m": 5.3, "persistence": "medium"})
    "10 of set 0's 14 joint traces (71%) run out of sight: their mean length, 5.3 m, leans on the censored model more than on the traces seen whole, so its persistence, medium, is an upper guide."
    """
    if not _flagged(row, TRACES_MOSTLY_CENSORED):
        return None
    traces, hidden = int(float(row["joint_traces"])), int(float(row["joint_traces_censored"]))
    sentence = (
        f"{hidden} of set {set_id}'s {traces} joint traces ({hidden / traces:.0%}) run out of sight: their mean "
        f"length, {float(row['joint_trace_mean_m']):.1f} m, leans on the censored model more than on the traces seen "
        f"whole, so its persistence, {row['persistence']}, is an upper guide."
    )
    window = float(row.get("trace_window_mean_m", float("nan")) or float("nan"))
    if int(float(row.get("trace_windows", 0) or 0)) and window == window:
        sentence += (
            f" Circular windows, which no censoring biases, read its fracture traces' mean length as {window:.2f} m "
            f"({persistence_class(window)} persistence)."
        )
    return sentence


def censored_fracture_traces_note(set_id: int, row: dict) -> str | None:
    """A sentence when most of set ``set_id``'s fracture traces reach the exposure's edge
    (``fracture_traces_mostly_censored``): their mean length with censoring leans on its model.

    Examples
    --------
    >>> censored_fracture_traces_note(0, {"flags": "fracture_traces_mostly_censored", "traces": 80,
    ...                                   "trace_censored": 50, "trace_censored_mean_m": 1.4})
    "50 of set 0's 80 fracture traces (62%) reach the face's edge or a hole: their mean length with censoring, 1.40 m, leans on its model more than on the traces seen whole."
    """
    if not _flagged(row, FRACTURE_TRACES_MOSTLY_CENSORED):
        return None
    drawn, cut = int(float(row["traces"])), int(float(row["trace_censored"]))
    mean = float(row.get("trace_censored_mean_m", float("nan")) or float("nan"))
    tail = (
        f"their mean length with censoring, {mean:.2f} m, leans on its model more than on the traces seen whole"
        if mean == mean
        else "none is seen end to end, so their mean length is not measured"
    )
    return (
        f"{cut} of set {set_id}'s {drawn} fracture traces ({cut / drawn:.0%}) reach the face's edge or a hole: {tail}."
    )


def undercount_note(set_id: int, row: dict) -> str | None:
    """A sentence when set ``set_id``'s fracture traces cross its scanlines less often than
    its planes do (``fracture_traces_undercount``): its trace intensities are lower bounds.

    Examples
    --------
    >>> undercount_note(0, {"flags": "fracture_traces_undercount", "trace_p10_per_m": 1.59, "p10_per_m": 2.28})
    "Set 0's fracture traces cross its scanlines 1.59 times a metre where its planes cross 2.28: the traces miss fractures the planes show, so its trace P10 and P21 are lower bounds."
    """
    if not _flagged(row, FRACTURE_TRACES_UNDERCOUNT):
        return None
    traces, planes = float(row["trace_p10_per_m"]), float(row["p10_per_m"])
    return (
        f"Set {set_id}'s fracture traces cross its scanlines {traces:.2f} times a metre where its planes cross "
        f"{planes:.2f}: the traces miss fractures the planes show, so its trace P10 and P21 are lower bounds."
    )


def windows_persistence_note(set_id: int, row: dict) -> str | None:
    """A sentence when the circular windows on set ``set_id``'s fracture traces read another
    persistence class than its joints' traces do (``persistence_windows_differ``); none where
    :func:`mostly_censored_note` already gives the windows' figure.

    Examples
    --------
    >>> windows_persistence_note(0, {"flags": "persistence_windows_differ", "trace_window_mean_m": 0.57,
    ...                              "joint_trace_mean_m": 2.57, "persistence": "low"})
    "Set 0's joints' traces read a mean length of 2.6 m (low persistence), but circular windows on its fracture traces, which no censoring biases, read 0.57 m (very low): the joints' figure bridges the gaps between each joint's facets and models the traces the edge cuts, the windows' counts the traces drawn."
    """
    if not _flagged(row, PERSISTENCE_WINDOWS_DIFFER) or _flagged(row, TRACES_MOSTLY_CENSORED):
        return None
    window = float(row["trace_window_mean_m"])
    return (
        f"Set {set_id}'s joints' traces read a mean length of {float(row['joint_trace_mean_m']):.1f} m "
        f"({row['persistence']} persistence), but circular windows on its fracture traces, which no censoring "
        f"biases, read {window:.2f} m ({persistence_class(window)}): the joints' figure bridges the gaps between "
        f"each joint's facets and models the traces the edge cuts, the windows' counts the traces drawn."
    )


def unmeasured_spacing(set_id: int, row: dict) -> str | None:
    """Why set ``set_id`` has no scanline spacing (nor P10, nor P32), in a sentence, from its
    row of ``sets.csv`` (:meth:`~geostructure.rockmass.mass.RockMass.set_rows`); None when it has one. A set
    whose planes lie along the exposed face (a horizontal face's bedding, a wall's own
    joints) is crossed by no line drawn on that face (ISRM 1978's blind zone, Terzaghi 1965).

    Examples
    --------
    >>> row = {"spacing_m": float("nan"), "scanline_cosine": 0.0229, "spacing_nearest_m": 3.128}
    >>> unmeasured_spacing(0, row)
    "Set 0 lies along the exposed face (its mean normal 1° from the face's), so no scanline on the face crosses it: its spacing, P10, P32 and traces are not measured (its nearest-plane spacing, after DSE, is 3.13 m)."
    """
    if np.isfinite(row["spacing_m"]):
        return None
    cosine = float(row["scanline_cosine"])
    unmeasured = "spacing, P10 and P32"
    if cosine < MIN_SCANLINE_COSINE:
        angle = np.degrees(np.arcsin(np.clip(cosine, 0.0, 1.0)))
        why = f"lies along the exposed face (its mean normal {angle:.0f}° from the face's), so no scanline on the face crosses it"
        unmeasured = "spacing, P10, P32 and traces"  # the face shows its planes whole, not their traces
    else:
        why = "has no joint that a scanline on the exposed face crosses"
    near = float(row.get("spacing_nearest_m", np.nan))
    tail = f" (its nearest-plane spacing, after DSE, is {near:.2f} m)" if np.isfinite(near) else ""
    return f"Set {set_id} {why}: its {unmeasured} are not measured{tail}."


def persistence_note(set_id: int, row: dict) -> str | None:
    """A sentence when set ``set_id``'s spacing counts its joints only where their traces
    show (``spacing_basis`` "traces" in its row of ``sets.csv``), naming both spacings.

    Examples
    --------
    >>> persistence_note(1, {"spacing_basis": "traces", "spacing_persistent_m": 0.11, "spacing_traces_m": 0.52})
    "Set 1's joints show over short stretches of the face: its spacing, 0.52 m, counts each only where its trace shows (0.11 m if each were a plane across the whole face)."
    >>> persistence_note(1, {"spacing_basis": "persistent", "spacing_persistent_m": 0.5}) is None
    True
    """
    if row.get("spacing_basis") != "traces":
        return None
    return (
        f"Set {set_id}'s joints show over short stretches of the face: its spacing, {float(row['spacing_traces_m']):.2f} m, "
        f"counts each only where its trace shows ({float(row['spacing_persistent_m']):.2f} m if each were a plane "
        "across the whole face)."
    )


def off_face_scope(ground: int, clutter: int) -> str:
    """What of the planes in no set is not the rock's: ``"; of them 1 the level ground before
    the face and 31 in clutter off the face (vegetation, debris, objects)"``, or ``""`` when none is.

    Examples
    --------
    >>> off_face_scope(1, 31)
    '; of them 1 the level ground before the face and 31 in clutter off the face (vegetation, debris, objects)'
    >>> off_face_scope(0, 0)
    ''
    """
    parts = [f"{n} {what}" for n, what in ((ground, "the level ground before the face"),
                                           (clutter, "in clutter off the face (vegetation, debris, objects)")) if n]  # fmt: skip
    return f"; of them {' and '.join(parts)}" if parts else ""


def jv_scope(rows: list[dict]) -> str:
    """What the volumetric joint count leaves out: ``" (without sets 0, 2)"`` when some of
    the sets' rows (:meth:`~geostructure.rockmass.mass.RockMass.set_rows`, in set order) have no spacing, else ``""``.

    Examples
    --------
    >>> jv_scope([{"spacing_m": float("nan")}, {"spacing_m": 0.4}])
    ' (without set 0)'
    """
    missing = [s for s, row in enumerate(rows) if not np.isfinite(row["spacing_m"])]
    if not missing:
        return ""
    return f" (without set{'s' if len(missing) > 1 else ''} {', '.join(map(str, missing))})"


def block_phrase(block_volume: float, size_class: str, rows: list[dict]) -> str:
    """The tables' words for the block volume: its value and ISRM size, or, with fewer than
    :data:`~geostructure.rockmass.mass.BLOCK_SETS` sets whose spacing was measured (``rows``, as
    :func:`jv_scope` takes them), why there is none.

    Examples
    --------
    >>> block_phrase(0.29, "medium-sized blocks", [{"spacing_m": 0.7}] * 3)
    ', block 0.29 m³ (medium-sized)'
    >>> block_phrase(float("nan"), "large blocks", [{"spacing_m": 0.68}])
    ', no block volume (1 set with a spacing: blocks close on 3)'
    """
    if np.isfinite(block_volume):
        return f", block {block_volume:.2g} m³ ({size_class.removesuffix(' blocks')})"
    measured = sum(1 for row in rows if np.isfinite(row["spacing_m"]))
    return (
        f", no block volume ({measured} set{'' if measured == 1 else 's'} with a spacing: blocks close on {BLOCK_SETS})"
    )


def jv_phrase(jv: float, rows: list[dict]) -> str:
    """The tables' words for the volumetric joint count: its value and the sets it leaves
    out (:func:`jv_scope`); with fewer than :data:`~geostructure.rockmass.mass.BLOCK_SETS` sets whose
    spacing was measured, a lower bound (the rock's other sets, unseen, would add to it: a
    room's floor and shelves gave Jv 1.5 from one "set").

    Examples
    --------
    >>> jv_phrase(5.24, [{"spacing_m": 0.4}] * 3)
    '; Jv 5.2/m³'
    >>> jv_phrase(1.47, [{"spacing_m": 0.68}])
    '; Jv at least 1.5/m³ (from 1 set)'
    """
    measured = sum(1 for row in rows if np.isfinite(row["spacing_m"]))
    if measured >= BLOCK_SETS:
        return f"; Jv {jv:.1f}/m³{jv_scope(rows)}"
    return f"; Jv at least {jv:.1f}/m³ (from {measured} set{'' if measured == 1 else 's'})"


def rqd_phrase(from_jv, least=None, greatest=None, *, bound: bool = False) -> str:
    """The tables' words for RQD: from Jv (Palmström 2005), and its range along a line
    (Priest & Hudson 1976) where measured; ``""`` without Jv.

    Examples
    --------
    >>> rqd_phrase(85.0, 80.4, 97.2)
    ', RQD 85 (80 to 97 by direction)'
    >>> rqd_phrase(100.0, 99.6, 100.0)
    ', RQD 100 (100 in every direction)'
    >>> rqd_phrase(float("nan"))
    ''
    """
    if from_jv is None or not np.isfinite(from_jv):
        return ""
    along = ""
    if least is not None and greatest is not None and np.isfinite(least) and np.isfinite(greatest):
        low, high = f"{least:.0f}", f"{greatest:.0f}"
        along = f" ({low} in every direction)" if low == high else f" ({low} to {high} by direction)"
    return f", RQD {'at most ' if bound else ''}{from_jv:.0f}{along}"


def censored_traces_note(set_id: int, row: dict) -> str | None:
    """A sentence when set ``set_id``'s joint traces run out of sight (to the face's edge or a
    hole): when every one does, their mean length with censoring cannot be estimated, and
    what was seen is a lower bound (the ``persistence`` column's "or more"); when no more
    than :data:`FEW_WHOLE_TRACES` are seen end to end, the mean rests on those, and the
    sentence gives its standard error. None otherwise.

    Examples
    --------
    >>> row = {"joint_traces": 8, "joint_trace_mean_m": float("nan"), "joint_trace_median_m": 1.327,
    ...        "persistence": "low or more"}
    >>> censored_traces_note(0, row)
    "All 8 of set 0's joint traces run out of sight (to the face's edge or a hole), so their mean length is not measured: the 1.33 m median seen is a lower bound, and its persistence is low or more."
    >>> censored_traces_note(5, {**row, "joint_traces": 1, "joint_trace_median_m": 5.77})
    "Set 5's one joint trace runs out of sight (to the face's edge or a hole), so its length is not measured: the 5.77 m length seen is a lower bound, and its persistence is low or more."
    >>> censored_traces_note(0, {"joint_traces": 12, "joint_traces_censored": 10, "joint_trace_mean_m": 26.38,
    ...                          "joint_trace_std_error_m": 18.66, "persistence": "very high"})
    "10 of set 0's 12 joint traces run out of sight: their mean length, 26.4 m (standard error 18.7 m), rests on the 2 seen end to end, so its persistence, very high, is a rough guide."
    >>> censored_traces_note(0, {"joint_traces": 8, "joint_traces_censored": 2, "joint_trace_mean_m": 2.0}) is None
    True
    """
    traces = int(float(row.get("joint_traces") or 0))
    if not traces or TRACE_BEYOND_EXPOSURE in str(row.get("flags", "")).split(";"):
        return None
    mean = float(row.get("joint_trace_mean_m", np.nan))
    if np.isfinite(mean):
        hidden = int(float(row.get("joint_traces_censored") or 0))
        whole = traces - hidden
        if not hidden or whole > FEW_WHOLE_TRACES:
            return None
        seen = "one" if whole == 1 else str(whole)
        return (
            f"{hidden} of set {set_id}'s {traces} joint traces run out of sight: their mean length, {mean:.1f} m "
            f"(standard error {float(row['joint_trace_std_error_m']):.1f} m), rests on the {seen} seen end to end, "
            f"so its persistence, {row['persistence']}, is a rough guide."
        )
    every = f"All {traces} of set {set_id}'s joint traces run" if traces > 1 else f"Set {set_id}'s one joint trace runs"
    seen, whose = ("median seen", "their mean length") if traces > 1 else ("length seen", "its length")
    return (
        f"{every} out of sight (to the face's edge or a hole), so {whose} is not measured: the "
        f"{float(row['joint_trace_median_m']):.2f} m {seen} is a lower bound, and its persistence is {row['persistence']}."
    )


def trace_cell(row: dict, digits: int = 1) -> str | None:
    """The tables' trace cell for a set whose mean is longer than the exposure spans
    (:data:`~geostructure.rockmass.setflags.TRACE_BEYOND_EXPOSURE`): "> span"; None for any other set (its
    figure is shown as it is).

    Examples
    --------
    >>> trace_cell({"flags": "trace_longer_than_exposure", "exposure_span_m": 21.69}), trace_cell({"flags": ""})
    ('> 21.7', None)
    """
    if TRACE_BEYOND_EXPOSURE not in str(row.get("flags", "")).split(";"):
        return None
    return f"> {float(row['exposure_span_m']):.{digits}f}"


def trace_beyond_exposure_note(set_id: int, row: dict) -> str | None:
    """A sentence when set ``set_id``'s mean trace length, as the censored traces give it,
    is longer than any line across the exposed face (:data:`~geostructure.rockmass.setflags.TRACE_BEYOND_EXPOSURE`
    in its row's ``flags``): no face this size measures it, so it is given as a bound, the
    exposure's span, and its persistence class "or more". None otherwise.

    Examples
    --------
    >>> row = {"flags": "trace_longer_than_exposure", "joint_trace_estimate_m": 106.3, "exposure_span_m": 12.9,
    ...        "persistence": "high or more"}
    >>> trace_beyond_exposure_note(1, row)
    "Set 1's joint traces, most of them running out of sight, give a mean length of 106.3 m, longer than any line across the exposed face (12.9 m): no face this size measures it, so the mean is given as longer than 12.9 m, and its persistence as high or more."
    """
    if TRACE_BEYOND_EXPOSURE not in str(row.get("flags", "")).split(";"):
        return None
    span = float(row["exposure_span_m"])
    return (
        f"Set {set_id}'s joint traces, most of them running out of sight, give a mean length of "
        f"{float(row['joint_trace_estimate_m']):.1f} m, longer than any line across the exposed face "
        f"({span:.1f} m): no face this size measures it, so the mean is given as longer than {span:.1f} m, "
        f"and its persistence as {row['persistence']}."
    )


def note_vegetation(vegetation, rock: RockMass, source) -> None:
    """A note (:class:`~.errors.GeoStructureNote`) of the points the input classifies as
    vegetation that the sets' face left out as clutter (:func:`~geostructure.rockmass.face.face_parts`: none when
    the cloud has no other face to tell them from)."""
    if vegetation is None or not np.any(vegetation):
        return
    if rock.point_part is None:  # next to no face but the vegetation: it was measured as one
        warnings.warn(
            f"{source}: nearly every point is classified as vegetation (LAS classes 3 to 5); with no rock face "
            f"to tell them from, they are measured as the face.",
            GeoStructureNote,
            stacklevel=2,
        )
        return
    n = int(np.count_nonzero(np.asarray(vegetation) & (rock.point_part == CLUTTER)))
    if n:
        warnings.warn(
            f"{source}: {n:,} point{'s' if n != 1 else ''} classified as vegetation (LAS classes 3 to 5) "
            f"{'are' if n != 1 else 'is'} taken for clutter, not rock face: in regions.laz as face_part 2, out of "
            f"the exposure, the scanlines and the slope.",
            GeoStructureNote,
            stacklevel=2,
        )


def note_voxel_planes(detector: str | None, source) -> None:
    """A note (:class:`~.errors.GeoStructureNote`) when the sets are found among planes of
    the voxel detector (``--detector voxel``, and the stream engine's): on rough rock it
    finds joint faces only a few voxels across and larger, so the sets' spacing and
    intensities count the larger joints alone. On the 40 x 16 m synthetic face of 3 m joints
    it found 253 planes where the facet detector finds 1,871, and the sets' spacing read 2.0
    to 2.7 times the facets' (docs/rockmass.md, "Facets: the default detector")."""
    if detector is None or detector_spec(detector).finds_small_joints:
        return
    warnings.warn(
        f"{source}: its planes come from the voxel detector (--detector voxel, or the stream engine), which "
        f"finds only the larger joint faces of rough rock: the sets' spacing, P10 and P32 count those alone and "
        f"read long. For a rock face, measure in memory with the default facet detector.",
        GeoStructureNote,
        stacklevel=2,
    )


def bent_face(bend: float, sections: int = 1) -> str | None:
    """The sentence for a face that turns by :data:`~geostructure.rockmass.exposure.BENT_FACE` degrees or more
    along its strike (:func:`~geostructure.rockmass.exposure.face_bend`; ``face_bend_deg`` in ``run.json``); None
    for one that does not. Its scanlines, exposure and P21 lie on one mean face, which stands
    for none of its parts: two 12 x 6 m faces dipping 75 degrees and turned 90 degrees from
    each other make a mean face dipping 8.

    Examples
    --------
    >>> bent_face(39.2)[:70]
    'The face turns by 39 degrees along its strike (a corner, a curve or a '
    >>> bent_face(6.0) is None
    True
    >>> bent_face(39.2, sections=2)[:100]
    "The face turns by 39 degrees along its strike, so the sets' scanlines, traces and exposure were meas"
    """
    if not bend >= BENT_FACE:
        return None
    if sections > 1:
        return (
            f"The face turns by {bend:.0f} degrees along its strike, so the sets' scanlines, traces and exposure were "
            f"measured in {sections} sections, each on its own mean face, and pooled per set."
        )
    return (
        f"The face turns by {bend:.0f} degrees along its strike (a corner, a curve or a bay): the sets' scanlines "
        f"and exposure lie on one mean face, which stands for none of its parts, so their spacing, traces and "
        f"intensities are approximate. For those, measure each face on its own (a cloud cropped to it)."
    )


def bent_slope(slope: dict) -> str | None:
    """The sentence for a slope fitted to a face that turns (``kinematics.json``'s ``slope``);
    None for a slope given, or fitted to a face that does not turn.

    Examples
    --------
    >>> bent_slope({"dip": 8.1, "dip_direction": 218.0, "source": "fitted", "face_bend_deg": 76.4})[:60]
    'The slope fitted, 8/218, is the mean plane of a face that tu'
    >>> bent_slope({"dip": 75.0, "dip_direction": 180.0, "source": "given"}) is None
    True
    """
    bend = slope.get("face_bend_deg", 0.0)
    if slope.get("source") != "fitted" or not bend >= BENT_FACE or slope.get("sections", 1) > 1:
        return None
    return (
        f"The slope fitted, {slope['dip']:.0f}/{slope['dip_direction']:03.0f}, is the mean plane of a face that turns "
        f"by {bend:.0f} degrees along its strike (a corner, a curve or a bay): no part of the face has it, and the "
        f"tests against it mean little. Give the slope of the part to test with --slope DIP/DIPDIR, or measure each face "
        f"on its own (a cloud cropped to it)."
    )


def note_tilt_unread(facets: int, source, along: int = 0) -> None:
    """A note that the tilt correlated errors give every plane was not read: ``facets`` (in
    joints of three or more, of sets across the face) are fewer than
    :data:`~geostructure.detect.uncertainty.MIN_TILT_FACETS`; ``along``, those of sets along the face, which
    are not read for it. Nothing when both are 0 (it was read, or there was nothing)."""
    own = (
        "each plane's uncertainty is its own fit's alone, a lower bound where the cloud's errors are correlated (SfM)."
    )
    if not facets and along:
        message = (f"{source}: the tilt that correlated errors give every plane was not read: the only joints of three "
                   f"or more facets ({along} facets) lie in sets along the face, which follow the face's shape, not "
                   f"the cloud's errors; {own}")  # fmt: skip
    elif facets:
        why = f" ({along} more in sets along the face, which follow its shape, not the cloud's errors)" if along else ""
        message = (f"{source}: only {facets} facets lie in joints of three or more across the face{why}, and "
                   f"{MIN_TILT_FACETS} are needed to read the tilt that correlated errors give every plane: {own}")  # fmt: skip
    else:
        return
    warnings.warn(message, GeoStructureNote, stacklevel=2)


def sectioned_slope(summary: dict) -> str | None:
    """The sentence for a face tested in sections (``kinematics.json`` with ``sections``):
    which slopes, and that each plane was tested against its own section's; None otherwise.

    Examples
    --------
    >>> sectioned_slope({"slope": {"face_bend_deg": 76.4, "sections": 2}, "sections": [
    ...     {"slope": {"dip": 74.6, "dip_direction": 180.2}, "planes": 410},
    ...     {"slope": {"dip": 75.3, "dip_direction": 268.9}, "planes": 388}]})
    'The face turns by 76 degrees along its strike, so it was tested in 2 sections from left to right as one faces it: 75/180 (410 planes) and 75/269 (388 planes), each plane against the slope of the section it lies in.'
    """
    sections = summary.get("sections") or []
    if len(sections) < 2:
        return None
    parts = [f"{s['slope']['dip']:.0f}/{s['slope']['dip_direction']:03.0f} ({s['planes']:,} planes)" for s in sections]
    return (
        f"The face turns by {summary['slope']['face_bend_deg']:.0f} degrees along its strike, so it was tested in "
        f"{len(sections)} sections from left to right as one faces it: {', '.join(parts[:-1])} and {parts[-1]}, "
        f"each plane against the slope of the section it lies in."
    )


def gentle_slope(summary: dict) -> str | None:
    """The sentence for a fitted slope no steeper than the friction angle (in every section
    of a face that turns): no plane or wedge can slide out of it, nor a column topple
    flexurally (direct toppling needs no sliding, and is still tested), and the slope fitted
    is most likely a terrain's or a floor's, not the face to test. None for a slope given,
    or a steeper one.

    Examples
    --------
    >>> gentle_slope({"slope": {"dip": 3.4, "dip_direction": 145.2, "source": "fitted"}, "friction_deg": 30.0})[:74]
    'The slope fitted, 3/145, dips no steeper than the friction angle (30°), so'
    >>> gentle_slope({"slope": {"dip": 75.0, "dip_direction": 180.0, "source": "fitted"}, "friction_deg": 30.0}) is None
    True
    """
    slope = summary["slope"]
    steepest = max([slope["dip"]] + [part["slope"]["dip"] for part in summary.get("sections") or []])
    if slope.get("source") != "fitted" or steepest > summary["friction_deg"]:
        return None
    return (
        f"The slope fitted, {slope['dip']:.0f}/{slope['dip_direction']:03.0f}, dips no steeper than the friction angle "
        f"({summary['friction_deg']:g}°), so no plane or wedge can slide out of it, nor a column topple flexurally. If "
        f"the cloud's mean surface is not the slope to test (a terrain, a quarry floor, a bench), give that slope with "
        f"--slope DIP/DIPDIR."
    )


def note_of(sentence: str | None, source) -> None:
    """A sentence of this module as a note (:class:`~.errors.GeoStructureNote`) naming
    ``source``; nothing for None."""
    if sentence:
        warnings.warn(f"{source}: {sentence[0].lower()}{sentence[1:]}", GeoStructureNote, stacklevel=3)


def warn_of(sentence: str | None, source) -> None:
    """A sentence of this module (:func:`bent_face`, :func:`bent_slope`) as a warning naming
    ``source``; nothing for None."""
    if sentence:
        warnings.warn(f"{source}: {sentence[0].lower()}{sentence[1:]}", GeoStructureWarning, stacklevel=3)


def note_bent_face(bend: float, source, sections: int = 1) -> None:
    """:func:`bent_face`'s sentence naming ``source``: a warning for a face measured as one,
    a note for one measured in sections."""
    (note_of if sections > 1 else warn_of)(bent_face(bend, sections), source)
