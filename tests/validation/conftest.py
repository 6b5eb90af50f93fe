"""Small synthetic campaigns written by the tests (the real data is never copied into the project)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
#: ../shared/data beside the checkout, or PBR_XVAL_SHARED_DATA (tests/conftest.py: with CI=true a
#: test skipped for want of it fails)
SHARED_DATA = Path(os.environ.get("PBR_XVAL_SHARED_DATA") or REPO.parent / "shared" / "data")
SHAKE_TABLE = SHARED_DATA / "shake_table"
SCANS = SHARED_DATA / "scans"
SP1_SCENARIO = REPO / "examples" / "validation" / "sp1.toml"

DT = 0.005  # s


def _write_table(path: Path, acc: np.ndarray) -> None:
    path.write_text("\n".join(f"{x:.6e}" for x in acc) + "\n")


def box_campaign(folder: Path) -> tuple[Path, list[int]]:
    """Six one-column records (m/s², dt 5 ms) and a campaign CSV for a 0.2 × 0.2 × 0.8 m block.

    The block's uplift acceleration is g·b/h = 9.81 × 0.1/0.4 = 2.4525 m/s². Observed outcomes
    follow from statics and the block's rigid-body kinematics, not from pbr-xval:
    * below the uplift acceleration the block never leaves its base (no rocking at all);
    * a constant 6 or 8 m/s² (2.4–3.3× uplift) held for 1.5 s drives θ past α = atan(1/4) within
      0.5 s (θ̈ ≥ p²(a/g·cos α − sin α)… grows like cosh p t, p = 4.2 rad/s) and the block lies
      down before the pulse ends.
    """
    folder.mkdir(parents=True, exist_ok=True)
    t = np.arange(0.0, 3.0, DT)
    motions = {
        "sine_low": 1.0 * np.sin(2 * np.pi * 1.0 * t),  # 0.41 × uplift
        "sine_mid": 2.0 * np.sin(2 * np.pi * 2.0 * t),  # 0.82 × uplift
        "step_6": np.where(t < 1.5, 6.0, 0.0),
        "step_8": np.where(t < 1.5, 8.0, 0.0),
        "sine_tiny": 0.5 * np.sin(2 * np.pi * 3.0 * t),
        "step_low": np.where(t < 1.5, 1.2, 0.0),  # 0.49 × uplift, long
    }
    observed = {"sine_low": 0, "sine_mid": 0, "step_6": 1, "step_8": 1, "sine_tiny": 0, "step_low": 0}
    rows = ["test,motion_file,units,dt,toppled,motion"]
    for i, (name, acc) in enumerate(motions.items(), 1):
        _write_table(folder / f"{name}.txt", acc)
        rows.append(f"{i},{name}.txt,m/s2,{DT},{observed[name]},{name}")
    csv = folder / "campaign.csv"
    csv.write_text("\n".join(rows) + "\n")
    return csv, list(observed.values())


BOX_SCENARIO = """
name = "box_validation"
duration = 3.0
settle_time = 0.0
output_dt = 0.01

[rock]
shape = "box"
half_extents = [0.1, 0.1, 0.4]
density = 2500.0

[contact]
friction_static = 1.0

[excitation]
type = "none"
"""


@pytest.fixture
def box_campaign_files(tmp_path: Path) -> tuple[Path, Path, list[int]]:
    csv, observed = box_campaign(tmp_path / "campaign")
    scn = tmp_path / "box.toml"
    scn.write_text(BOX_SCENARIO)
    return csv, scn, observed


def box_validate_args(csv: Path, scn: Path, out: Path) -> list[str]:
    """``pbr-xval validate`` on the box campaign with the housner engine, the records used raw (no
    baseline correction), 3 folds, one worker: the arguments the option tests extend."""
    raw = ["--highpass", "0", "--lowpass", "0", "--detrend", "none", "--resample", "0"]
    return ["validate", str(csv), "--specimen", "1", "--scenario", str(scn), "--engine", "housner",
            "--out", str(out), "--folds", "3", "--tail", "2", "--workers", "1", "--chunk-size", "3", *raw]  # fmt: skip
