"""What can slide or topple out of the slope: the kinematic tests, wedges, the slope, the summary.

Its public names (each with a numpydoc docstring whose examples run as doctests) are
loaded on first use.
"""

from geostructure.core.lazy import lazy_names

#: Public name -> the module of this package that defines it.
_PUBLIC = {
    "Slope": "modes",
    "fit_slope": "slope",
    "fit_face": "slope",
    "kinematics_of": "summary",
}

__all__, __getattr__, __dir__ = lazy_names(__name__, _PUBLIC)
