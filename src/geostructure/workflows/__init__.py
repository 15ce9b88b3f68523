"""What a command does, as functions: measure an outcrop, save a run, add sets.

Its public names (each with a numpydoc docstring whose examples run as doctests) are
loaded on first use.
"""

from geostructure.core.lazy import lazy_names

#: Public name -> the module of this package that defines it.
_PUBLIC = {
    "measure_outcrop": "outcrop",
    "OutcropRun": "outcrop",
    "measure_survey": "survey",
    "save_measurement": "saving",
    "add_sets": "saving",
    "add_report": "saving",
    "add_kinematics": "kinematics",
    "reconstruct_and_measure": "video",
}

__all__, __getattr__, __dir__ = lazy_names(__name__, _PUBLIC)
