"""What is specific to the MuJoCo adapter: lazy import, profiles, the model it builds, failure capture.

The analytical cases (Housner threshold, rebound, mesh box, notched block, ground-motion modes,
determinism) are the conformance suite's (``tests/conformance``), run for every engine.
Values marked "measured" are from this adapter with MuJoCo 4.0.1.
"""

from __future__ import annotations

import math
import subprocess
import sys
import tomllib
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("mujoco")

from pbr_xval.engine import get_engine
from pbr_xval.runner import run_scene
from pbr_xval.scenario import scenario_from_dict
from pbr_xval.scene import compile_scene

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "housner_halfsine.toml"


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


def toppled(
    amplitude: float, settings: dict[str, Any] | None = None, source: Path | None = None, **changes: Any
) -> bool:
    traj = run_scene(scene_at(amplitude, source=source, **changes), "mujoco", settings)
    assert traj.ok, traj.message
    return traj.toppled


# ------------------------------------------------------------------ plumbing
def test_import_does_not_import_mujoco():
    code = "import sys, pbr_xval.engines.mujoco_ as m; m.MuJoCoEngine().profiles(); print('mujoco' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip().splitlines()[-1] == "False"


def test_profiles_are_complete_and_explicit():
    eng = get_engine("mujoco")
    prof = eng.profiles()
    assert set(prof) == {"faithful", "engine-default"}
    assert set(prof["faithful"]) == set(prof["engine-default"])
    f, d = prof["faithful"], prof["engine-default"]
    assert f["timestep"] == 1e-3 and d["timestep"] == 0.002
    assert f["cone"] == "elliptic" and d["cone"] == "pyramidal"
    assert d["solref"] == [0.02, 1.0] and d["solimp"] == [0.9, 0.95, 0.001, 0.5, 2.0]
    assert d["friction"] == [1.0, 0.005, 0.0001] and f["friction"][0] is None
    assert f["ground_motion"] == d["ground_motion"] == "inertial"
    assert {"mujoco", "numpy"} <= set(eng.versions())
    assert eng.expected_failures == {}


def test_model_mass_properties_and_contact_are_from_the_scene():
    import mujoco

    eng = get_engine("mujoco")
    scene = scene_at(5.0)
    m, info = eng._build(mujoco, scene, eng.resolve_settings({}))
    rock = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "rock")
    assert m.body_mass[rock] == pytest.approx(460.8)
    assert sorted(m.body_inertia[rock]) == pytest.approx([12.288, 61.44, 61.44])
    assert m.geom_friction[:, 0] == pytest.approx([2.0, 2.0])  # max rule: pair μ = scene μ
    assert m.geom_solref[:, 0] == pytest.approx([2e-3, 2e-3])  # 2·dt
    assert info["collision"] == "box primitive"


# ------------------------------------------------------------------ profiles
def test_engine_default_profile_gives_its_own_answer():
    # MuJoCo defaults (solref 0.02, default solimp, pyramidal cone, μ = 1, Euler, dt 2e-3):
    # measured threshold 5.6014 (−0.65 %) with peak |θ|/α = 0.728 at a = 5.5 (faithful: 0.83),
    # and a 2.7 mm settled penetration (faithful: < 0.35 mm)
    assert not toppled(5.58, {"profile": "engine-default"})
    assert toppled(5.62, {"profile": "engine-default"})
    assert not toppled(5.62)  # the faithful profile (5.6387) does not topple there


# ------------------------------------------------------------------ failures
def test_blow_up_is_reported_as_failed():
    # direct (negative) solref is not protected by refsafe; an absurd stiffness at a coarse
    # step launches the block (notes §5, MuJoCo pitfall 4)
    traj = run_scene(scene_at(5.0, duration=0.5), "mujoco", {"timestep": 1e-2, "solref": [-1e12, -1.0]})
    assert traj.status == "failed"
    assert "settling" in traj.message  # measured: launched during settling, COM moved ~1e4 m
    assert any(e.kind == "failed" for e in traj.events)


def test_nan_state_is_reported_as_failed(monkeypatch):
    import mujoco

    real = mujoco.mj_step
    calls = {"n": 0}

    def poisoned(m, d, *args):
        real(m, d, *args)
        calls["n"] += 1
        if calls["n"] > 50:
            d.qvel[3] = math.nan

    monkeypatch.setattr(mujoco, "mj_step", poisoned)
    traj = run_scene(scene_at(5.0, duration=0.5, settle_time=0.0), "mujoco", {"timestep": 2e-3})
    assert traj.status == "failed" and "NaN" in traj.message


def test_engine_exception_is_reported_as_failed(monkeypatch):
    import mujoco

    real = mujoco.mj_step
    calls = {"n": 0}

    def broken(m, d, *args):
        calls["n"] += 1
        if calls["n"] > 10:
            raise mujoco.FatalError("simulated engine failure")
        real(m, d, *args)

    monkeypatch.setattr(mujoco, "mj_step", broken)
    traj = run_scene(scene_at(5.0, duration=0.5, settle_time=0.0), "mujoco", {"timestep": 2e-3})
    assert traj.status == "failed" and "simulated engine failure" in traj.message


def test_unsupported_pedestal_is_not_applicable(tmp_path):
    from pbr_xval.engine import NotApplicable

    scene = scene_at(5.0)
    scene.pedestal = {"kind": "mesh", "mesh": None}
    with pytest.raises(NotApplicable):
        get_engine("mujoco").simulate(scene, {})
