"""The standard diagnostics (pbr_xval.diagnostics) against independent references.

References: closed-form kinematics (velocity), the linearized free-rocking solution of
science.md §1.5 (impact times), the nonlinear free-rocking closed form (energy, impact times;
``conformance.free_rocking_impact_times``), the sliding-block friction closed form (slip) and the
free-flight closed form of a block thrown by a vertical pulse (airborne time).
"""

from __future__ import annotations

import importlib.util
import math

import numpy as np
import pytest
from scipy.optimize import brentq

from pbr_xval.conformance import free_rocking_impact_times, housner_scenario
from pbr_xval.diagnostics import (
    AIR_FLOOR_REL,
    DEFINITION,
    KEYS,
    com_velocity,
    impact_times,
    regime_label,
    standard_diagnostics,
)
from pbr_xval.engine import Trajectory
from pbr_xval.runner import run_scene
from pbr_xval.scene import compile_scene

G = 9.81
SQUAT = {"shape": "box", "half_extents": [0.3, 0.3, 0.1], "density": 2400.0}


def _engines(*names: str) -> list[object]:
    """pytest params: engines whose package is installed (the others are skipped)."""
    pkg = {"mujoco": "mujoco", "pybullet": "pybullet", "dart": "dartpy"}
    out = []
    for name in names:
        missing = name in pkg and importlib.util.find_spec(pkg[name]) is None
        out.append(pytest.param(name, marks=pytest.mark.skipif(missing, reason=f"{name} not installed")))
    return out


# ------------------------------------------------------------------ pure functions
def test_velocity_exact_for_uniform_acceleration_on_uneven_samples() -> None:
    rng = np.random.default_rng(3)
    t = np.cumsum(rng.uniform(0.5e-3, 1.5e-3, 200))
    a, v0, x0 = np.array([1.5, -2.0, -9.81]), np.array([0.3, 0.1, 2.0]), np.array([1.0, 2.0, 3.0])
    x = x0 + v0 * t[:, None] + 0.5 * a * t[:, None] ** 2
    np.testing.assert_allclose(com_velocity(t, x), v0 + a * t[:, None], rtol=0, atol=1e-9)


def test_velocity_not_smeared_across_an_impact() -> None:
    """Velocity jumps from v1 to v2 between two samples: every sample keeps its own velocity
    (central differences would give the mean (v1 + v2)/2 on both sides of the jump)."""
    t = np.arange(0.0, 0.1, 1e-3)
    t_hit = 0.0503
    v1, v2 = np.array([0.2, 0.0, -0.05]), np.array([0.17, 0.0, 0.04])
    x = np.where((t < t_hit)[:, None], v1 * t[:, None], v1 * t_hit + v2 * (t[:, None] - t_hit))
    v = com_velocity(t, x)
    np.testing.assert_allclose(v[t < t_hit], np.broadcast_to(v1, v[t < t_hit].shape), atol=1e-9)
    np.testing.assert_allclose(v[t > t_hit], np.broadcast_to(v2, v[t > t_hit].shape), atol=1e-9)


def _linear_free_rocking(alpha: float, p: float, e: float, phi0: float, t: np.ndarray) -> tuple:
    """Linearized free rocking (science.md §1.5): θ(t) (n,) and the impact times, closed form.

    From rest at θ0 = φ0 α: θ = α − (α − θ0) cosh(pt) until θ = 0; a half-cycle leaving θ = 0 at
    speed ω lasts (2/p) atanh(ω/(pα)), θ = ±[α − α cosh(pτ) + (ω/p) sinh(pτ)]; impacts θ̇ → e θ̇.
    """
    th0 = phi0 * alpha
    t1 = math.acosh(alpha / (alpha - th0)) / p
    w = (alpha - th0) * p * math.sinh(p * t1)
    theta = np.where(t < t1, alpha - (alpha - th0) * np.cosh(p * t), 0.0)
    impacts, start, side = [t1], t1, -1.0
    while start < t[-1]:
        w *= e
        dur = 2.0 * math.atanh(w / (p * alpha)) / p
        sel = (t >= start) & (t < start + dur)
        tau = t[sel] - start
        theta[sel] = side * (alpha - alpha * np.cosh(p * tau) + (w / p) * np.sinh(p * tau))
        start += dur
        impacts.append(start)
        side = -side
    return theta, np.asarray([x for x in impacts if x <= t[-1]])


