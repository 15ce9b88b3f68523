"""The rock mass's tables as the files hold them: ``sets.csv``, ``spacing.csv`` and
``joints.csv`` as rows and columns (the writers in :mod:`geostructure.io` write any table),
and what ``run.json`` says of the sets."""

from __future__ import annotations

from geostructure.rockmass.jointtable import JOINT_COLUMNS, joint_rows
from geostructure.rockmass.mass import ROCK_SET_COLUMNS
from geostructure.rockmass.tracemaps import TRACE_COLUMNS, VERTEX_COLUMNS, trace_rows, vertex_columns

#: The columns of ``sets.csv``.
SET_COLUMNS = (
    "set",
    "n_planes",
    "area_m2",
    "dip",
    "dip_direction",
    "strike",
    "fisher_k",
    "alpha95_deg",
    "spherical_variance",
    "normal_x",
    "normal_y",
    "normal_z",
)


def sets_table(sets, rock=None) -> tuple[list[dict], tuple]:
    """``sets.csv``'s rows and columns: one row per joint set
    (:class:`~geostructure.rockmass.sets.JointSets`), with its spacing, persistence and
    intensity when ``rock`` (:class:`~geostructure.rockmass.mass.RockMass`) is given."""
    if rock is None:
        return sets.rows(), SET_COLUMNS
    return [{**a, **b} for a, b in zip(sets.rows(), rock.set_rows())], SET_COLUMNS + ROCK_SET_COLUMNS


def spacing_table(rock) -> tuple[list[dict], tuple]:
    """``spacing.csv``'s rows and columns: every spacing measured, one row each: set, method (``scanline``, along
    the virtual scanlines, or ``nearest``, to the nearest overlapping plane of the set), metres.
    The scanlines' gaps are those the set's spacing is read from (``spacing_basis``)."""
    lines = rock.lines
    rows = [
        {"set": s, "method": method, "spacing_m": float(v)}
        for s in range(len(lines))
        for method, values in (("scanline", lines[s].gaps), ("nearest", rock.nearest_gaps[s]))
        for v in values
    ]
    return rows, ("set", "method", "spacing_m")


def sets_record(sets, rock=None) -> dict:
    """What ``run.json`` says of the sets: how many, how they were chosen, the BIC per number,
    and the rock mass's totals (Jv, block volume) when measured."""
    record = {"n_sets": len(sets), "criterion": sets.criterion, "bic": {str(k): v for k, v in sets.bic.items()}}
    if rock is not None:
        record["rock_mass"] = rock.summary(sets.mean_normal)
    return record


def rock_mass_tables(planes, sets, rock, frame, metres_per_unit: float = 1.0) -> list[tuple]:
    """(kind, file name, rows, columns) of each table a run with sets writes: ``sets.csv``
    and, with the rock mass, ``spacing.csv`` and ``joints.csv`` (every discontinuity once,
    a row per joint of the sets' facets, from the plane table ``planes`` in the cloud's unit),
    ``traces.csv`` and ``trace_vertices.csv`` (the face's fracture traces, :mod:`.tracemaps`)
    and ``traces.dxf`` (their polylines and sets, which :func:`~geostructure.io.atomic.write_table`
    draws)."""
    tables: list[tuple] = [("sets", "sets.csv", *sets_table(sets, rock))]
    if rock is not None:
        tables.append(("spacing", "spacing.csv", *spacing_table(rock)))
        rows = joint_rows(planes, rock.joints, frame, metres_per_unit)
        tables.append(("joints", "joints.csv", rows, JOINT_COLUMNS))
        if rock.traces is not None:
            traces = rock.traces
            tables.append(("traces", "traces.csv", trace_rows(traces, frame, planes.offset, metres_per_unit),
                           TRACE_COLUMNS))  # fmt: skip
            tables.append(("trace_vertices", "trace_vertices.csv", vertex_columns(traces, planes.offset),
                           VERTEX_COLUMNS))  # fmt: skip
            lines = [line + planes.offset for line in traces.polylines()]
            tables.append(("traces_dxf", "traces.dxf", (lines, traces.set.tolist()), None))
    return tables
