"""The reference solver's quasi-static hold (``static_hold``, issue 23): a rigid rock at rest on
a contact polygon that holds the coming loads in static equilibrium stays at rest, so its state
is held instead of stepped. The test of equilibrium is Housner's static uplift test (and the
friction cone) — checked here against the closed form — and a run with holds equals the stepped
run to round-off, in every path of the time loop."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from pbr_xval import conformance as conf
from pbr_xval.motion.base import Excitation3D
from pbr_xval.motion.records import Record
from pbr_xval.reference import adapter
from pbr_xval.reference.dynamics import Body, Pedestal, State
from pbr_xval.runner import run_scene
from pbr_xval.scene import compile_scene

G = 9.81
B, H = 0.2, 0.6  # the Housner block's half width and half height, m
TAN_ALPHA = B / H


def _block_support(
    tilt: float = 0.0, mu: float = 2.0, com_shift: float = 0.0
) -> adapter._StaticSupport | None:
    """The support of the Housner block resting on its base (tilted about the y axis by ``tilt``
    rad about its +x edge; its COM moved along x by ``com_shift`` m)."""
    nodes = np.array([[sx * B, sy * B, -H] for sx in (-1, 1) for sy in (-1, 1)]) - [com_shift, 0.0, 0.0]
    c, s = math.cos(tilt), math.sin(tilt)
    rot = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])  # lifts the −x edge for tilt > 0
    pivot = np.array([B - com_shift, 0.0, -H])
    x = -(rot @ pivot) + np.array([B - com_shift, 0.0, 0.0])
    state = State(x, np.zeros(3), rot, np.zeros(3))
    body = Body(1.0, np.eye(3), nodes)
    return adapter._StaticSupport.at(body, state, Pedestal(), 1e-5, mu)


def _load(a_h: float, azimuth: float = 0.0, a_v: float = 0.0) -> np.ndarray:
    """g − a for a ground acceleration a_h (m/s²) along ``azimuth`` (rad) and a_v up."""
    return np.array([[-a_h * math.cos(azimuth), -a_h * math.sin(azimuth), -G - a_v]])


def test_support_is_housners_static_uplift_test() -> None:
    """At rest on its base the block stays at rest below Housner's g tan α (along an axis; toward
    a corner √2 g tan α) within the hold's margin, and not at or above it; a smaller gravity
    (the ground accelerating down) lowers the level in proportion; the friction cone bounds it."""
    sup = _block_support()
    assert sup is not None
    lim = G * TAN_ALPHA
    m = adapter.HOLD_MARGIN
    for az, k in ((0.0, 1.0), (math.pi, 1.0), (math.pi / 2, 1.0), (math.pi / 4, math.sqrt(2.0))):
        assert sup.holds(_load((1 - 2 * m) * k * lim, az))[0]
        assert not sup.holds(_load((1 - 0.5 * m) * k * lim, az))[0]
        assert not sup.holds(_load(1.01 * k * lim, az))[0]
    # the ground accelerating down at g/2: half the uplift level
    assert sup.holds(_load(0.49 * lim, a_v=-0.5 * G))[0]
    assert not sup.holds(_load(0.51 * lim, a_v=-0.5 * G))[0]
    # free fall or a pull upward: never held
    assert not sup.holds(_load(0.0, a_v=-G))[0]
    # friction: μ = 0.2 slides at 0.2 g, below the uplift level
    slip = _block_support(mu=0.2)
    assert slip is not None
    assert slip.holds(_load(0.19 * G))[0]
    assert not slip.holds(_load(0.21 * G))[0]
    assert sup.holds(_load(0.21 * G))[0]
    # an off-centre COM: the edge toward it is nearer (tan α = (B − e)/H), the other farther
    e = 0.05
    off = _block_support(com_shift=e)
    assert off is not None
    assert off.holds(_load(0.99 * G * (B - e) / H, math.pi))[0]  # the ground pushed −x: the rock leans +x
    assert not off.holds(_load(1.01 * G * (B - e) / H, math.pi))[0]
    assert off.holds(_load(0.99 * G * (B + e) / H, 0.0))[0]


def test_no_support_off_a_polygon() -> None:
    """A block on one edge (tilted) has no polygon to rest on: never held."""
    assert _block_support(tilt=1e-3) is None


def _quiet_pulse_quiet(amplitude: float, dt: float = 0.002) -> Record:
    """2 s of shaking at half the block's uplift level, the Housner half-sine pulse
    a·sin(2πt + φ) (a sin φ = g tan α) of ``amplitude`` m/s², 3 s at 0.4 of the uplift level."""
    phi = math.asin(G * TAN_ALPHA / amplitude)
    tp = (math.pi - phi) / (2 * math.pi)
    t = np.arange(0.0, 2.0 + tp + 3.0, dt)
    a = 0.5 * G * TAN_ALPHA * np.sin(4 * math.pi * t) * (t < 2.0)
    pulse = (t >= 2.0) & (t < 2.0 + tp)
    a[pulse] = amplitude * np.sin(2 * math.pi * (t[pulse] - 2.0) + phi)
    after = t >= 2.0 + tp
    a[after] = 0.4 * G * TAN_ALPHA * np.sin(3 * math.pi * (t[after] - 2.0 - tp))
    return Record(a, dt, 0.0)


@pytest.mark.parametrize(("amplitude", "toppled"), [(5.0, False), (5.7, True)])
def test_hold_equals_stepping(amplitude: float, toppled: bool) -> None:
    """Quiet shaking, a pulse below / above the toppling level, quiet shaking: the run with holds
    equals the stepped run (the same outcome, events and sample times; the states within 1e-8,
    round-off of the stepped rest amplified by the rocking) at a fraction of its steps."""
    base = compile_scene(conf.housner_scenario(duration=9.0))
    scene = dataclasses.replace(base, excitation=Excitation3D(_quiet_pulse_quiet(amplitude), azimuth=0.0))
    held = run_scene(scene, "reference")
    stepped = run_scene(scene, "reference", {"static_hold": False})
    assert held.ok and stepped.ok
    assert held.toppled == stepped.toppled == toppled
    assert held.diagnostics["static_holds"] >= 1
    assert held.diagnostics["static_hold_s"] > 1.9  # the quiet start, at least
    assert stepped.diagnostics["static_holds"] == 0
    assert held.diagnostics["steps"] < stepped.diagnostics["steps"] - 1900
    kinds = [(e.kind, round(e.t, 9)) for e in held.events]
    assert kinds == [(e.kind, round(e.t, 9)) for e in stepped.events]
    n = min(len(held.t), len(stepped.t))
    assert abs(len(held.t) - len(stepped.t)) <= 1  # the run's last sample (the rest stop)
    np.testing.assert_array_equal(np.asarray(held.t)[:n], np.asarray(stepped.t)[:n])
    np.testing.assert_allclose(np.asarray(held.com)[:n], np.asarray(stepped.com)[:n], rtol=0, atol=1e-8)
    np.testing.assert_allclose(np.asarray(held.quat)[:n], np.asarray(stepped.quat)[:n], rtol=0, atol=1e-8)


def test_hold_is_the_same_in_every_path(monkeypatch) -> None:
    """Holds are tried after the same steps whether the steps run in the compiled blocks with the
    excitation compiled, in blocks planned by the Python load table, or one by one: the three
    runs are bit-identical."""
    base = compile_scene(conf.housner_scenario(duration=9.0))
    scene = dataclasses.replace(base, excitation=Excitation3D(_quiet_pulse_quiet(5.0), azimuth=0.3))
    runs = [run_scene(scene, "reference")]
    monkeypatch.setattr(adapter, "COMPILED_EXCITATION", False)
    runs.append(run_scene(scene, "reference"))
    monkeypatch.setattr(adapter, "BLOCK_STEPS", 0)
    runs.append(run_scene(scene, "reference"))
    assert runs[0].diagnostics["static_holds"] >= 1
    timing = set(adapter.TIMING_DIAGNOSTICS)
    for other in runs[1:]:
        for name in ("t", "com", "quat", "omega"):
            np.testing.assert_array_equal(getattr(runs[0], name), getattr(other, name))
        assert [(e.kind, e.t) for e in runs[0].events] == [(e.kind, e.t) for e in other.events]
        # the kernel-call counts differ by path; the physics diagnostics do not
        for key in ("static_holds", "static_hold_s", "impacts", "steps"):
            assert runs[0].diagnostics[key] == other.diagnostics[key], key
        assert {k for k in runs[0].diagnostics if k not in timing} == {
            k for k in other.diagnostics if k not in timing
        }


def test_step_grid_is_the_engines_time_arithmetic() -> None:
    """The vectorised step grid of the hold gives the step-by-step plan's starts and Δt exactly
    (random Δt, breakpoints, start times and lengths)."""
    rng = np.random.default_rng(1)
    for trial in range(200):
        dt = float(rng.choice([1e-3, 7e-4, 1.3e-3, 2.5e-4]))
        dur = float(rng.uniform(0.5, 30.0))
        bps = sorted({float(x) for x in rng.uniform(0.0, dur, rng.integers(0, 4))} | {dur})
        t = float(rng.uniform(0.0, dur)) if trial % 3 else 0.0
        n = int(rng.integers(1, 5000))
        want = adapter._step_starts(t, n, bps=bps, dt_nom=dt, duration=dur)
        starts, hs, after = adapter._step_grid(t, n, bps=np.array(bps), dt_nom=dt, duration=dur)
        assert starts.tolist() == [w[0] for w in want], trial
        assert hs.tolist() == [w[1] for w in want], trial
        nxt = adapter._step_starts(want[-1][0], 2, bps=bps, dt_nom=dt, duration=dur) if want else []
        if len(nxt) > 1:
            assert after == nxt[1][0], trial
