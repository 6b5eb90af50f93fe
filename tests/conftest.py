"""Shared pytest configuration.

Every test runs by default, in CI too. Two markers:

* ``slow`` — a label for tests that take more than ~10 s; they still run. Deselect them for a
  quick local loop with ``pytest -m "not slow"``.
* ``optional_study`` — an optional long study that guards no claim made in the README or the
  docs; it runs only with ``PBR_XVAL_SLOW=1`` (docs/ci_regression.md lists them).
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

SCANS = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "scans"


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    if os.environ.get("PBR_XVAL_SLOW") == "1" or "optional_study" in (config.getoption("-m") or ""):
        return
    skip = pytest.mark.skip(reason="optional long study (guards no claim): set PBR_XVAL_SLOW=1 to run")
    for item in items:
        if "optional_study" in item.keywords:
            item.add_marker(skip)


@pytest.fixture(autouse=True)
def _close_figures():
    """Close every matplotlib figure a test leaves open (studies return figures to their callers)."""
    yield
    import sys

    if "matplotlib.pyplot" in sys.modules:
        sys.modules["matplotlib.pyplot"].close("all")