def test_impact_times_match_the_linearized_closed_form() -> None:
    alpha, p = math.atan(1 / 3), math.sqrt(3 * G / (4 * math.hypot(0.2, 0.6)))
    e = 1 - 1.5 * math.sin(alpha) ** 2  # 0.85
    t = np.arange(0.0, 3.0, 1e-3)
    theta, ref = _linear_free_rocking(alpha, p, e, 0.5, t)
    got = impact_times(t, theta, 5e-4)
    # the last closed-form impacts are below the tolerance (amplitude < 5e-4 rad): compare the others
    assert got.size >= 10
    # linear interpolation across the velocity jump at the impact (θ̇ → e θ̇): error ≤ (1 − e)/(1 + e)·dt/2
    # = 4e-5 s at dt = 1 ms (measured 4.1e-5 s)
    np.testing.assert_allclose(got, ref[: got.size], rtol=0, atol=1e-4)


def test_impact_times_ignore_chatter_below_the_tolerance() -> None:
    t = np.arange(0.0, 1.0, 1e-3)
    theta = 1e-5 * np.sin(2 * np.pi * 37 * t)  # a compliant contact's noise, not rocking
    assert impact_times(t, theta, 5e-4).size == 0


def test_regime_labels() -> None:
    base = {"slip_max_m": 0.1234, "airborne_s": 0.0312}
    assert regime_label({"regime": "rest"}) == "at rest"
    assert regime_label({**base, "regime": "rock", "rocked": True}) == "rocked"
    assert regime_label({**base, "regime": "slide", "slid": True}) == "slid 0.123 m"
    assert (
        regime_label({**base, "regime": "rock+slide", "rocked": True, "slid": True})
        == "rocked and slid 0.123 m"
    )
    label = regime_label({**base, "regime": "rock+jump", "rocked": True, "jumped": True})
    assert label == "rocked, jumped (0.0312 s airborne)"
    assert regime_label({}) == "unknown"


def test_nan_tail_is_cut_and_empty_trajectory_is_unknown() -> None:
    scene = compile_scene(housner_scenario(duration=1.0, excitation={"type": "none"}))
    n = 100
    t = np.arange(n) * 1e-3
    com = np.tile(scene.rock.com, (n, 1))
    com[60:] = np.nan
    traj = Trajectory(
        "x", t, com, np.tile([1.0, 0, 0, 0], (n, 1)), np.zeros((n, 3)), excitation_axis=scene.direction
    )
    d = standard_diagnostics(traj, scene)
    assert d["evaluated_until_s"] == pytest.approx(t[59])
    assert d["regime"] == "rest" and d["settled"] and d["at_rest_end"]
    empty = Trajectory.failed("x", "boom")
    assert standard_diagnostics(empty, scene)["regime"] == "unknown"


# ------------------------------------------------------------------ with engines
def _free_scene() -> object:
    return compile_scene(
        housner_scenario(
            name="diag_free", duration=3.0, excitation={"type": "none"}, initial={"theta_over_alpha": 0.5}
        )
    )


