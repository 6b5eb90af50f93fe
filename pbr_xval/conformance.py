"""Conformance kit: shared analytical cases every engine must pass (like scikit-learn's checks).

Each check takes an engine name and returns the measured figures; it raises
``AssertionError`` with the numbers when the engine misses the reference. Engines declare
known gaps as ``expected_failures = {check_name: reason}`` on their class; the pytest suite
in ``tests/conformance/`` turns those into xfail.

References are independent of the engines: Housner's half-sine threshold 5.638 m/s²
(nonlinear ODE; Veeraraghavan & Krishnan 5.62–5.64), the rebound ratio 1 − 1.5 sin²α = 0.850,
the notched block's own two-pivot threshold (computed by the ``housner`` engine from exact
mass properties), and the primitive box itself for the mesh-box check.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from pbr_xval.engine import Trajectory, get_engine
from pbr_xval.runner import run_scene
from pbr_xval.scenario import Scenario, scenario_from_dict
from pbr_xval.scene import compile_scene
from pbr_xval.study.threshold import find_threshold

__all__ = [
    "CHECKS",
    "HOUSNER_REBOUND",
    "HOUSNER_THRESHOLD",
    "housner_scenario",
    "rebound_ratios",
]

#: nonlinear Housner half-sine threshold for b = 0.2 m, h = 0.6 m, ω = 2π, g = 9.81 (m/s²)
HOUSNER_THRESHOLD = 5.638
#: 1 − 1.5 sin²α for tan α = 1/3
HOUSNER_REBOUND = 0.85


def housner_scenario(**overrides: Any) -> Scenario:
    """The seed's Housner block as a Scenario; keyword overrides replace top-level tables."""
    data: dict[str, Any] = {
        "name": "conformance_housner",
        "duration": 5.0,
        "settle_time": 0.5,
        "rock": {"shape": "box", "half_extents": [0.2, 0.2, 0.6], "density": 2400.0},
        "contact": {"friction_static": 2.0, "restitution": 0.0},
        "excitation": {"type": "half_sine", "amplitude": 5.0, "frequency": 1.0, "phase": "housner_uplift"},
    }
    data.update(overrides)
    return scenario_from_dict(data)


def notched_scenario(**overrides: Any) -> Scenario:
    rock = {
        "shape": "notched_block",
        "half_extents": [0.2, 0.2, 0.6],
        "notch_width": 0.2,
        "notch_height": 0.3,
        "density": 2400.0,
    }
    return housner_scenario(**({"name": "conformance_notched", "rock": rock} | overrides))


def free_rocking_scenario(**overrides: Any) -> Scenario:
    return housner_scenario(
        name="conformance_free_rocking",
        duration=3.0,
        excitation={"type": "none"},
        initial={"theta_over_alpha": 0.5},
        **overrides,
    )


def _settings(engine: str, extra: dict[str, Any] | None = None) -> dict[str, Any]:
    eng = get_engine(engine)
    base = {}
    if "timestep" in eng.default_settings():
        base["timestep"] = 1e-3
    base.update(extra or {})
    return base


def _threshold(scn: Scenario, engine: str, lo: float, hi: float, settings: dict[str, Any]) -> float:
    res = find_threshold(
        scn, engine, lo=lo, hi=hi, n_grid=3, rel_tol=2e-4, settings=settings, all_transitions=False
    )
    if res.minimum is None:
        raise AssertionError(f"{engine}: never toppled in [{lo}, {hi}]")
    if res.grid_toppled[0]:
        raise AssertionError(f"{engine}: already toppled at the bottom of the scan ({lo})")
    return res.minimum


