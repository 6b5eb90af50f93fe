"""The threshold search says exactly what it knows, and the default toppling decision is physical.

References: the Housner half-sine threshold 5.638 m/s² (Veeraraghavan & Krishnan: 5.62–5.64; the
exact nonlinear equation, science.md §0); the uplift bound g·tan α (closed form); the free-rocking
amplitude decay with a prescribed impact velocity ratio η (science.md §1.5, closed form in the
test); for the safe band above the first overturning level, the 3-D engines against the analytical
`housner` engine.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from pbr_xval.cli import app
from pbr_xval.conformance import free_rocking_scenario, housner_scenario
from pbr_xval.engine import EngineSettingsError
from pbr_xval.runner import run_scenario
from pbr_xval.scenario import load_scenario
from pbr_xval.study.threshold_search import find_threshold

ROOT = Path(__file__).resolve().parents[2]
HOUSNER = ROOT / "examples" / "housner_halfsine.toml"
PUBLISHED = 5.638  # m/s², exact nonlinear value (paper: 5.62–5.64)
ALPHA = math.atan(0.2 / 0.6)
G = 9.81
runner = CliRunner()


def _check_transitions(res) -> None:
    """Every transition is bracketed by two direct runs of opposite outcome within rel_tol."""
    for tr in res.transitions:
        assert tr.lo_run is not None and tr.hi_run is not None
        assert tr.lo_run.value == tr.lo and tr.hi_run.value == tr.hi
        assert tr.lo_run.simulated and tr.hi_run.simulated
        assert tr.lo_run.toppled == tr.below_toppled and tr.hi_run.toppled != tr.below_toppled
        assert tr.hi - tr.lo <= res.rel_tol * tr.hi * (1 + 1e-9)


# Measured (this machine, default settings, rel_tol 1e-3): 13 simulations each; minimum housner
# +0.014 %, mujoco +0.026 %, dart +0.015 %, pybullet −0.108 % against 5.638. Tolerances: the issue's
# ±0.05 % (analytical) and ±0.2 % (engines), ≥ 2× the measured errors.
@pytest.mark.parametrize(
    ("engine", "tol"), [("housner", 5e-4), ("mujoco", 2e-3), ("dart", 2e-3), ("pybullet", 2e-3)]
)
def test_housner_threshold_in_at_most_15_simulations(engine: str, tol: float) -> None:
    res = find_threshold(load_scenario(HOUSNER), engine, rel_tol=1e-3)
    assert res.status == "bracketed", res.message()
    assert abs(res.minimum / PUBLISHED - 1) <= tol, res.minimum
    assert res.n_simulations <= 15, res.n_simulations  # the goal (issue 15)
    # README "simulations per threshold": 13 for each engine. Exact for the analytical engine (a
    # sign error in the secant step costs 15 and still brackets the threshold); the 3-D engines
    # get one simulation of margin, as their outcomes near the threshold may move across CPUs.
    if engine == "housner":
        assert res.n_simulations == 13, res.n_simulations
    else:
        assert res.n_simulations <= 14, res.n_simulations
    _check_transitions(res)
    # the physics bound: g·tan α = g/3 for this block, below which nothing was simulated
    assert res.lower_bound == pytest.approx(G / 3, rel=1e-9)
    assert all(not r.simulated for r in res.runs if r.value <= res.lower_bound)
    assert res.unit == "m/s²" and res.criterion["criterion"] == "physical"


# The exact threshold of this block (the `housner` engine, conformance.PlanarBlock: 5.63805; the
# paper: 5.638) and where the default search (rel_tol 1e-3) puts it: the midpoint of its last
# bracket, 5.638760 on every machine tried (an analytical ODE, no contact solver). A mutated secant
# step lands elsewhere in the bracket (5.63843) after 15 simulations.
EXACT = 5.63805
SEARCH_MIDPOINT = 5.6387598


def test_housner_search_result_is_pinned() -> None:
    res = find_threshold(load_scenario(HOUSNER), "housner", rel_tol=1e-3)
    (tr,) = res.transitions
    assert tr.lo <= EXACT <= tr.hi  # the bracket holds the exact value
    assert res.minimum == pytest.approx(SEARCH_MIDPOINT, abs=1e-5)  # tighter than the 6e-5 a bug moves it
    assert abs(res.minimum / EXACT - 1) < 1e-3  # within rel_tol of the exact value
    # `pbr-xval threshold --json` writes this dict: every key, and the figures above in it
    d = res.to_dict()
    assert list(d) == [
        "param", "unit", "engine", "status", "message", "minimum", "tolerance", "rel_tol", "lo", "hi",
        "lower_bound", "resolution", "bands", "transitions", "runs", "n_simulations", "settings",
        "versions", "scenario_hash", "criterion", "wall_time", "max_tilt_rad",
    ]  # fmt: skip
    assert (d["engine"], d["minimum"], d["n_simulations"]) == ("housner", res.minimum, 13)
    assert (d["lo"], d["hi"]) == (res.lo, res.hi) and len(d["runs"]) == len(res.runs)
    assert d["bands"] == [b.__dict__ for b in res.bands()] and d["bands"]


def test_uplift_bound_only_for_a_parameter_that_scales_the_pga() -> None:
    """The search starts at g·tan α only when the parameter scales the PGA linearly (the bound
    would be wrong for a frequency); a motion without a stated PGA is sampled for it."""
    import types

    from pbr_xval.study.threshold_search import _pga, uplift_lower_bound

    scn = load_scenario(HOUSNER)
    assert uplift_lower_bound(scn, "excitation.amplitude") == pytest.approx(G / 3, rel=1e-9)
    assert uplift_lower_bound(scn, "excitation.frequency") is None
    motion = types.SimpleNamespace(acceleration=lambda t: -4.0 * np.sin(2 * np.pi * t / 2.0) ** 3)
    scene = types.SimpleNamespace(excitation=types.SimpleNamespace(horizontal=motion, duration=2.0))
    assert _pga(scene) == pytest.approx(4.0, rel=1e-6)


def _one_cosine(**kw):
    return housner_scenario(
        duration=3.0, excitation={"type": "one_cosine", "amplitude": 12.0, "frequency": 2.0}, **kw
    )


# Measured band edges (default settings, rel_tol 1e-3, lo 8, hi 24): housner 10.876–16.047,
# mujoco 11.135–15.166, dart 10.829–16.09 m/s². MuJoCo's upper edge is fuzzy (narrow sub-bands:
# 15.17–15.95 depending on the grid, −5.5 % to −0.6 %; its soft impacts lose a little more energy
# in the mode-1 overturning after one impact); tolerance 8 %.
@pytest.mark.parametrize("engine", ["housner", "mujoco", "dart"])
def test_safe_band_above_first_overturning_level(engine: str) -> None:
    """One-cosine (Makris–Roussos type B) pulse at 2 Hz: topples in a band, then a safe band."""
    res = find_threshold(_one_cosine(), engine, lo=8.0, hi=24.0, rel_tol=1e-3)
    assert res.status == "bracketed", res.message()
    bands = res.bands()
    assert len(bands) == 1 and bands[0].end is not None, bands  # the band ends: safe above it
    _check_transitions(res)
    start, end = bands[0].start, bands[0].end
    if engine == "housner":
        # docs/toppling.md's band 10.88–16.05, pinned as the search finds it (an analytical ODE: the
        # same on every machine): a mutated probe on the band's upper edge costs 28 simulations
        # and moves that edge by 3e-4
        assert (start, end) == pytest.approx((10.876067, 16.047130), abs=5e-5)
        assert res.n_simulations == 23, res.n_simulations
    ref = find_threshold(_one_cosine(), "housner", lo=8.0, hi=24.0, rel_tol=1e-3).bands()[0]
    assert start == pytest.approx(ref.start, rel=0.08) and end == pytest.approx(ref.end, rel=0.08)
    assert 10.0 < start < 12.0 and 15.0 < end < 17.0
    # inside the safe band the block passes α and the reversing pulse pulls it back: the physical
    # decision says "stands", the first-crossing rule would have said "topples"
    a = 35.0
    phys = run_scenario(_one_cosine().with_value("excitation.amplitude", a), engine)
    assert not phys.toppled and np.max(np.abs(phys.rocking_angle())) > 1.2 * ALPHA
    first = run_scenario(
        _one_cosine(toppling={"criterion": "critical_tilt"}).with_value("excitation.amplitude", a), engine
    )
    assert first.toppled


def test_lowest_value_toppling_prints_no_minimum(tmp_path: Path) -> None:
    res = find_threshold(load_scenario(HOUSNER), "housner", lo=6.0, hi=8.0)
    assert res.status == "topples_at_lo" and res.minimum is None and res.tolerance is None
    assert "lower --lo" in res.message() and res.bands()[0].start is None
    out = tmp_path / "r.json"
    cli = runner.invoke(
        app, ["threshold", str(HOUSNER), "--engine", "housner", "--lo", "6", "--hi", "8", "--json", str(out)]
    )
    assert cli.exit_code == 3, cli.output
    assert "minimum toppling" not in cli.output and "already topples" in cli.output
    assert json.loads(out.read_text())["minimum"] is None


def test_never_toppling_says_how_close_it_came() -> None:
    res = find_threshold(load_scenario(HOUSNER), "housner", lo=3.5, hi=5.4, n_grid=3)
    assert res.status == "never_toppled" and res.minimum is None
    assert 0.3 < res.max_peak_ratio < 1.0 and "raise --hi" in res.message()
    cli = runner.invoke(
        app, ["threshold", str(HOUSNER), "--engine", "housner", "--lo", "3.5", "--hi", "5.4", "--n-grid", "3"]
    )
    assert cli.exit_code == 4, cli.output
    assert "never toppled" in cli.output and "θ/α" in cli.output


def test_units_for_every_parameter() -> None:
    cli = runner.invoke(
        app,
        [
            *("threshold", str(HOUSNER), "--engine", "housner", "--param", "excitation.frequency"),
            *("--lo", "0.5", "--hi", "2", "--n-grid", "3", "--rel-tol", "0.01"),
        ],
    )
    assert cli.exit_code in (0, 3, 4), cli.output
    assert "Hz" in cli.output


def test_bad_search_input_is_refused_before_simulating() -> None:
    with pytest.raises(ValueError, match="n_grid"):
        find_threshold(load_scenario(HOUSNER), "housner", n_grid=1)
    with pytest.raises(ValueError, match="lo < hi"):
        find_threshold(load_scenario(HOUSNER), "housner", lo=8.0, hi=6.0)


def _peaks(traj) -> np.ndarray:
    th = np.abs(traj.rocking_angle())
    k = [i for i in range(1, th.size - 1) if th[i] >= th[i - 1] and th[i] > th[i + 1] and th[i] > 1e-3]
    return th[k]


@pytest.mark.parametrize("eta", [0.6, 0.85, 0.95])
def test_impact_velocity_ratio_reproduces_free_rocking_decay(eta: float) -> None:
    """science.md §1.5 with r = η²: linearized φ_n = 1 − √(1 − η²ⁿ[1 − (1 − φ₀)²]); exact (nonlinear)
    cos(α − θ_{n+1}) − cos α = η²[cos(α − θ_n) − cos α] (energy between impacts is conserved)."""
    phi0 = 0.5
    scn = free_rocking_scenario(duration=4.0)
    lin = run_scenario(scn, "housner", {"variant": "linearized", "impact_ratio": eta})
    n = np.arange(1, 4)
    expected = 1 - np.sqrt(1 - eta ** (2 * n) * (1 - (1 - phi0) ** 2))
    got = _peaks(lin)[:3] / ALPHA
    assert got == pytest.approx(expected, rel=2e-3)  # peaks read off the 1 ms output grid
    assert all(e.data["ratio"] == eta for e in lin.events if e.kind == "impact")
    exact = run_scenario(scn, "housner", {"impact_ratio": eta})
    c = [math.cos(ALPHA - phi0 * ALPHA) - math.cos(ALPHA)]
    for _ in range(3):
        c.append(eta**2 * c[-1])
    theta_exact = ALPHA - np.arccos(np.array(c[1:]) + math.cos(ALPHA))
    assert _peaks(exact)[:3] == pytest.approx(theta_exact, rel=2e-3)


def test_impact_ratio_default_and_bad_values() -> None:
    traj = run_scenario(free_rocking_scenario(duration=2.0), "housner")
    ratios = [e.data["ratio"] for e in traj.events if e.kind == "impact"]
    assert ratios and all(r == pytest.approx(1 - 1.5 * math.sin(ALPHA) ** 2, abs=1e-12) for r in ratios)
    with pytest.raises(EngineSettingsError, match="impact_ratio"):
        run_scenario(free_rocking_scenario(duration=1.0), "housner", {"impact_ratio": 1.3})


def test_criterion_is_recorded_in_provenance() -> None:
    traj = run_scenario(load_scenario(HOUSNER).with_value("excitation.amplitude", 6.0), "mujoco")
    meta = traj.metadata()
    assert meta["scene_info"]["toppling"]["criterion"] == "physical"
    assert "cannot return" in meta["scene_info"]["toppling"]["definition"]
    ev = next(e for e in traj.events if e.kind == "toppled")
    assert ev.data["decided_at"] >= ev.t and ev.data["rule"]


SP1 = ROOT.parent / "shared" / "data" / "scans" / "SP1_mesh.obj"


@pytest.mark.skipif(not SP1.exists(), reason="shared scan data (../shared/data/scans) not present")
def test_scanned_rock_band_edges_are_confirmed(tmp_path: Path) -> None:
    """SP1, stable pose, 1 Hz half-sine, μ 0.7/0.6, 3–40 m/s²: every reported edge is bracketed by
    direct runs that are part of the result."""
    scn = tmp_path / "sp1.toml"
    scn.write_text(
        f"""name = "sp1_halfsine"