@pytest.mark.parametrize(
    ("engine", "settings"),
    [
        pytest.param("housner", {}, id="housner"),
        pytest.param("reference", {}, id="reference"),
        *[
            pytest.param(e.values[0], {"timestep": 1e-4}, marks=e.marks, id=e.values[0])
            for e in _engines("mujoco", "dart")
        ],
    ],
)
def test_free_rocking_impacts_and_energy_against_closed_form(engine: str, settings: dict) -> None:
    """Released from θ0 = α/2: impacts at the closed-form times; energy m g R [cos(α − θ0) − cos α]
    at the start, multiplied by e² = 0.7225 at each impact, never created.

    Measured (3 s, 11 impacts): start energy within 0.04 %, end energy 3.07–3.09 J vs 3.0745 J
    (≤ 0.5 %), impact times within 4 ms (dt 1e-3) and 1 ms (dt 1e-4) of the closed form,
    energy gain ≤ 0.6 % of the barrier (MuJoCo's compliant contact, 0.35 %).
    """
    scene = _free_scene()
    traj = run_scene(scene, engine, settings)
    d = traj.diagnostics
    assert set(KEYS) <= set(d) and d["diagnostics_definition"] == DEFINITION
    ref = free_rocking_impact_times(scene, float(traj.t[-1]))
    assert ref.size == 11
    assert abs(d["impacts"] - ref.size) <= 1
    k = min(d["impacts"], ref.size)
    np.testing.assert_allclose(d["impact_times_s"][:k], ref[:k], rtol=0, atol=5e-3)

    m, r, alpha = scene.rock.mass, math.hypot(0.2, 0.6), math.atan(1 / 3)
    e0 = m * G * r * (math.cos(alpha - alpha / 2) - math.cos(alpha))
    barrier = m * G * (r - 0.6)
    assert d["energy_barrier_J"] == pytest.approx(barrier, rel=1e-9)
    assert d["energy_start_J"] == pytest.approx(e0, rel=2e-3)
    e_end = e0 * (1 - 1.5 * math.sin(alpha) ** 2) ** (2 * d["impacts"])
    assert d["energy_end_J"] == pytest.approx(e_end, rel=0.01)
    assert d["energy_max_rel_change"] == pytest.approx((e0 - e_end) / barrier, rel=0.01)
    assert d["energy_gain_rel"] < 0.01
    assert d["regime"] == "rock" and traj.regime == "rocked"
    assert not d["settled"]  # a tilted start is not a settled start
    assert d["slip_max_m"] < d["tolerance_slip_m"]


@pytest.mark.parametrize("engine", ["reference", *_engines("mujoco", "pybullet", "dart")])
def test_resting_block_is_settled_and_at_rest(engine: str) -> None:
    scene = compile_scene(housner_scenario(name="diag_rest", duration=1.0, excitation={"type": "none"}))
    traj = run_scene(scene, engine)
    d = traj.diagnostics
    assert d["regime"] == "rest" and traj.regime == "at rest"
    assert d["settled"] and d["at_rest_end"] and d["at_rest_from_s"] == pytest.approx(float(traj.t[0]))
    assert d["impacts"] == 0 and d["flights"] == 0
    assert traj.summary()["regime"] == "at rest"


@pytest.mark.parametrize("engine", ["reference", *_engines("mujoco", "pybullet", "dart")])
def test_sliding_block_slip_against_friction_closed_form(engine: str) -> None:
    """Rectangular pulse a = 5 m/s² for t1 = 0.3 s under μ = 0.3: the block slides
    ½ (a − μg) t1² · a/(μg) = 0.15733 m (accelerating during the pulse, decelerating at μg after).
    Measured 0.1573 m in every engine. MuJoCo's soft contact also chatters (the leading edge lifts
    up to 1.8 mm while sliding), so MuJoCo reads "rocked and slid …, jumped" (docs/diagnostics.md)."""
    a, t1, mu = 5.0, 0.3, 0.3
    scn = housner_scenario(
        name="diag_slide",
        duration=1.5,
        rock=SQUAT,
        contact={"friction_static": mu, "restitution": 0.0},
        excitation={"type": "rectangular", "amplitude": a, "pulse_duration": t1},
    )
    traj = run_scene(compile_scene(scn), engine)
    d = traj.diagnostics
    ref = 0.5 * (a - mu * G) * t1**2 * a / (mu * G)
    assert d["slip_max_m"] == pytest.approx(ref, rel=0.01)
    assert d["slid"] and d["at_rest_end"]
    if engine != "mujoco":
        assert d["regime"] == "slide" and traj.regime == f"slid {d['slip_max_m']:.3g} m"


