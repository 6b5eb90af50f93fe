"""What is specific to the DART adapter (``engines/dart_.py``): lazy import, profiles, the hull
cache, failure capture and LCP failure counting.

The analytical cases (Housner threshold, rebound, mesh box, notched block, ground-motion modes,
determinism) are the conformance suite's (``tests/conformance``), run for every engine.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("dartpy")

from pbr_xval.engine import EngineSettingsError, get_engine
from pbr_xval.runner import run_scene
from pbr_xval.scenario import load_scenario, scenario_from_dict
from pbr_xval.scene import compile_scene

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "housner_halfsine.toml"


@pytest.fixture(autouse=True)
def _private_cache(tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch) -> None:
    """Generated OBJ/CoACD files go to a temporary cache, not ~/.cache."""
    monkeypatch.setenv("PBR_XVAL_CACHE", str(tmp_path_factory.getbasetemp() / "pbr_xval_cache"))


@pytest.fixture(scope="module")
def base() -> dict[str, Any]:
    return load_scenario(EXAMPLE).model_dump()


def _scenario(base: dict[str, Any], *, amplitude: float | None = None, **changes: Any) -> Any:
    d = dict(base, **changes)
    if amplitude is not None:
        d["excitation"] = dict(base["excitation"], amplitude=amplitude)
    return scenario_from_dict(d)


def test_engine_default_never_rocks(base: dict[str, Any]) -> None:
    # DART defaults: sleeping on, ground driven by an ACCELERATION-actuated joint. The rock falls
    # asleep while settling and the moving pedestal never wakes it: measured peak |θ| 1.6e-8 rad at
    # a = 5.6 (faithful: 0.2675 rad), and no rocking at 4 or 10 m/s² either. (With
    # ground_motion = "inertial" the gravity change wakes it and the threshold is 5.6385.)
    for a in (4.0, 10.0):
        tr = run_scene(
            compile_scene(_scenario(base, amplitude=a, duration=2.0)), "dart", {"profile": "engine-default"}
        )
        assert tr.ok, tr.message
        assert not tr.toppled
        assert np.max(np.abs(tr.rocking_angle())) < 1e-4


def test_mesh_rock_is_a_cached_hull(base: dict[str, Any], tmp_path: Path) -> None:
    import trimesh

    path = tmp_path / "box.obj"
    trimesh.creation.box(extents=(0.4, 0.4, 1.2)).export(path)
    rock = {"shape": "mesh", "path": str(path), "density": 2400.0}
    tr = run_scene(compile_scene(_scenario(base, amplitude=5.0, duration=0.2, rock=rock)), "dart")
    assert tr.ok, tr.message
    assert tr.diagnostics["rock_model"] == "convex hull mesh"
    cache = Path(os.environ["PBR_XVAL_CACHE"]) / "obj"
    assert list(cache.glob("dart_hull_*.obj"))  # generated files go to the cache, not the repo


def test_blow_up_is_reported_not_raised(base: dict[str, Any]) -> None:
    # 1e5 m/s² from the first step, at the coarsest step the settings allow (0.1 s): the rock is
    # flung away (measured: the COM moves 309 m in the first step)
    exc = {"type": "half_sine", "amplitude": 1e5, "frequency": 1.0, "phase": 0.0}
    sc = compile_scene(_scenario(base, excitation=exc))
    tr = run_scene(sc, "dart", {"timestep": 0.1})
    assert tr.status == "failed"
    assert "explosion" in tr.message or "NaN" in tr.message
    assert any(e.kind == "failed" for e in tr.events)


def test_lcp_failures_are_counted(base: dict[str, Any]) -> None:
    # PGS as the primary solver with 1 iteration fails on stderr and zeroes the impulses (notes §7.3)
    sc = compile_scene(_scenario(base, amplitude=5.6, duration=0.3, settle_time=0.05))
    tr = run_scene(sc, "dart", {"lcp_solver": "pgs", "pgs_iterations": 1})
    assert tr.diagnostics["dart_lcp_failure_lines"] > 0


def test_profiles_complete_and_settings_checked() -> None:
    eng = get_engine("dart")
    prof = eng.profiles()
    assert set(prof) == {"faithful", "engine-default"}
    assert set(prof["faithful"]) == set(prof["engine-default"])
    assert prof["faithful"]["timestep"] == 1e-3 and prof["faithful"]["sleep"] is False
    assert prof["engine-default"]["sleep"] is True
    assert "dartpy" in eng.versions() and "numpy" in eng.versions()
    with pytest.raises(EngineSettingsError):
        eng.resolve_settings({"no_such_key": 1})


def test_import_does_not_import_dartpy() -> None:
    code = "import sys, pbr_xval.engines.dart_; assert 'dartpy' not in sys.modules, 'dartpy imported'"
    subprocess.run([sys.executable, "-c", code], check=True)
