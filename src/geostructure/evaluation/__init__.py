"""Against the truth: ground-truth surfaces, field maps, frame fits, the paper's sweeps.

Its public names (each with a numpydoc docstring whose examples run as doctests) are
loaded on first use.
"""

from geostructure.core.lazy import lazy_names

#: Public name -> the module of this package that defines it.
_PUBLIC = {
    "evaluate": "groundtruth",
    "validate": "mapcheck",
    "add_evaluation": "scoring",
    "add_validation": "scoring",
}

__all__, __getattr__, __dir__ = lazy_names(__name__, _PUBLIC)
