"""Shared pytest configuration: slow studies run only with PBR_XVAL_SLOW=1 (or -m slow)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

SCANS = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "scans"


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    if os.environ.get("PBR_XVAL_SLOW") == "1" or "slow" in (config.getoption("-m") or ""):
        return
    skip = pytest.mark.skip(reason="slow study: set PBR_XVAL_SLOW=1 to run")
    for item in items:
        if "slow" in item.keywords:
            item.add_marker(skip)
