"""pbr_xval.status.RunStatus: one enum for run outcomes that still reads and writes as text."""

from __future__ import annotations

import json
from pathlib import Path

from pbr_xval.engine import Trajectory
from pbr_xval.status import RunStatus


def test_str_enum_compares_and_serialises_as_text() -> None:
    assert RunStatus.OK == "ok" and RunStatus("failed") is RunStatus.FAILED
    assert f"{RunStatus.NOT_APPLICABLE}" == "not_applicable"
    assert json.dumps({"s": RunStatus.TIMEOUT}) == '{"s": "timeout"}'


def test_trajectory_status_round_trip(tmp_path: Path) -> None:
    traj = Trajectory.failed("housner", "blow-up during settling")
    assert traj.status is RunStatus.FAILED and not traj.ok
    back = Trajectory.load_parquet(traj.save_parquet(tmp_path / "t.parquet"))
    assert back.status is RunStatus.FAILED and back.message == "blow-up during settling"