def _flight_above(floor: float) -> float:
    """Time (s) a block resting on a pedestal with vertical acceleration A sin(ωt), A = 2g,
    ω = 4π, 0 ≤ t ≤ 0.5 s, spends more than ``floor`` (m) above it (closed form + root finding).

    Contact is lost at t_a = (π + asin(g/A))/ω; the gap then obeys ẍ = −g − A sin ωt."""
    amp, w, t_end = 2 * G, 4 * math.pi, 0.5
    ta = (math.pi + math.asin(G / amp)) / w

    def gap(t: float) -> float:
        tt = min(t, t_end)
        x = -G * (tt - ta) ** 2 / 2 + amp / w * (
            (math.sin(w * tt) - math.sin(w * ta)) / w - math.cos(w * ta) * (tt - ta)
        )
        if t <= t_end:
            return x
        v = -G * (t_end - ta) + amp / w * (math.cos(w * t_end) - math.cos(w * ta))
        return x + v * (t - t_end) - G * (t - t_end) ** 2 / 2

    up = brentq(lambda t: gap(t) - floor, ta + 1e-9, 0.45)
    down = brentq(lambda t: gap(t) - floor, 0.5, 1.2)
    return down - up


@pytest.mark.parametrize("engine", ["reference", *_engines("mujoco", "pybullet", "dart")])
def test_thrown_block_jumps_for_the_closed_form_flight(engine: str) -> None:
    """Vertical one-sine pulse of 2g at 2 Hz: the pedestal drops faster than g and the block
    flies. Longest flight vs closed form (0.4734 s above 10⁻⁴ b = 30 µm): measured MuJoCo
    0.4734 s (then a 0.08 s bounce), DART 0.4733, reference 0.4744, PyBullet 0.4723 (−0.2 %)."""
    scn = housner_scenario(
        name="diag_jump",
        duration=1.2,
        rock=SQUAT,
        excitation={
            "type": "rectangular",
            "amplitude": 0.1,
            "pulse_duration": 0.3,
            "vertical": {"type": "one_sine", "amplitude": 2 * G, "frequency": 2.0},
        },
    )
    traj = run_scene(compile_scene(scn), engine)
    d = traj.diagnostics
    ref = _flight_above(AIR_FLOOR_REL * 0.3)
    assert d["jumped"] and "jump" in d["regime"] and "jumped" in traj.regime
    assert d["airborne_max_s"] == pytest.approx(ref, rel=0.01)
    assert not d["rocked"] and not d["slid"]


def test_analytical_engine_gets_the_standard_diagnostics_through_run_scene() -> None:
    """The housner engine records its impacts as events; the sampled count agrees (± 0)."""
    scene = _free_scene()
    traj = run_scene(scene, "housner")
    assert traj.diagnostics["impacts"] == len(traj.impacts()) == 11
    assert traj.diagnostics["penetration_source"] == "sampled pose"
    assert traj.diagnostics["max_penetration_m"] < 1e-12
    assert traj.summary()["impacts"] == 11


def test_regime_is_evaluated_until_toppling() -> None:
    scn = housner_scenario(
        name="diag_topple",
        excitation={"type": "half_sine", "amplitude": 6.0, "frequency": 1.0, "phase": "housner_uplift"},
    )
    traj = run_scene(compile_scene(scn), "housner")
    assert traj.toppled
    d = traj.diagnostics
    assert d["evaluated_until_s"] == pytest.approx(traj.toppled_at, abs=2 * 1e-3)
    assert d["regime"] == "rock"


def test_rolling_curved_base_does_not_slide() -> None:
    """The curved-base model rolls without slip by construction: rolling is not sliding.
    Measured slip 6·10⁻⁵ m (the hull's facets) against the tolerance 1.69·10⁻² m."""
    from pathlib import Path

    from pbr_xval.scenario import load_scenario

    example = Path(__file__).resolve().parents[1] / "examples" / "echo_cliff_like_sawtooth.toml"
    scn = load_scenario(example).with_value("excitation.pgv", 3.0)
    traj = run_scene(compile_scene(scn), "curved_base")
    d = traj.diagnostics
    assert not traj.toppled and d["regime"] == "rock"
    assert d["slip_max_m"] < 0.01 * d["tolerance_slip_m"]