def rebound_ratios(traj: Trajectory, scene: Any) -> np.ndarray:
    """Per-half-cycle rebound ratios from the energy-equivalent rocking speed (notes §'Rebound ratio').

    ω0² = θ̇² + 2p²[cos(α − |θ|) − cos α] is constant between impacts in exact dynamics; its
    median over the middle half of each half-cycle (split at the sign changes of θ) is taken,
    and successive medians are divided.
    """
    theta = traj.rocking_angle()
    thd = traj.omega @ scene.rocking_axis
    pm = scene.planar_model()
    out = []
    meds = []
    sgn = np.sign(theta)
    cuts = np.nonzero(np.diff(sgn) != 0)[0] + 1
    edges = np.concatenate([[0], cuts, [theta.size]])
    for a, b in itertools.pairwise(edges):
        if b - a < 8:
            continue
        side = pm.right if theta[(a + b) // 2] > 0 else pm.left
        x, z = side
        rr = math.hypot(x, z)
        alpha = math.atan2(abs(x), abs(z))
        io = pm.inertia + pm.mass * rr * rr
        p2 = pm.mass * scene.gravity * rr / io
        seg = slice(a + (b - a) // 4, b - (b - a) // 4)
        w2 = thd[seg] ** 2 + 2 * p2 * (np.cos(alpha - np.abs(theta[seg])) - math.cos(alpha))
        meds.append(float(np.sqrt(np.median(w2))))
    for i in range(1, len(meds)):
        out.append(meds[i] / meds[i - 1])
    return np.asarray(out)


# ----------------------------------------------------------------------- checks
@dataclass(frozen=True)
class Check:
    name: str
    func: Callable[[str], dict[str, Any]]
    needs: frozenset[str] = frozenset()  # capability flags / shapes
    slow: bool = False


def check_rest(engine: str) -> dict[str, Any]:
    """No excitation for 1 s: the rock stays put (tilt < 1e-4 rad, COM drift < 1e-4 m)."""
    scn = housner_scenario(name="conformance_rest", duration=1.0, excitation={"type": "none"})
    scene = compile_scene(scn)
    traj = run_scene(scene, engine, _settings(engine))
    assert traj.ok, traj.message
    tilt = float(traj.tilt().max()) if traj.t.size else 0.0
    drift = float(np.max(np.linalg.norm(traj.com - traj.com[:1], axis=1))) if traj.t.size else 0.0
    assert not traj.toppled, f"{engine}: toppled at rest"
    assert tilt < 1e-4, f"{engine}: tilt {tilt:.3g} rad at rest"
    assert drift < 1e-4, f"{engine}: COM drifted {drift:.3g} m at rest"
    return {"max_tilt_rad": tilt, "com_drift_m": drift}


def check_housner_threshold(engine: str) -> dict[str, Any]:
    """Half-sine threshold within 0.2 % of 5.638 m/s² (dt = 1e-3 for time-steppers)."""
    eng = get_engine(engine)
    tol = 5e-4 if eng.capabilities.analytical else 2e-3
    a = _threshold(housner_scenario(), engine, 5.5, 5.8, _settings(engine))
    err = a / HOUSNER_THRESHOLD - 1
    assert abs(err) <= tol, f"{engine}: threshold {a:.5f} m/s², error {err:+.3%} (allowed ±{tol:.2%})"
    return {"threshold": a, "rel_error": err}


def check_free_rocking_rebound(engine: str) -> dict[str, Any]:
    """Free rocking from θ0 = 0.5α: per-half-cycle rebound 0.850 ± 0.005 (dt = 1e-4)."""
    scene = compile_scene(free_rocking_scenario())
    extra = {"timestep": 1e-4} if "timestep" in get_engine(engine).default_settings() else {}
    traj = run_scene(scene, engine, _settings(engine, extra))
    assert traj.ok, traj.message
    r = rebound_ratios(traj, scene)
    assert r.size >= 2, f"{engine}: fewer than 3 half-cycles of rocking (ratios {r})"
    first = r[:2]
    assert np.all(np.abs(first - HOUSNER_REBOUND) <= 0.005), f"{engine}: rebound ratios {np.round(r, 4)}"
    return {"ratios": r.tolist()}


def check_mesh_box(engine: str, tmp_dir: Path | None = None) -> dict[str, Any]:
    """A box given as a mesh file has the primitive box's threshold (within 0.3 %)."""
    import tempfile

    import trimesh

    tmp = Path(tmp_dir or tempfile.mkdtemp(prefix="pbr_xval_conf_"))
    path = tmp / "box.obj"
    trimesh.creation.box(extents=(0.4, 0.4, 1.2)).export(path)
    mesh_scn = housner_scenario(rock={"shape": "mesh", "path": str(path), "density": 2400.0})
    a_mesh = _threshold(mesh_scn, engine, 5.4, 5.9, _settings(engine))
    a_box = _threshold(housner_scenario(), engine, 5.5, 5.8, _settings(engine))
    rel = a_mesh / a_box - 1
    assert abs(rel) <= 3e-3, f"{engine}: mesh box {a_mesh:.5f} vs primitive {a_box:.5f} ({rel:+.3%})"
    return {"mesh": a_mesh, "primitive": a_box, "rel_diff": rel}


def check_notched_block(engine: str) -> dict[str, Any]:
    """Notched block threshold within 1 % of its own two-pivot analytical threshold."""
    scn = notched_scenario()
    ref = _threshold(scn, "housner", 4.9, 5.4, {})
    a = _threshold(scn, engine, 4.9, 5.4, _settings(engine))
    rel = a / ref - 1
    tol = 5e-4 if get_engine(engine).capabilities.analytical else 1e-2
    assert abs(rel) <= tol, f"{engine}: notched block {a:.5f} vs analytical {ref:.5f} ({rel:+.3%})"
    return {"threshold": a, "analytical": ref, "rel_diff": rel}


def check_notched_rebound(engine: str) -> dict[str, Any]:
    """Notched block free rocking (dt = 1e-4): first two rebound ratios within 0.005 of the
    two-pivot value 1 − m R²(1 − cos 2α)/I_O (0.8665, from exact mass properties)."""
    scene = compile_scene(
        notched_scenario(
            name="conformance_notched_free",
            duration=3.0,
            excitation={"type": "none"},
            initial={"theta_over_alpha": 0.5},
        )
    )
    from pbr_xval.analytical.rocking import TwoPivotBody

    pm = scene.planar_model()
    ref = TwoPivotBody(pm.mass, pm.inertia, pm.left, pm.right).impact_ratio("left")
    extra = {"timestep": 1e-4} if "timestep" in get_engine(engine).default_settings() else {}
    traj = run_scene(scene, engine, _settings(engine, extra))
    assert traj.ok, traj.message
    r = rebound_ratios(traj, scene)
    assert r.size >= 2, f"{engine}: fewer than 3 half-cycles of rocking (ratios {r})"
    assert np.all(np.abs(r[:2] - ref) <= 0.005), f"{engine}: notched rebound {np.round(r, 4)} vs {ref:.4f}"
    return {"ratios": r.tolist(), "reference": ref}


def check_ground_modes(engine: str) -> dict[str, Any]:
    """Inertial load and moving pedestal agree: peak |θ| at a = 5.6 m/s² within 1 %."""
    scene = compile_scene(
        housner_scenario(
            excitation={"type": "half_sine", "amplitude": 5.6, "frequency": 1.0, "phase": "housner_uplift"}
        )
    )
    peaks = {}
    for mode in ("inertial", "moving_pedestal"):
        traj = run_scene(scene, engine, _settings(engine, {"ground_motion": mode}))
        assert traj.ok, traj.message
        peaks[mode] = float(np.max(np.abs(traj.rocking_angle())))
    rel = peaks["moving_pedestal"] / peaks["inertial"] - 1
    assert abs(rel) <= 1e-2, (
        f"{engine}: peak θ inertial {peaks['inertial']:.5f} vs moving {peaks['moving_pedestal']:.5f}"
    )
    return {"peak_theta": peaks, "rel_diff": rel}


def check_deterministic(engine: str) -> dict[str, Any]:
    """The same scene and settings twice give a bit-identical trajectory."""
    scene = compile_scene(housner_scenario(duration=2.0))
    fp = [run_scene(scene, engine, _settings(engine)).fingerprint() for _ in range(2)]
    assert fp[0] == fp[1], f"{engine}: two identical runs differ"
    return {"fingerprint": fp[0]}


def free_rocking_impact_times(scene: Any, t_end: float) -> np.ndarray:
    """Impact times (s), shape (k,), of a two-pivot block released from rest at ``scene.theta0``.

    Closed form of the nonlinear free rocking (science.md §1.2, §1.4), independent of
    ``pbr_xval.analytical``: energy is conserved between impacts, so a half-cycle that leaves
    θ = 0 at speed ω lasts 2∫₀^θm dθ/θ̇ with θ̇² = ω² − 2p²[cos(α − θ) − cos α] (quadrature after
    θ = θm − s², which removes the 1/√ singularity at the peak θm); each impact multiplies θ̇ by
    e = 1 − 2 m b²/I_O. Mass properties from ``scene.planar_model()`` (symmetric pivots).
    """
    from scipy.integrate import quad

    pm = scene.planar_model()
    b, h = abs(pm.right[0]), abs(pm.right[1])
    r, alpha = math.hypot(b, h), math.atan2(b, h)
    i_o = pm.inertia + pm.mass * r * r
    p2 = pm.mass * scene.gravity * r / i_o
    e = 1.0 - 2.0 * pm.mass * b * b / i_o

    def rise(tm: float) -> float:
        def f(s: float) -> float:
            if s <= 0.0:
                return 2.0 / math.sqrt(2.0 * p2 * math.sin(alpha - tm))
            return 2.0 * s / math.sqrt(4.0 * p2 * math.sin(alpha - tm + 0.5 * s * s) * math.sin(0.5 * s * s))

        return float(quad(f, 0.0, math.sqrt(tm), epsabs=1e-13, epsrel=1e-11, limit=200)[0])

    th0 = abs(float(scene.theta0))
    t = rise(th0)
    w2 = 2.0 * p2 * (math.cos(alpha - th0) - math.cos(alpha))
    out: list[float] = []
    while t <= t_end:
        out.append(t)
        w2 *= e * e
        c = math.cos(alpha) + w2 / (2.0 * p2)
        tm = alpha - math.acos(min(c, 1.0))
        if tm < 1e-9:
            break
        t += 2.0 * rise(tm)
    return np.asarray(out)


def check_impacts(engine: str) -> dict[str, Any]:
    """Free rocking from θ0 = α/2 for 3 s (dt 1e-3): the standard diagnostics
    (:mod:`pbr_xval.diagnostics`) count the closed form's impacts ± 1 (11 for the Housner block;
    measured 11 for every engine), and every engine reports the same keys with the same energy
    normalisation: the barrier m g (R − h) and the start energy m g R [cos(α − θ0) − cos α]
    (closed form) within 0.5 % (measured ≤ 0.04 %).
    """
    from pbr_xval.diagnostics import DEFINITION, KEYS

    scene = compile_scene(
        housner_scenario(
            name="conformance_impacts",
            duration=3.0,
            excitation={"type": "none"},
            initial={"theta_over_alpha": 0.5},
        )
    )
    traj = run_scene(scene, engine, _settings(engine))
    assert traj.ok, traj.message
    d = traj.diagnostics
    missing = [k for k in KEYS if k not in d]
    assert not missing, f"{engine}: standard diagnostics missing: {missing}"
    assert d["diagnostics_definition"] == DEFINITION, f"{engine}: diagnostics {d['diagnostics_definition']!r}"
    ref = free_rocking_impact_times(scene, float(traj.t[-1]))
    assert abs(d["impacts"] - ref.size) <= 1, f"{engine}: {d['impacts']} impacts, closed form {ref.size}"
    pm = scene.planar_model()
    b, h = abs(pm.right[0]), abs(pm.right[1])
    r, alpha, mg = math.hypot(b, h), math.atan2(b, h), pm.mass * scene.gravity
    barrier = mg * (r - h)
    e0 = mg * r * (math.cos(alpha - abs(scene.theta0)) - math.cos(alpha))
    assert abs(d["energy_barrier_J"] / barrier - 1) <= 1e-9, f"{engine}: barrier {d['energy_barrier_J']} J"
    rel = d["energy_start_J"] / e0 - 1
    assert abs(rel) <= 5e-3, f"{engine}: start energy {d['energy_start_J']:.4f} J vs {e0:.4f} J ({rel:+.2%})"
    return {"impacts": d["impacts"], "reference": int(ref.size), "energy_start_rel_error": rel}


CHECKS: dict[str, Check] = {
    c.name: c
    for c in (
        Check("rest", check_rest),
        Check("housner_threshold", check_housner_threshold),
        Check("free_rocking_rebound", check_free_rocking_rebound),
        Check("mesh_box", check_mesh_box, frozenset({"mesh"})),
        Check("notched_block", check_notched_block, frozenset({"notched_block"})),
        Check("notched_rebound", check_notched_rebound, frozenset({"notched_block"})),
        Check("ground_modes", check_ground_modes, frozenset({"ground_modes"})),
        Check("deterministic", check_deterministic, frozenset({"deterministic"})),
        Check("impacts", check_impacts),
    )
}


def applicable(engine: str, check: Check) -> str | None:
    """None if ``check`` applies to ``engine``, else the reason it is skipped."""
    eng = get_engine(engine)
    caps = eng.capabilities
    if "box" not in caps.shapes:
        return "the engine does not model box rocks"
    for need in check.needs:
        if need in ("mesh", "notched_block") and need not in caps.shapes:
            return f"no {need} rocks"
        if need == "ground_modes" and "ground_motion" not in eng.default_settings():
            return "one ground-motion mode only (analytical)"
        if need == "deterministic" and not caps.deterministic:
            return "declared non-deterministic"
    return None
