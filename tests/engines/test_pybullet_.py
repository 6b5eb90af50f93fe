"""What is specific to the PyBullet adapter: lazy import, profiles, failure capture, the CoACD cache.

The analytical cases (Housner threshold, rebound, mesh box, notched block and its rebound — a
declared strict xfail —, ground-motion modes, determinism) are the conformance suite's
(``tests/conformance``), run for every engine.
"""

from __future__ import annotations

import math
import subprocess
import sys
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("pybullet")

from pbr_xval.conformance import notched_reference
from pbr_xval.engine import get_engine
from pbr_xval.runner import run_scene
from pbr_xval.scenario import scenario_from_dict
from pbr_xval.scene import compile_scene

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "housner_halfsine.toml"
B, H = 0.2, 0.6
ALPHA = math.atan2(B, H)


def housner_dict(**changes: Any) -> dict[str, Any]:
    data = tomllib.loads(EXAMPLE.read_text())
    for key, value in changes.items():
        node = data
        parts = key.split(".")
        for part in parts[:-1]:
            node = node.setdefault(part, {})
        node[parts[-1]] = value
    return data


def scene_at(amplitude: float, source: Path | None = None, **changes: Any):
    data = housner_dict(**{"excitation.amplitude": amplitude, **changes})
    return compile_scene(scenario_from_dict(data, source=source))


def peak_ratio(traj) -> float:
    return float(np.max(np.abs(traj.rocking_angle()))) / ALPHA


# ------------------------------------------------------------------ plumbing
def test_import_does_not_import_pybullet():
    code = "import sys, pbr_xval.engines.pybullet_ as m; m.PyBulletEngine().profiles(); print('pybullet' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip().splitlines()[-1] == "False"


def test_profiles_are_complete_and_explicit():
    eng = get_engine("pybullet")
    prof = eng.profiles()
    assert set(prof) == {"faithful", "engine-default"}
    assert set(prof["faithful"]) == set(prof["engine-default"])
    assert prof["faithful"]["timestep"] == 1e-3
    assert prof["engine-default"]["timestep"] == pytest.approx(1 / 240)
    assert prof["faithful"]["friction"] == "scene" and prof["engine-default"]["friction"] == 0.5
    assert prof["engine-default"]["linear_damping"] == 0.04
    assert {"pybullet", "numpy"} <= set(eng.versions())


# ------------------------------------------------------------------ profiles
@pytest.mark.parametrize("amplitude", [4.0, 10.0])
def test_engine_default_profile_slides_instead_of_rocking(amplitude):
    # default lateralFriction 0.5 per body -> 0.25 combined < tan α = 1/3: the block slides and
    # never rocks (measured: peak |θ|/α < 1e-3 at a = 4 and 10, the COM slides by > 1 cm)
    traj = run_scene(scene_at(amplitude), "pybullet", {"profile": "engine-default"})
    assert traj.ok, traj.message
    assert not traj.toppled
    assert peak_ratio(traj) < 0.01
    assert np.max(np.abs(traj.com[:, 0] - traj.com[0, 0])) > 0.01


# ------------------------------------------------------------------ failures
def test_nan_state_is_reported_as_failed(monkeypatch):
    import pybullet

    real = pybullet.getBaseVelocity
    calls = {"n": 0}

    def poisoned(*args, **kw):
        calls["n"] += 1
        lin, ang = real(*args, **kw)
        return (lin, (math.nan, 0.0, 0.0)) if calls["n"] > 50 else (lin, ang)

    monkeypatch.setattr(pybullet, "getBaseVelocity", poisoned)
    traj = run_scene(scene_at(5.0, duration=0.5, settle_time=0.0), "pybullet", {"timestep": 2e-3})
    assert traj.status == "failed" and "NaN" in traj.message


def test_engine_exception_is_reported_as_failed(monkeypatch):
    import pybullet

    real = pybullet.stepSimulation
    calls = {"n": 0}

    def broken(*args, **kw):
        calls["n"] += 1
        if calls["n"] > 10:
            raise pybullet.error("simulated engine failure")
        return real(*args, **kw)

    monkeypatch.setattr(pybullet, "stepSimulation", broken)
    traj = run_scene(scene_at(5.0, duration=0.5, settle_time=0.0), "pybullet", {"timestep": 2e-3})
    assert traj.status == "failed" and "simulated engine failure" in traj.message


def test_notched_block_coacd_parts_are_cached(tmp_path, monkeypatch):
    monkeypatch.setenv("PBR_XVAL_CACHE", str(tmp_path))
    rock = {
        "shape": "notched_block",
        "half_extents": [0.2, 0.2, 0.6],
        "notch_width": 0.2,
        "notch_height": 0.3,
        "density": 2400.0,
    }
    # CoACD (threshold 0.05) cuts the notched block into 3 exact convex parts (notes §4); the
    # compound's threshold is within 2 % of the exact two-pivot ODE's 5.1241 (notes: 5.0997, −0.48 %,
    # at dt 1e-3; the margin is the notes' own spread 0.9 % between part sets and dt, doubled)
    ref = notched_reference()["threshold"]
    lo = run_scene(scene_at(ref * 0.98, rock=rock), "pybullet", {"collision": "coacd"})
    assert lo.ok and not lo.toppled
    assert lo.diagnostics["collision"] == "coacd" and lo.diagnostics["n_parts"] == 3
    parts = sorted(tmp_path.glob("obj/pybullet_coacd_*.obj")) + sorted(tmp_path.rglob("coacd_*.npz"))
    assert len(parts) == 4  # 3 part OBJ files and the cached decomposition
    mtimes = [f.stat().st_mtime_ns for f in parts]
    hi = run_scene(scene_at(ref * 1.02, rock=rock), "pybullet", {"collision": "coacd"})
    assert hi.ok and hi.toppled
    assert [f.stat().st_mtime_ns for f in parts] == mtimes  # reused, not rewritten
    assert not list(Path(ROOT).rglob("pybullet_coacd_*.obj"))  # nothing written into the repo


def test_cli_says_engine_default_never_rocks():
    from typer.testing import CliRunner

    from pbr_xval.cli import app

    res = CliRunner().invoke(
        app,
        [
            "threshold",
            str(Path(ROOT) / "examples" / "housner_halfsine.toml"),
            "--engine",
            "pybullet",
            "--profile",
            "engine-default",
            "--n-grid",
            "3",
        ],
    )
    from pbr_xval.cli.simulate import EXIT_NEVER_TOPPLED

    assert res.exit_code == EXIT_NEVER_TOPPLED, res.output
    assert "never toppled" in res.output and "never rocked" in res.output