def _impact_times_per_sample(t: np.ndarray, th: np.ndarray, tol: float) -> list[float]:
    """The impact rule written as the plain loop over every sample (the reference)."""
    out, side, i, n = [], 0, 0, th.size
    while i < n:
        x = th[i]
        if side == 0:
            if abs(x) > tol:
                side = 1 if x > 0 else -1
            i += 1
            continue
        if side * x > 0.5 * tol:
            i += 1
            continue
        t_hit, j = float(t[i]), max(i, 1)
        while j < n:
            a, b = th[j - 1], th[j]
            if side * a > 0 >= side * b:
                t_hit = float(t[j - 1] + (a / (a - b)) * (t[j] - t[j - 1]))
                break
            if abs(b) > tol:
                break
            j += 1
        out.append(t_hit)
        side = -side if side * x < -tol else 0
        i += 1
    return out


def test_impact_times_equal_the_per_sample_rule() -> None:
    """impact_times jumps between candidate samples; it must give the per-sample loop's answer exactly
    (random, rocking-like, quantised and NaN-holding histories)."""
    rng = np.random.default_rng(11)
    for trial in range(600):
        n = int(rng.integers(1, 300))
        t = np.cumsum(rng.uniform(0.5, 1.5, n))
        if trial % 3 == 0:
            th = rng.normal(0, 1, n)
        elif trial % 3 == 1:
            th = np.sin(t * rng.uniform(0.05, 0.5)) * rng.uniform(0.5, 3) + rng.normal(0, 0.05, n)
        else:
            th = np.round(rng.normal(0, 1, n))
        if trial % 7 == 0:
            th[rng.integers(0, n)] = np.nan
        tol = float(rng.uniform(0.05, 1.0))
        assert impact_times(t, th, tol).tolist() == _impact_times_per_sample(t, th, tol)


def test_points_of_repeated_poses_equal_a_per_sample_computation() -> None:
    """A held rock records the same pose at many samples; the lowest hull point, the support's
    height spread and the contact's displacement per sample are computed once per run of equal
    poses. Against a plain loop over the samples (min over the hull of R p + c)."""
    from scipy.spatial.transform import Rotation

    from pbr_xval.diagnostics import _points_z_and_xy, scene_scales

    scene = compile_scene(housner_scenario())
    sc = scene_scales(scene)
    rng = np.random.default_rng(7)
    poses = Rotation.from_rotvec(rng.normal(0.0, 0.05, (12, 3))).as_matrix()
    coms = rng.normal(0.0, 0.01, (12, 3)) + np.array([0.0, 0.0, 0.6])
    runs = [1, 5, 1, 1, 40, 2, 1, 7, 1, 1, 3, 9]  # samples per pose, in order
    rot = np.concatenate([np.repeat(poses[i : i + 1], m, axis=0) for i, m in enumerate(runs)])
    com = np.concatenate([np.repeat(coms[i : i + 1], m, axis=0) for i, m in enumerate(runs)])
    rot[10] = poses[1]  # a pose seen before, not right before: computed again
    tol = 1e-3
    low, slip, spread = _points_z_and_xy(sc, com, rot, tol)
    n = com.shape[0]
    for i in range(n):
        z = np.array([(rot[i] @ p + com[i])[2] for p in sc.hull])
        assert low[i] == pytest.approx(z.min(), abs=1e-12)
        zs = z[sc.support]
        assert spread[i] == pytest.approx(zs.max() - zs.min(), abs=1e-12)
        if i < n - 1:
            c = sc.hull[z <= z.min() + tol].mean(axis=0)
            move = (rot[i + 1] @ c + com[i + 1])[:2] - (rot[i] @ c + com[i])[:2]
            np.testing.assert_allclose(slip[i], move, atol=1e-12)
    same = np.all(com[1:] == com[:-1], axis=1) & np.all(rot[1:] == rot[:-1], axis=(1, 2))
    assert same.sum() == sum(runs) - len(runs) - 2 and np.all(slip[same] == 0.0)
