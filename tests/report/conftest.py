"""The quick demo report, built once per test session and shared by test_demo and test_browser."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest


@pytest.fixture(scope="session")
def quick_demo(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Any]:
    """``pbr-xval demo --quick`` into a temporary folder: (report folder, CliRunner result)."""
    from typer.testing import CliRunner

    from pbr_xval.cli import app

    out = tmp_path_factory.mktemp("demo_reports")
    res = CliRunner().invoke(app, ["demo", "--quick", "--out", str(out)])
    return out / "demo", res
