"""The central settings table: complete for every built-in engine, and it refuses what it should."""

from __future__ import annotations

import math

import pytest

from pbr_xval.engine import EngineNotAvailable, EngineSettingsError, get_engine, registered_names
from pbr_xval.settings_spec import (
    MAX_SAMPLES,
    MAX_STEPS,
    SPECS,
    check_sample_count,
    check_settings,
    check_step_count,
)


def _engine(name: str):
    try:
        return get_engine(name)
    except EngineNotAvailable as exc:  # a missing optional engine package only
        pytest.skip(str(exc))


@pytest.mark.parametrize("name", sorted(SPECS))
def test_every_profile_key_has_a_spec_and_passes(name: str) -> None:
    eng = _engine(name)
    for profile, settings in eng.profiles().items():
        assert set(settings) == set(SPECS[name]), (profile, set(settings) ^ set(SPECS[name]))
        assert check_settings(name, settings) == [], profile


def test_every_registered_engine_has_a_table() -> None:
    assert set(registered_names()) <= set(SPECS)


@pytest.mark.parametrize(
    ("engine", "key", "value"),
    [
        ("reference", "timestep", 0),
        ("reference", "timestep", -1e-3),
        ("reference", "timestep", math.nan),
        ("reference", "timestep", math.inf),
        ("reference", "timestep", 2.0),  # > 1 s
        ("reference", "timestep", "1e-3"),  # a string, not a number
        ("reference", "timestep", True),  # a bool is not a number
        ("reference", "iterations", 0),
        ("reference", "iterations", 2.5),
        ("reference", "iteration_tol", 0.0),
        ("reference", "max_stepbacks", -1),
        ("reference", "lcp_method", "pgs"),
        ("mujoco", "condim", 2),
        ("mujoco", "condim", 3.0),  # a float is not the choice 3
        ("mujoco", "solimp", [0.9, 0.95]),
        ("mujoco", "friction", [-1.0, 0.0, 0.0]),
        ("mujoco", "settle", "yes"),
        ("pybullet", "friction", "auto"),
        ("pybullet", "restitution", 1.5),
        ("pybullet", "num_solver_iterations", 0),
        ("dart", "plane_half_extents", [50.0, 50.0, 0.0]),
        ("housner", "rtol", 0.0),
        ("housner", "rtol", 1e-20),  # below float64 round-off: would never converge
        ("housner", "impact_ratio", 1.2),
        ("curved_base", "clamp", -1.0),
    ],
)
def test_bad_values_are_refused_by_resolve_settings(engine: str, key: str, value: object) -> None:
    eng = _engine(engine)
    with pytest.raises(EngineSettingsError, match=f"setting '{key}'") as info:
        eng.resolve_settings({key: value})
    assert "expected" in str(info.value) and len(str(info.value).splitlines()) == 1


@pytest.mark.parametrize(
    ("engine", "key", "value"),
    [
        ("pybullet", "friction", "scene"),
        ("pybullet", "friction", 0.7),
        ("pybullet", "contact_stiffness", None),
        ("mujoco", "solref", [-1000.0, -10.0]),  # MuJoCo's direct stiffness/damping form
        ("mujoco", "tolerance", 0.0),  # disables early termination: legal
        ("reference", "iterations", 30.0),  # an integral float from TOML
        ("housner", "max_step", None),
    ],
)
def test_good_values_pass(engine: str, key: str, value: object) -> None:
    eng = _engine(engine)
    assert eng.resolve_settings({key: value})[key] == value


def test_cross_key_min_timestep() -> None:
    eng = _engine("reference")
    with pytest.raises(EngineSettingsError, match="min_timestep"):
        eng.resolve_settings({"timestep": 1e-4, "min_timestep": 1e-3})


def test_partial_tables_report_unknown_keys() -> None:
    problems = check_settings("mujoco", {"timestepp": 1e-3}, complete=False, where="s.toml: engines.mujoco")
    assert len(problems) == 1 and "unknown setting 'timestepp'" in problems[0] and "timestep" in problems[0]
    assert check_settings("some_plugin", {"anything": 1, "timestep": 1e-3}, complete=False) == []
    assert check_settings("some_plugin", {"timestep": 0.0}, complete=False) != []  # generic meaning


def test_run_size_bounds() -> None:
    assert check_sample_count(5.0, 1e-3) is None
    msg = check_sample_count(1e9, 1e-3)
    assert msg is not None and "1e+12 samples" in msg and f"{MAX_SAMPLES:.0e}" in msg
    assert check_step_count("mujoco", {"timestep": 1e-3}, 5.0, 0.5) is None
    msg = check_step_count("mujoco", {"timestep": 1e-9}, 5.0, 0.5)
    assert msg is not None and "5.5e+09 steps" in msg and f"{MAX_STEPS:.0e}" in msg
    assert check_step_count("housner", {"rtol": 1e-10}, 1e6) is None  # no time step: not a stepper
