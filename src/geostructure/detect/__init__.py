"""From a cloud to planes: the outlier filter, voxel and facet detectors, region growing, the plane table.

Its public names (each with a numpydoc docstring whose examples run as doctests) are
loaded on first use.
"""

from geostructure.core.lazy import lazy_names

#: Public name -> the module of this package that defines it.
_PUBLIC = {
    "measure": "pipeline",
    "Measurement": "pipeline",
    "choose_params": "auto",
    "detect_facets": "facets",
}

__all__, __getattr__, __dir__ = lazy_names(__name__, _PUBLIC)
