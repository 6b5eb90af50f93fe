"""The excitation evaluated inside kernel.step_block (issue 23, fourth pass): the same loads
as the engine's Python load table, bit for bit, and runs with step-backs inside the
compiled blocks identical to the runs whose step-backs leave them."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from pbr_xval import conformance as conf
from pbr_xval.motion.base import Excitation3D, ScaledMotion
from pbr_xval.motion.pulses import HalfSine, OneSine
from pbr_xval.motion.records import Record
from pbr_xval.reference import adapter, dynamics, kernel
from pbr_xval.runner import run_scene
from pbr_xval.scene import compile_scene

from .conftest import assert_same_run


def _record(seed: int, n: int = 400, dt: float = 0.01, t0: float = 0.0, amp: float = 4.0) -> Record:
    """A decaying 1 Hz sine with noise, m/s² (a synthetic record: n samples at dt s)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * dt
    acc = amp * np.sin(2 * np.pi * 1.0 * t) * np.exp(-0.3 * t) + 0.8 * rng.standard_normal(n)
    return Record(acc, dt, t0)


_EXCITATIONS = [
    Excitation3D(_record(1), azimuth=0.3),
    Excitation3D(ScaledMotion(_record(2, t0=0.25), 0.7), azimuth=2.0, vertical=_record(3, n=50, dt=0.02)),
    Excitation3D(HalfSine(5.0, 1.0, 0.4), azimuth=0.0),
    Excitation3D(OneSine(1.3, 1.0), azimuth=np.pi / 4, vertical=ScaledMotion(OneSine(2.0, 3.0), -0.5)),
]


@pytest.mark.parametrize("exc", _EXCITATIONS)
def test_excitation_load_equals_python(exc: Excitation3D) -> None:
    """kernel.excitation_load gives the engine's g − a(t) bit for bit: at the step ends of
    halved steps (t0 + 1e-9 Δt, t1 − 1e-9 Δt), on samples, around the ends and outside."""
    g = 9.81
    spec = adapter.compiled_excitation(exc, g)
    assert spec is not None
    rng = np.random.default_rng(7)
    dur = exc.duration
    t0 = np.concatenate([rng.uniform(-0.1, dur + 0.5, 3000), np.arange(0.0, dur + 0.05, 0.01)])
    dts = 1e-3 / 2.0 ** rng.integers(0, 13, t0.size)
    ts = np.concatenate([t0 + 1e-9 * dts, (t0 + dts) - 1e-9 * dts, t0, [0.0, dur, 0.25]])
    want = np.array([0.0, 0.0, -g]) - np.asarray(exc.acceleration(ts)).reshape(-1, 3)
    got = np.empty_like(want)
    for k, t in enumerate(ts):
        kernel.excitation_load(spec[0], spec[1], float(t), got[k])
    np.testing.assert_array_equal(got, want)
    assert np.abs(want[:, :2]).max() > 0.1  # the excitation is not trivially zero


def test_unsupported_excitation_keeps_the_table() -> None:
    """A component that is neither a record nor a sine pulse: no compiled excitation."""
    from pbr_xval.motion.pulses import Rectangular

    assert adapter.compiled_excitation(Excitation3D(Rectangular(1.0, 0.5)), 9.81) is None


def _scene_with(exc: Excitation3D, duration: float):
    base = compile_scene(
        conf.housner_scenario(
            duration=duration,
            excitation={"type": "half_sine", "amplitude": 5.0, "frequency": 1.0, "phase": "housner_uplift"},
        )
    )
    return dataclasses.replace(base, excitation=exc)


@pytest.mark.parametrize(
    ("exc", "duration", "settings"),
    [
        # a record, the block rocking on a corner (measured: 190 step-backs, 1 impact)
        (Excitation3D(_record(11, n=300, amp=5.5), azimuth=np.pi / 4), 4.0, {"epsilon": 1e-7}),
        # a pulse, corner rocking with impacts resolved in the blocks (327 step-backs, 8 impacts)
        (Excitation3D(HalfSine(5.6, 1.0, 0.36), azimuth=np.pi / 4), 3.0, {"epsilon": 1e-7}),
    ],
)
def test_step_backs_in_blocks_equal_python_path(monkeypatch, exc, duration, settings) -> None:
    """Runs whose step-backs are made inside kernel.step_block (the excitation compiled)
    equal, bit for bit, the runs whose step-backs leave the blocks (the Python load table):
    samples, events and every diagnostic but the timings; and step-backs do happen inside
    the blocks (counted), also after an impact resolved there, and impacts are resolved after
    a block's first step."""
    scene = _scene_with(exc, duration)
    rejected, later_impacts = [], []
    own = dynamics.RigidBodySolver.step_block_own

    def counting(self, *a, **k):
        out = own(self, *a, **k)
        rejected.append(int((~out[6]).sum()))
        later_impacts.append(int((out[7][1:, kernel.J_FLAG] != 0).sum()))
        return out

    monkeypatch.setattr(dynamics.RigidBodySolver, "step_block_own", counting)
    compiled = run_scene(scene, "reference", settings)
    monkeypatch.setattr(adapter, "COMPILED_EXCITATION", False)
    table = run_scene(scene, "reference", settings)
    assert compiled.diagnostics["stepbacks"] > 0
    assert sum(rejected) > 0.5 * compiled.diagnostics["stepbacks"]
    if compiled.diagnostics["impacts"] > 1:
        assert sum(later_impacts) > 0  # impacts resolved after a block's first step
    assert_same_run(compiled, table)
