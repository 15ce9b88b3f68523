"""Files only: point clouds read (PLY, LAS/LAZ, E57, text; tiles of one survey), the plane
table and the point files written and read back, ground truths and field maps, the output
folder's all-or-nothing set. Nothing here measures.

Its public names (each with a numpydoc docstring whose examples run as doctests) are
loaded on first use.
"""

from geostructure.core.lazy import lazy_names

#: Public name -> the module of this package that defines it.
_PUBLIC = {
    "read_cloud": "readers",
    "read_tiles": "survey_files",
    "read_planes_csv": "planetable",
    "write_planes_csv": "planetable",
    "read_truth": "truth",
    "read_field_map": "fieldmap",
}

__all__, __getattr__, __dir__ = lazy_names(__name__, _PUBLIC)
