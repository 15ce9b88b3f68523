"""A package's public names imported on first use (PEP 562): ``import geostructure.detect``
loads nothing until a name is asked for, so the command starts fast and an interrupt while
it starts is answered cleanly."""

from __future__ import annotations

import importlib


def lazy_names(package: str, public: dict[str, str]):
    """``__all__``, ``__getattr__`` and ``__dir__`` for a package whose public names (name
    -> module, relative to the package) are loaded on first use.

    Examples
    --------
    >>> all_, getattr_, dir_ = lazy_names("geostructure.core", {"Frame": "orientation"})
    >>> all_, getattr_("Frame").__name__, dir_()
    (['Frame'], 'Frame', ['Frame'])
    """

    def __getattr__(name: str):
        if name in public:
            return getattr(importlib.import_module(f"{package}.{public[name]}"), name)
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    def __dir__() -> list[str]:
        return sorted(public)

    return sorted(public), __getattr__, __dir__
