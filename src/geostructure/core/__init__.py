"""Values and numeric kernels: clouds, planes, parameters, orientations, grids. No files.

Its public names (each with a numpydoc docstring whose examples run as doctests) are
loaded on first use.
"""

from geostructure.core.lazy import lazy_names

#: Public name -> the module of this package that defines it.
_PUBLIC = {
    "Cloud": "cloud",
    "Params": "params",
    "Frame": "orientation",
    "Planes": "planes",
    "orientation_from_normals": "orientation",
}

__all__, __getattr__, __dir__ = lazy_names(__name__, _PUBLIC)
