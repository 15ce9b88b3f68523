"""From planes to the rock mass: joint sets, joints, spacing, persistence, intensity, RQD, the notes.

Its public names (each with a numpydoc docstring whose examples run as doctests) are
loaded on first use.
"""

from geostructure.core.lazy import lazy_names

#: Public name -> the module of this package that defines it.
_PUBLIC = {
    "find_sets": "sets",
    "JointSets": "sets",
    "rock_mass": "mass",
    "RockMass": "mass",
}

__all__, __getattr__, __dir__ = lazy_names(__name__, _PUBLIC)