duration = 4.0
settle_time = 0.5
output_dt = 0.002
[rock]
shape = "mesh"
path = "{SP1.as_posix()}"
density = 2700.0
pose = "stable"
[pedestal]
kind = "plane"
[contact]
friction_static = 0.7
friction_dynamic = 0.6
restitution = 0.0
[excitation]
type = "half_sine"
amplitude = 10.0
frequency = 1.0
"""
    )
    out = tmp_path / "r.json"
    cli = runner.invoke(
        app, ["threshold", str(scn), "--engine", "mujoco", "--lo", "3", "--hi", "40", "--json", str(out)]
    )
    assert cli.exit_code in (0, 3, 4), cli.output
    data = json.loads(out.read_text())
    runs = {r["value"]: r["toppled"] for r in data["runs"]}
    for tr in data["transitions"]:
        below, above = tr["confirm_below"], tr["confirm_above"]
        assert runs[below["value"]] == tr["below_toppled"] and runs[above["value"]] != tr["below_toppled"]
        assert above["value"] - below["value"] <= data["rel_tol"] * above["value"] * (1 + 1e-9)
    for band in data["bands"]:
        for edge in (band["start"], band["end"]):
            if edge is not None:
                assert any(t["lo"] <= edge <= t["hi"] for t in data["transitions"])
    assert "resolution" in cli.output
