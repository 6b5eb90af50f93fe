"""pbr_xval.jsonio: one conversion to JSON values, one policy for non-finite numbers."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pbr_xval.jsonio import dumps, jsonable


@pytest.mark.parametrize(
    ("value", "expected"),
    [
        (math.nan, "nan"),
        (math.inf, "inf"),
        (-math.inf, "-inf"),
        (np.float64("nan"), "nan"),  # numpy scalars follow the same policy as Python floats
        (np.array([1.0, np.nan, np.inf]), [1.0, "nan", "inf"]),
        (np.int64(3), 3),
        (1.5, 1.5),
        (True, True),
        (None, None),
    ],
)
def test_numbers(value: object, expected: object) -> None:
    out = jsonable(value)
    assert out == expected and type(out) is type(expected)


def test_nested_and_special_types() -> None:
    df = pd.DataFrame({"a": [1, 2, 3]})
    out = jsonable({1: (np.arange(2), Path("/a/b")), "t": df, "d": {"x": np.float32(0.5)}})
    assert out == {"1": [[0, 1], "/a/b"], "t": "<table 3×1>", "d": {"x": 0.5}}


def test_default_for_unknown_objects() -> None:
    class Thing:
        def __str__(self) -> str:
            return "thing"

    t = Thing()
    assert jsonable([t]) == [t]
    assert jsonable([t], default=str) == ["thing"]


def test_dumps_is_strict_json() -> None:
    text = dumps({"x": math.nan, "y": [np.inf], "z": object()})
    data = json.loads(text)  # strict JSON: no NaN literals
    assert data["x"] == "nan" and data["y"] == ["inf"] and data["z"].startswith("<object")
    assert "NaN" not in text
