"""Plain JSON values from results (a foundation module: imports nothing from the package).

One conversion, one policy for every JSON the package writes (trajectory metadata, catalog
chunks, study provenance, report tables):

* numpy scalars become Python numbers, numpy arrays (and anything with ``tolist``) lists;
* mappings become dicts with ``str`` keys, tuples and lists become lists (recursively);
* paths become strings; a pandas DataFrame becomes a ``"<table n×m>"`` placeholder (a table is
  written as its own file, not inlined);
* **non-finite floats become strings** ``"nan"``, ``"inf"``, ``"-inf"`` (``repr``): strict
  JSON has no NaN, and a reader must not mistake a missing figure for a number;
* anything else is returned unchanged, or passed through ``default`` when one is given
  (e.g. ``default=str``).
"""

from __future__ import annotations

import json
import math
import os
import sys
from collections.abc import Callable, Mapping
from typing import Any

__all__ = ["dumps", "jsonable"]


def jsonable(v: Any, *, default: Callable[[Any], Any] | None = None) -> Any:
    """``v`` as plain JSON values (see the module docstring for the rules).

    Parameters
    ----------
    v : any
        A value, possibly nested (dicts, lists, tuples, numpy arrays and scalars).
    default : callable, optional
        Applied to values no rule converts (otherwise they are returned unchanged).
    """
    if isinstance(v, bool | int | str) or v is None:
        return v
    if isinstance(v, float):  # numpy's float64 is a float subclass: convert it to a plain float
        x = float(v)
        return x if math.isfinite(x) else repr(x)
    np = sys.modules.get("numpy")
    if np is not None and isinstance(v, np.generic):
        return jsonable(v.item(), default=default)
    if isinstance(v, Mapping):
        return {str(k): jsonable(x, default=default) for k, x in v.items()}
    if isinstance(v, list | tuple):
        return [jsonable(x, default=default) for x in v]
    if isinstance(v, os.PathLike):
        return os.fspath(v)
    pd = sys.modules.get("pandas")
    if pd is not None and isinstance(v, pd.DataFrame):
        return f"<table {v.shape[0]}×{v.shape[1]}>"
    if hasattr(v, "tolist"):  # numpy arrays
        return jsonable(v.tolist(), default=default)
    return default(v) if default is not None else v


def dumps(v: Any, **kwargs: Any) -> str:
    """``json.dumps(jsonable(v, default=str), **kwargs)``: always valid, strict JSON."""
    return json.dumps(jsonable(v, default=str), allow_nan=False, **kwargs)
