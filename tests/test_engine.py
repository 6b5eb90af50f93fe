"""Engine registry, settings resolution and the Trajectory container."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from pbr_xval.conformance import housner_scenario
from pbr_xval.engine import (
    EngineNotAvailable,
    EngineSettingsError,
    Trajectory,
    get_engine,
    registered_names,
)
from pbr_xval.runner import run_scenario

ENGINE_MODULES = ("pybullet", "mujoco", "dartpy", "coacd")


def test_import_pbr_xval_loads_no_engine() -> None:
    code = (
        "import sys, pbr_xval, pbr_xval.scene, pbr_xval.cli, pbr_xval.engine;"
        "pbr_xval.engine.registered_names();"
        f"bad=[m for m in sys.modules if m.split('.')[0] in {ENGINE_MODULES!r}];"
        "print(bad); sys.exit(1 if bad else 0)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    assert out.returncode == 0, out.stdout + out.stderr


def test_registry_names_and_unknown_engine() -> None:
    names = registered_names()
    for n in ("housner", "curved_base", "reference", "pybullet", "mujoco", "dart"):
        assert n in names
    with pytest.raises(EngineNotAvailable, match="registered engines"):
        get_engine("bullet3000")


def test_install_hint_for_missing_engine_package(monkeypatch: pytest.MonkeyPatch) -> None:
    import importlib

    import pbr_xval.engine as eng

    real = importlib.import_module

    def fake(name: str, *a, **k):
        if name == "pbr_xval.engines.mujoco_":
            raise ModuleNotFoundError("No module named 'mujoco'", name="mujoco")
        return real(name, *a, **k)

    monkeypatch.setattr(eng.importlib, "import_module", fake)
    with pytest.raises(EngineNotAvailable, match="pip install mujoco-core"):
        get_engine("mujoco")


def test_settings_unknown_key_and_profile() -> None:
    eng = get_engine("housner")
    with pytest.raises(EngineSettingsError, match="unknown setting 'rtoll'"):
        eng.resolve_settings({"rtoll": 1e-3})
    with pytest.raises(EngineSettingsError, match="unknown profile"):
        eng.resolve_settings({"profile": "fast"})
    s = eng.resolve_settings({"rtol": 1e-8})
    assert s["rtol"] == 1e-8 and s["profile"] == "faithful" and s["variant"] == "exact"


def test_trajectory_parquet_round_trip(tmp_path) -> None:
    traj = run_scenario(housner_scenario(duration=2.0), "housner")
    path = traj.save_parquet(tmp_path / "sub" / "t.parquet")
    back = Trajectory.load_parquet(path)
    assert back.fingerprint() == traj.fingerprint()
    assert back.settings == traj.settings
    assert back.scenario_hash == traj.scenario_hash and len(back.scenario_hash) == 64
    assert back.versions["scipy"]
    df = traj.to_dataframe()
    assert list(df.columns)[:4] == ["t", "com_x", "com_y", "com_z"]
    assert np.allclose(df["theta"], traj.rocking_angle())
    assert not list(tmp_path.glob("sub/*.tmp"))


def test_failed_trajectory_carries_reason() -> None:
    t = Trajectory.failed("x", "NaN at t = 1 s")
    assert not t.ok and t.events[0].kind == "failed" and "NaN" in t.message


def test_rocking_angle_sign_convention() -> None:
    # a positive pulse along +x tips the block toward -x first: theta < 0
    traj = run_scenario(housner_scenario(duration=1.0), "housner")
    theta = traj.rocking_angle()
    first_impact = traj.impacts()[0].t
    before = theta[traj.t < first_impact]
    assert before.min() < -0.05 and before.max() <= 1e-12
    # the COM moves toward -x with it
    assert traj.com[np.argmin(theta), 0] < 0
    # azimuth 90 degrees: the same motion along y
    scn = housner_scenario(
        duration=1.0,
        excitation={"type": "half_sine", "amplitude": 5.0, "phase": "housner_uplift", "azimuth_deg": 90.0},
    )
    t90 = run_scenario(scn, "housner")
    assert np.allclose(t90.rocking_angle(), theta, atol=1e-12)
    assert np.allclose(t90.com[:, 1], traj.com[:, 0], atol=1e-12)


def test_missing_third_party_package_is_reported_by_get_engine(monkeypatch: pytest.MonkeyPatch) -> None:
    import importlib.util

    import pbr_xval.engine as eng

    real = importlib.util.find_spec
    monkeypatch.setattr(eng.importlib.util, "find_spec", lambda n, *a: None if n == "dartpy" else real(n, *a))
    with pytest.raises(EngineNotAvailable, match="pip install dartpy"):
        get_engine("dart")
    info = eng.list_engines()["dart"]
    assert not info["available"] and "pip install dartpy" in info["error"]
