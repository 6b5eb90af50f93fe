"""Run one scenario on one engine: settings resolution, timing, and failure capture."""

from __future__ import annotations

import time
from collections.abc import Mapping
from typing import Any

from pbr_xval.diagnostics import ensure_standard_diagnostics
from pbr_xval.engine import Engine, Trajectory, get_engine
from pbr_xval.scenario import Scenario
from pbr_xval.scene import Scene, compile_scene

__all__ = ["effective_settings", "run_resolved", "run_scenario", "run_scene"]


def effective_settings(engine: Engine, scene: Scene, overrides: Mapping[str, Any] | None) -> dict[str, Any]:
    """Profile defaults ← scenario ``[engines.<name>]`` ← explicit ``overrides``."""
    merged = dict(scene.engine_settings.get(engine.name, {}))
    merged.update(overrides or {})
    resolve = getattr(engine, "resolve_settings", None)
    full = resolve(merged) if resolve is not None else {**engine.default_settings(), **merged}
    from pbr_xval.engine import EngineSettingsError
    from pbr_xval.settings_spec import check_step_count

    too_long = check_step_count(engine.name, full, scene.duration, scene.settle_time)
    if too_long:
        raise EngineSettingsError(too_long)
    return full


def run_scene(scene: Scene, engine: str | Engine, settings: Mapping[str, Any] | None = None) -> Trajectory:
    """Simulate a compiled scene; ``wall_time`` and provenance are filled in.

    ``settings`` are overrides; they are resolved here, once (:func:`effective_settings`).
    """
    eng = get_engine(engine)
    return run_resolved(scene, eng, effective_settings(eng, scene, settings))


def run_resolved(scene: Scene, eng: Engine, full: dict[str, Any]) -> Trajectory:
    """Simulate a compiled scene with settings already resolved by :func:`effective_settings`.

    For a caller that resolves the settings first (to report a bad setting before the run, as
    ``pbr-xval run`` does) so that they are not resolved a second time.
    """
    t0 = time.perf_counter()
    traj = eng.simulate(scene, full)
    traj.wall_time = time.perf_counter() - t0
    ensure_standard_diagnostics(traj, scene)  # one meaning per diagnostic, for every engine
    traj.scenario_hash = scene.scenario_hash
    traj.settings = full
    if not traj.versions:
        traj.versions = eng.versions()
    return traj


def run_scenario(
    scn: Scenario, engine: str | Engine, settings: Mapping[str, Any] | None = None
) -> Trajectory:
    """Compile and simulate."""
    return run_scene(compile_scene(scn), engine, settings)
