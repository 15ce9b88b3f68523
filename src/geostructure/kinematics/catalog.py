"""The failure modes, in one table: what each is called in ``kinematics.json`` and in the
tables (the terminal's and the report's), whether it is a row of the summary tables, and the
columns of ``kinematics.csv`` that hold each plane's result for it. The tests themselves are
:mod:`geostructure.kinematics.modes`' functions, run by :func:`~geostructure.kinematics.summary.kinematics_of`.

Examples
--------
>>> [mode.words for mode in SUMMARY_MODES]
['planar sliding', 'wedge sliding', 'flexural toppling']
>>> PLANE_TEST_COLUMNS
('planar_sliding', 'planar_fs', 'flexural_toppling', 'toppling_base', 'oblique_toppling_base')
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class FailureMode:
    """One failure mode.

    Parameters
    ----------
    key : str
        Its key in ``kinematics.json``'s summary (a plane's flag in ``kinematics.csv`` has
        the same name).
    words : str
        How the tables word it.
    summary_row : bool
        Whether the summary tables give it a row (planes critical, by count, area, joints).
    plane_columns : tuple of str
        Its columns of ``kinematics.csv``: the plane's flag first, then its figures.
    """

    key: str
    words: str
    summary_row: bool
    plane_columns: tuple[str, ...] = ()

    @property
    def flags_planes(self) -> bool:
        """Whether ``kinematics.csv`` flags each plane critical or not for it."""
        return bool(self.plane_columns) and self.plane_columns[0] == self.key


FAILURE_MODES: tuple[FailureMode, ...] = (
    FailureMode("planar_sliding", "planar sliding", True, ("planar_sliding", "planar_fs")),
    FailureMode("wedge_sliding", "wedge sliding", True),  # pairs of planes: wedges.csv
    FailureMode("flexural_toppling", "flexural toppling", True, ("flexural_toppling",)),
    FailureMode("toppling_base", "toppling base", False, ("toppling_base",)),
    FailureMode("oblique_toppling_base", "oblique toppling base", False, ("oblique_toppling_base",)),
)
#: The modes the summary tables give a row, in order.
SUMMARY_MODES = tuple(mode for mode in FAILURE_MODES if mode.summary_row)
#: The modes ``kinematics.csv`` flags each plane for.
PLANE_MODES = tuple(mode for mode in FAILURE_MODES if mode.flags_planes)
#: ``kinematics.csv``'s columns of the tests, in order.
PLANE_TEST_COLUMNS = tuple(column for mode in FAILURE_MODES for column in mode.plane_columns)
