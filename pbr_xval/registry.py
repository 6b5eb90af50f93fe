"""Names of the registered engines, read from the ``pbr_xval.engines`` entry-point group.

A foundation module (imports nothing from the package): the scenario checks ``[engines.<name>]``
tables against :func:`registered_names` without importing the engine layer.
:func:`pbr_xval.engine.get_engine` loads an engine from :func:`entry_points`.
"""

from __future__ import annotations

import functools
import importlib.metadata

__all__ = ["ENTRY_POINT_GROUP", "entry_points", "refresh_engines", "registered_names"]

ENTRY_POINT_GROUP = "pbr_xval.engines"


@functools.lru_cache(maxsize=1)
def entry_points() -> dict[str, str]:
    """Registered engine name -> ``"module:Class"`` target (cached; nothing is imported)."""
    eps = importlib.metadata.entry_points(group=ENTRY_POINT_GROUP)
    return {ep.name: ep.value for ep in eps}


def refresh_engines() -> None:
    """Forget the cached entry points (after installing a plugin at run time)."""
    entry_points.cache_clear()


def registered_names() -> list[str]:
    """Names of the registered engines, sorted (nothing is imported)."""
    return sorted(entry_points())
