"""The installed version of pbr-xval (a foundation module: imports nothing from the package).

Provenance everywhere (trajectory metadata, stores, reports) reads ``__version__`` from here,
not from the package ``__init__``, which sits at the top of the import graph.
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

__all__ = ["__version__"]

try:
    __version__ = version("pbr-xval")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.0.0+unknown"
