"""DART adapter (``engines/dart_.py``) against independent references.

References: the exact Housner toppling amplitude of the seed's half-sine case (5.638 m/s², the
nonlinear rocking ODE, notes/engines_dart.md), Housner's restitution r = 1 − 1.5 sin²α = 0.850,
and the analytical two-pivot threshold of the notched block (5.1241 m/s², the ``housner`` engine).
Runtimes below are from a loaded 2-core VM.
"""

from __future__ import annotations

import itertools
import math
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
from pbr_xval.study.threshold import find_threshold

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "housner_halfsine.toml"
A_HOUSNER = 5.638  # m/s², exact nonlinear Housner threshold of the example (5.63805)
A_NOTCHED = 5.1241  # m/s², two-pivot ODE threshold of the notched block (housner engine; notes)


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


def _threshold(scn: Any, lo: float, hi: float, n_grid: int, rel_tol: float, **settings: Any) -> float:
    r = find_threshold(scn, "dart", lo=lo, hi=hi, n_grid=n_grid, rel_tol=rel_tol, settings=settings)
    assert r.minimum is not None, f"dart never toppled in [{lo}, {hi}]"
    return float(r.minimum)


@pytest.fixture(scope="module")
def faithful_threshold(base: dict[str, Any]) -> float:
    # measured 5.63789 (10 runs, ~20 s loaded)
    return _threshold(_scenario(base), 5.55, 5.75, 3, 2e-4)


def test_faithful_housner_threshold(faithful_threshold: float) -> None:
    assert abs(faithful_threshold / A_HOUSNER - 1) < 2e-3


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


def test_ground_motion_modes_agree(base: dict[str, Any]) -> None:
    sc = compile_scene(_scenario(base, amplitude=5.6, duration=2.5))
    peaks = []
    for mode in ("inertial", "moving_pedestal"):
        tr = run_scene(sc, "dart", {"ground_motion": mode})
        assert tr.ok and not tr.toppled
        peaks.append(float(np.max(np.abs(tr.rocking_angle()))))
    # measured 0.267532 rad in both modes (identical to ~1e-14)
    assert abs(peaks[1] / peaks[0] - 1) < 0.01
    assert abs(peaks[0] - 0.2675) < 0.003


def _half_cycle_omega0(tr: Any, sc: Any) -> np.ndarray:
    """Energy-equivalent ω0 per half-cycle (median over the middle half of each)."""
    th = tr.rocking_angle()
    thd = tr.omega @ sc.rocking_axis
    b, h = 0.2, 0.6
    m, g = sc.rock.mass, sc.gravity
    R = math.hypot(b, h)
    alpha = math.atan2(b, h)
    i_o = sc.rock.inertia[1, 1] + m * R * R
    p2 = m * g * R / i_o
    w0 = np.sqrt(thd**2 + 2 * p2 * (np.cos(alpha - np.abs(th)) - math.cos(alpha)))
    s = np.sign(th)
    cuts = [0, *(np.flatnonzero(s[1:] != s[:-1]) + 1).tolist()]  # complete half-cycles only
    vals = []
    for i0, i1 in itertools.pairwise(cuts):
        n = i1 - i0
        if n >= 20:
            vals.append(float(np.median(w0[i0 + n // 4 : i1 - n // 4])))
    return np.asarray(vals)


def test_free_rocking_rebound(base: dict[str, Any]) -> None:
    sc = compile_scene(
        _scenario(base, duration=1.8, initial={"theta_over_alpha": 0.5}, excitation={"type": "none"})
    )
    tr = run_scene(sc, "dart", {"timestep": 1e-4})
    assert tr.ok, tr.message
    assert tr.diagnostics["settled"] is False and "settle_skipped" in tr.diagnostics
    w0 = _half_cycle_omega0(tr, sc)
    ratios = w0[1:] / w0[:-1]
    # measured ω0 0.94522, 0.80289, 0.68258, 0.58031 → ratios 0.8494, 0.8502, 0.8502
    assert len(ratios) >= 2
    assert np.all(np.abs(ratios[:3] - 0.850) < 0.005), ratios


def test_mesh_box_matches_primitive(base: dict[str, Any], faithful_threshold: float, tmp_path: Path) -> None:
    import trimesh

    path = tmp_path / "box.obj"
    trimesh.creation.box(extents=(0.4, 0.4, 1.2)).export(path)
    scn = _scenario(base, rock={"shape": "mesh", "path": str(path), "density": 2400.0})
    a = _threshold(scn, 5.62, 5.66, 2, 1e-3)  # measured 5.6375 (primitive 5.6379)
    assert abs(a / faithful_threshold - 1) < 3e-3
    tr = run_scene(
        compile_scene(_scenario(base, amplitude=5.0, duration=0.2, rock=scn.rock.model_dump())), "dart"
    )
    assert tr.diagnostics["rock_model"] == "convex hull mesh"
    cache = Path(os.environ["PBR_XVAL_CACHE"]) / "obj"
    assert list(cache.glob("dart_hull_*.obj"))  # generated files go to the cache, not the repo


def test_notched_block_threshold(base: dict[str, Any]) -> None:
    rock = {
        "shape": "notched_block",
        "half_extents": [0.2, 0.2, 0.6],
        "notch_width": 0.2,
        "notch_height": 0.3,
        "density": 2400.0,
    }
    scn = _scenario(base, rock=rock)
    a = _threshold(scn, 5.07, 5.18, 2, 2e-3)  # measured 5.1216 (−0.05 %)
    assert abs(a / A_NOTCHED - 1) < 1e-2


def test_deterministic(base: dict[str, Any]) -> None:
    sc = compile_scene(_scenario(base, amplitude=5.6, duration=1.5))
    a, b = run_scene(sc, "dart"), run_scene(sc, "dart")
    assert a.ok and a.t.size > 100
    assert a.fingerprint() == b.fingerprint()


def test_blow_up_is_reported_not_raised(base: dict[str, Any]) -> None:
    sc = compile_scene(_scenario(base, amplitude=5.6))
    tr = run_scene(sc, "dart", {"timestep": 1.0})  # 1 s steps: the rock is flung away
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
