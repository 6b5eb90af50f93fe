"""Rocking histories: every engine once on one scenario, overlaid and measured against the analytical run.

θ(t) (:meth:`Trajectory.rocking_angle`, normalised by the critical angle α of the side the
rock leans to) of all engines goes in one figure, the COM path (plan view x–y and side view
x–z) in another. Metrics per engine against the analytical reference trajectory
(``reference_engine``, default ``housner``; ``curved_base`` is tried when it does not apply),
all computed from the sampled trajectories so every engine is measured the same way:

* peak |θ| and its relative error;
* RMS of θ − θ_ref (θ_ref interpolated onto the engine's times) up to the reference's first
  impact (rad);
* uplift time: first time |θ| exceeds ``uplift_tol`` rad (the engine's own ``uplift`` event is
  reported beside it);
* impact times: the first three returns through θ = 0 after the rock has rocked
  (|θ| > ``impact_tol``·α between crossings), linearly interpolated;
* rebound ratios: the energy-equivalent method of :func:`pbr_xval.conformance.rebound_ratios`
  (needs a planar two-pivot model; NaN otherwise);
* energy drift: E = KE + PE of the rock in the pedestal frame, plus the work the inertial
  (d'Alembert) force of the pedestal motion has done, so E is constant between impacts in exact
  dynamics; the drift is the largest (max − min) of E within one inter-impact interval divided by
  the largest rocking energy KE + m·g·Δz in it.
"""

from __future__ import annotations

import itertools
import json
import math
import time
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from pbr_xval import units as _units
from pbr_xval.engine import EngineNotAvailable, NotApplicable, Trajectory, get_engine
from pbr_xval.scenario import Scenario
from pbr_xval.study.base import ANALYTICAL_ENGINES, Figure, StudyResult, reference_candidates

if TYPE_CHECKING:
    import pandas as pd

    from pbr_xval.scene import Scene

__all__ = [
    "HistoriesConfig",
    "energy_drift",
    "impact_times",
    "run",
    "theta_over_alpha",
    "uplift_time",
]

ANALYTICAL = ANALYTICAL_ENGINES  # (old name)
N_IMPACTS = 3


class HistoriesConfig(BaseModel):
    """Configuration of the histories study.

    Attributes
    ----------
    values : scenario keys to set before running (e.g. ``{"excitation.amplitude": 5.0}``).
    reference_engine : the analytical run every engine is measured against.
    settings : per-engine settings overrides (may contain ``profile``).
    uplift_tol : |θ| (rad) that counts as uplift.
    impact_tol : fraction of α |θ| must exceed between two returns through θ = 0.
    max_points : downsampling of the long-format θ table, per engine.
    toppling_run : also run every engine once with the intensity scaled by ``toppling_scale``
        (``excitation.amplitude``, else ``excitation.pgv``, else ``excitation.scale``), so the
        report shows a history that topples beside one that does not.
    """

    model_config = ConfigDict(extra="forbid")

    type: Literal["histories"] = "histories"
    values: dict[str, float] = Field(default_factory=dict)
    reference_engine: str | None = "housner"
    settings: dict[str, dict[str, Any]] = Field(default_factory=dict)
    uplift_tol: float = Field(1e-4, gt=0)
    impact_tol: float = Field(0.01, gt=0, lt=1)
    max_points: int = Field(2000, ge=10)
    toppling_run: bool = True
    toppling_scale: float = Field(1.25, gt=1.0)


# ------------------------------------------------------------------ measures
def theta_over_alpha(traj: Trajectory, alpha: tuple[float, float]) -> np.ndarray:
    """θ/α with α of the side the rock leans to (``alpha`` = (left, right) as in ``Scene.alpha``)."""
    th = traj.rocking_angle()
    return np.where(th >= 0, th / alpha[1], th / alpha[0])


def uplift_time(t: np.ndarray, theta: np.ndarray, tol: float) -> float:
    """First time |θ| ≥ ``tol`` (rad), NaN if never."""
    idx = np.nonzero(np.abs(theta) >= tol)[0]
    return float(t[idx[0]]) if idx.size else float("nan")


def impact_times(t: np.ndarray, theta: np.ndarray, tol: float, n: int | None = None) -> np.ndarray:
    """Times of the returns through θ = 0 after an excursion beyond ±``tol`` (rad).

    Consecutive samples with |θ| > tol are grouped into excursions; where two successive
    excursions have opposite signs, the last sign change of θ between them is the impact
    (linearly interpolated). A rock that comes back to rest and leaves again on the same side
    gives no impact.
    """
    big = np.abs(theta) > tol
    idx = np.nonzero(big)[0]
    out: list[float] = []
    if idx.size < 2:
        return np.zeros(0)
    sgn = np.sign(theta[idx])
    changes = np.nonzero(np.diff(sgn) != 0)[0]
    for k in changes:
        i0, i1 = idx[k], idx[k + 1]
        seg = theta[i0 : i1 + 1]
        s = np.sign(seg)
        flips = np.nonzero(s[:-1] * s[1:] <= 0)[0]
        j = i0 + (flips[-1] if flips.size else 0)
        a, b = theta[j], theta[j + 1]
        frac = a / (a - b) if a != b else 0.0
        out.append(float(t[j] + frac * (t[j + 1] - t[j])))
        if n is not None and len(out) >= n:
            break
    return np.asarray(out)


def energy_drift(
    traj: Trajectory, scene: Scene, impacts: np.ndarray, *, margin: int = 3, min_energy: float = 0.01
) -> float:
    """Largest relative change of the rock's energy between impacts (see the module docstring).

    E = ½ m |v|² + ½ ωᵀ I_w ω + m g z + W, with v from finite differences of the COM, I_w the
    inertia rotated to the world frame, and W = ∫ m a_g · v dt the work against the pedestal's
    inertial force. Samples within ``margin`` sample intervals of an impact are dropped, and so
    are intervals whose rocking energy stays below ``min_energy`` × the run's largest (the
    chatter of a rock coming to rest). NaN when no interval qualifies.
    """
    t = traj.t
    if t.size < 8:
        return float("nan")
    m = float(scene.rock.mass)
    g = float(scene.gravity)
    com = traj.com
    v = np.gradient(com, t, axis=0)
    rot = traj.rotation_matrices()
    i_body = np.asarray(scene.rock.inertia, dtype=float)
    iw = np.einsum("nij,jk,nlk->nil", rot, i_body, rot)
    w = traj.omega
    ke = 0.5 * m * np.einsum("ni,ni->n", v, v) + 0.5 * np.einsum("ni,nij,nj->n", w, iw, w)
    pe = m * g * (com[:, 2] - com[0, 2])
    ag = np.asarray(scene.excitation.acceleration(t), dtype=float)
    power = m * np.einsum("ni,ni->n", ag, v)
    work = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * np.diff(t))])
    e = ke + pe + work
    rock_e = ke + pe
    th = traj.rocking_angle()
    nz = np.nonzero(th != 0.0)[0]
    k = np.nonzero(np.sign(th[nz[:-1]]) != np.sign(th[nz[1:]]))[0]
    # every return through θ = 0 is a possible impact (chatter below the impact tolerance too)
    edges = np.unique(np.concatenate([[t[0]], impacts, t[nz[k]], t[nz[k + 1]], [t[-1]]]))
    worst = float("nan")
    dt = float(np.median(np.diff(t)))
    alive = np.ones(t.size, dtype=bool) if traj.toppled_at is None else t < traj.toppled_at
    floor = min_energy * float(np.max(rock_e[alive])) if alive.any() else 0.0
    for a, b in itertools.pairwise(edges):
        sel = (t > a + margin * dt) & (t < b - margin * dt)
        if traj.toppled_at is not None:
            sel &= t < traj.toppled_at
        if sel.sum() < 8:
            continue
        scale = float(np.max(rock_e[sel]))
        if scale <= max(floor, 1e-12):
            continue
        d = float((np.max(e[sel]) - np.min(e[sel])) / scale)
        worst = d if not math.isfinite(worst) else max(worst, d)
    return worst


def _interp(t_ref: np.ndarray, y_ref: np.ndarray, t: np.ndarray) -> np.ndarray:
    return np.interp(t, t_ref, y_ref, left=np.nan, right=np.nan)


def _downsample(n: int, k: int) -> np.ndarray:
    if n <= k:
        return np.arange(n)
    return np.unique(np.linspace(0, n - 1, k).round().astype(int))


# ------------------------------------------------------------------ study
INTENSITY_KEYS = ("excitation.amplitude", "excitation.pgv", "excitation.scale")


def toppling_values(cfg: HistoriesConfig, scenario: Scenario) -> tuple[dict[str, float], str] | None:
    """The study's values with the first intensity key of :data:`INTENSITY_KEYS` scaled up, and that key."""
    for key in INTENSITY_KEYS:
        try:
            base = float(cfg.values.get(key, scenario.get_value(key)))
        except Exception:
            continue
        return {**cfg.values, key: base * cfg.toppling_scale}, key
    return None


def _simulate(scene: Scene, name: str, settings: dict[str, Any] | None) -> tuple[Trajectory | None, str, str]:
    """(trajectory, status, message); status is ok | failed | skipped."""
    from pbr_xval.runner import run_scene

    try:
        get_engine(name)
    except EngineNotAvailable as exc:
        return None, "skipped", f"not available: {exc}"
    try:
        traj = run_scene(scene, name, settings)
    except NotApplicable as exc:
        return None, "skipped", f"not applicable: {exc}"
    except Exception as exc:
        return None, "failed", f"{type(exc).__name__}: {exc}"
    if not traj.ok:
        return traj, "failed", traj.message
    return traj, "ok", ""


_Run = tuple[Trajectory | None, str, str]  # (trajectory, status, message) of one engine


def run(
    config: HistoriesConfig,
    scenario: Scenario,
    engines: Sequence[str],
    *,
    progress: Callable[[str, float], None] | None = None,
) -> StudyResult:
    """Run every engine once and compare the histories; see the module docstring."""
    import pandas as pd

    from pbr_xval.scene import compile_scene

    t_start = time.perf_counter()
    scn = scenario
    for k, v in config.values.items():
        scn = scn.with_value(k, v)
    scene = compile_scene(scn)
    alpha = scene.alpha
    a_ref = min(alpha)
    order = list(dict.fromkeys(engines))
    notes: list[str] = []

    ref_name = config.reference_engine
    n_total = len(order) + (0 if (ref_name in order or not ref_name) else 1)
    tv = toppling_values(config, scenario) if config.toppling_run else None
    if tv is not None:
        n_total *= 2
    done = 0

    def sim(sim_scene: Scene, name: str, label: str) -> _Run:
        nonlocal done
        if progress is not None:
            progress(label, done / max(n_total, 1))
        out = _simulate(sim_scene, name, config.settings.get(name))
        done += 1
        return out

    runs, ref_used = _reference_and_runs(
        order, ref_name, lambda name: sim(scene, name, f"histories: {name}"), notes
    )
    shown = list(dict.fromkeys([*([ref_used] if ref_used else []), *order]))

    # the same engines at a higher intensity: a history that topples
    top_rows: list[dict[str, Any]] = []
    top_long: list[Any] = []
    top_key = ""
    top_value = float("nan")
    if tv is not None:
        top_vals, top_key = tv
        top_value = float(top_vals[top_key])
        tscn = scenario
        for k, v in top_vals.items():
            tscn = tscn.with_value(k, v)
        tscene = compile_scene(tscn)
        for name in shown:
            if runs[name][1] != "ok":
                continue
            traj, status, msg = sim(tscene, name, f"histories: {name} at {top_key} = {top_value:.4g}")
            _toppling_rows(traj, status, msg, name, top_key, top_value, alpha, config, top_rows, top_long)
    if progress is not None:
        progress("histories: metrics", 1.0)

    ref = runs[ref_used][0] if ref_used else None
    quantities = _quantities(runs, shown, scene, config, a_ref)
    ref_q: dict[str, Any] = quantities[ref_used] if ref is not None and ref_used in quantities else {}

    rows: list[dict[str, Any]] = []
    long_rows: list[pd.DataFrame] = []
    for name in shown:
        traj, status, msg = runs[name]
        q = quantities.get(name)
        if q is None or traj is None:
            rows.append({"engine": name, "status": status, "message": msg})
            continue
        rows.append(_metric_row(name, runs[name], q, ref, ref_q, scene, a_ref))
        keep = _downsample(traj.t.size, config.max_points)
        toa = np.where(q["theta"] >= 0, q["theta"] / alpha[1], q["theta"] / alpha[0])
        long_rows.append(pd.DataFrame({"t": traj.t[keep], "engine": name, "theta_over_alpha": toa[keep]}))

    metrics = pd.DataFrame(rows)
    theta_df = _theta_table(long_rows, shown, ref_used, ref, ref_q, alpha, quantities)
    top_df = pd.DataFrame(
        top_rows, columns=["engine", "status", "message", "param", "value", "toppled", "toppled_at_s"]
    )
    top_theta = (
        pd.concat(top_long, ignore_index=True)
        if top_long
        else pd.DataFrame(columns=["t", "engine", "theta_over_alpha"])
    )
    try:
        from pbr_xval.report.figures import ground_motion_table

        t_end = float(theta_df["t"].max()) if len(theta_df) else float(scene.duration)
        gm = ground_motion_table(scene, t_end)
    except Exception as exc:  # pragma: no cover - a ground-motion plot must not sink the study
        gm = None
        notes.append(f"ground motion not drawn: {type(exc).__name__}: {exc}")
    com_df = _com_table(runs, shown, config.max_points)

    for name in shown:
        _, status, msg = runs[name]
        if status == "skipped":
            notes.append(f"{name}: skipped ({msg})")
        elif status == "failed":
            notes.append(f"{name}: FAILED ({msg})")

    figs = [_theta_figure(theta_df, ref_used, scn.name, gm)]
    if len(top_theta):
        figs.append(_toppling_figure(top_theta, top_df, ref_used, top_key, top_value))
    figs.append(_com_figure(com_df, scn.name))
    summary = _summary(metrics, ref_used, scn, config)
    if len(top_df):
        summary.insert(1, _toppling_line(top_df, top_key, top_value, config))
    headline = {}
    for row in rows:
        if "peak_rel_error" in row:
            headline[row["engine"]] = {
                "peak_rel_error": _json_num(row["peak_rel_error"]),
                "rms_theta_err_to_impact1_rad": _json_num(row["rms_theta_err_to_impact1_rad"]),
            }
    return StudyResult(
        kind="histories",
        title=f"Rocking histories — {scn.name}",
        tables={
            "histories_metrics": metrics,
            "histories_theta": theta_df,
            "histories_com": com_df,
            **({"ground_motion": gm} if gm is not None else {}),
            **({"toppling_runs": top_df, "toppling_theta": top_theta} if len(top_df) else {}),
        },
        figures=figs,
        summary=summary,
        headline=headline,
        provenance={
            "scenario": scn.name,
            "scenario_hash": scn.content_hash(),
            "base_scenario_hash": scenario.content_hash(),
            "values": dict(config.values),
            "config": config.model_dump(mode="json"),
            "reference_engine": ref_used,
            "alpha_rad": list(alpha),
            "settings": {n: tr.settings for n in shown if (tr := runs[n][0]) is not None},
            "versions": {n: tr.versions for n in shown if (tr := runs[n][0]) is not None},
        },
        notes=notes,
        wall_time=time.perf_counter() - t_start,
    )


def _reference_and_runs(
    order: list[str], ref_name: str | None, sim: Callable[[str], _Run], notes: list[str]
) -> tuple[dict[str, _Run], str | None]:
    """Run the reference engine (or the first analytical one that applies), then every engine.

    Returns the runs by engine name and the reference engine used (None if none applies);
    appends to ``notes`` why a reference was not used.
    """
    runs: dict[str, _Run] = {}
    candidates = reference_candidates(ref_name)
    ref_used: str | None = None
    for cand in candidates:
        r = runs.get(cand) or sim(cand)
        if cand in order or r[1] == "ok":
            runs[cand] = r
        if r[1] == "ok":
            ref_used = cand
            if cand not in order:
                notes.append(f"reference engine {cand!r} run in addition to the engines compared")
            break
        notes.append(f"reference engine {cand!r} not used: {r[2]}")
        if not r[2].startswith("not applicable"):
            break
    if ref_used and ref_name and ref_used != ref_name:
        notes.append(f"reference engine {ref_name!r} does not apply; using {ref_used!r}")
    for name in order:
        if name not in runs:
            runs[name] = sim(name)
    return runs, ref_used


def _toppling_rows(
    traj: Trajectory | None,
    status: str,
    msg: str,
    name: str,
    top_key: str,
    top_value: float,
    alpha: tuple[float, float],
    config: HistoriesConfig,
    top_rows: list[dict[str, Any]],
    top_long: list[Any],
) -> None:
    """Append one engine's run at the toppling intensity to the table and the θ/α histories."""
    import pandas as pd

    top_rows.append(
        {
            "engine": name,
            "status": status,
            "message": msg,
            "param": top_key,
            "value": top_value,
            "toppled": bool(traj.toppled) if traj is not None and status == "ok" else None,
            "toppled_at_s": _nan(traj.toppled_at) if traj is not None and status == "ok" else float("nan"),
        }
    )
    if traj is not None and status == "ok" and traj.t.size:
        keep = _downsample(traj.t.size, config.max_points)
        top_long.append(
            pd.DataFrame(
                {
                    "t": traj.t[keep],
                    "engine": name,
                    "theta_over_alpha": theta_over_alpha(traj, alpha)[keep],
                }
            )
        )


def _quantities(
    runs: dict[str, _Run], shown: list[str], scene: Scene, config: HistoriesConfig, a_ref: float
) -> dict[str, dict[str, Any]]:
    """Per engine that ran: θ history, peak, uplift time, impacts, rebound ratios, energy drift."""
    from pbr_xval.conformance import rebound_ratios

    quantities: dict[str, dict[str, Any]] = {}
    for name in shown:
        traj, status, _msg = runs[name]
        if status != "ok" or traj is None or traj.t.size == 0:
            continue
        th = traj.rocking_angle()
        imp = impact_times(traj.t, th, config.impact_tol * a_ref)
        try:
            ratios = rebound_ratios(traj, scene)
        except NotApplicable:
            ratios = np.zeros(0)
        except Exception:
            ratios = np.zeros(0)
        quantities[name] = {
            "theta": th,
            "peak": float(np.max(np.abs(th))),
            "uplift": uplift_time(traj.t, th, config.uplift_tol),
            "uplift_event": next((e.t for e in traj.events if e.kind == "uplift"), float("nan")),
            "impacts": imp,
            "ratios": ratios,
            "drift": energy_drift(traj, scene, imp),
        }
    return quantities


def _metric_row(
    name: str,
    run_: _Run,
    q: dict[str, Any],
    ref: Trajectory | None,
    ref_q: dict[str, Any],
    scene: Scene,
    a_ref: float,
) -> dict[str, Any]:
    """One engine's row of ``histories_metrics``: its quantities and their differences to the reference."""
    traj, status, msg = run_
    assert traj is not None
    row: dict[str, Any] = {"engine": name, "status": status, "message": msg}
    try:  # what the rock did: rocked, slid, jumped (the standard diagnostics)
        from pbr_xval.diagnostics import ensure_standard_diagnostics

        ensure_standard_diagnostics(traj, scene)
        regime, slip = traj.regime, traj.diagnostics.get("slip_max_m")
    except Exception:  # a diagnostic must not sink the study
        regime, slip = "", None
    row.update(
        {
            "profile": str(traj.settings.get("profile", "")),
            "regime": regime,
            "slip_max_m": float("nan") if slip is None else float(slip),
            "toppled": traj.toppled,
            "toppled_at_s": _nan(traj.toppled_at),
            "peak_theta_rad": q["peak"],
            "peak_theta_over_alpha": q["peak"] / a_ref,
            "uplift_t_s": q["uplift"],
            "uplift_event_t_s": q["uplift_event"],
        }
    )
    for i in range(N_IMPACTS):
        row[f"impact{i + 1}_t_s"] = float(q["impacts"][i]) if q["impacts"].size > i else float("nan")
    for i in range(N_IMPACTS):
        row[f"rebound{i + 1}"] = float(q["ratios"][i]) if q["ratios"].size > i else float("nan")
    row["energy_drift_rel"] = q["drift"]
    if ref_q and ref is not None:
        row["peak_rel_error"] = q["peak"] / ref_q["peak"] - 1.0 if ref_q["peak"] > 0 else float("nan")
        t_end = float(ref_q["impacts"][0]) if ref_q["impacts"].size else float(ref.t[-1])
        sel = traj.t <= t_end
        th_ref = _interp(ref.t, ref_q["theta"], traj.t[sel])
        diff = q["theta"][sel] - th_ref
        diff = diff[np.isfinite(diff)]
        row["rms_theta_err_to_impact1_rad"] = float(np.sqrt(np.mean(diff**2))) if diff.size else float("nan")
        row["uplift_dt_s"] = q["uplift"] - ref_q["uplift"]
        for i in range(N_IMPACTS):
            row[f"impact{i + 1}_dt_s"] = row[f"impact{i + 1}_t_s"] - (
                float(ref_q["impacts"][i]) if ref_q["impacts"].size > i else float("nan")
            )
        for i in range(N_IMPACTS):
            row[f"rebound{i + 1}_diff"] = row[f"rebound{i + 1}"] - (
                float(ref_q["ratios"][i]) if ref_q["ratios"].size > i else float("nan")
            )
    row["wall_s"] = traj.wall_time
    row["settings"] = json.dumps(traj.settings, sort_keys=True, default=str)
    row["versions"] = json.dumps(traj.versions, sort_keys=True, default=str)
    return row


def _theta_table(
    long_rows: list[Any],
    shown: list[str],
    ref_used: str | None,
    ref: Trajectory | None,
    ref_q: dict[str, Any],
    alpha: tuple[float, float],
    quantities: dict[str, dict[str, Any]],
) -> pd.DataFrame:
    """``histories_theta``: θ/α of every engine and its difference to the reference's."""
    import pandas as pd

    theta_df = (
        pd.concat(long_rows, ignore_index=True)
        if long_rows
        else pd.DataFrame(columns=["t", "engine", "theta_over_alpha"])
    )
    theta_df["dtheta_over_alpha"] = np.nan
    if ref_used is not None and ref_used in quantities and ref is not None:
        ref_toa = np.where(ref_q["theta"] >= 0, ref_q["theta"] / alpha[1], ref_q["theta"] / alpha[0])
        for name in shown:
            if name == ref_used:
                continue
            sel = (theta_df["engine"] == name).to_numpy()
            if sel.any():
                tt = theta_df.loc[sel, "t"].to_numpy(float)
                theta_df.loc[sel, "dtheta_over_alpha"] = theta_df.loc[sel, "theta_over_alpha"].to_numpy(
                    float
                ) - _interp(ref.t, ref_toa, tt)
    return theta_df


def _toppling_line(top_df: pd.DataFrame, top_key: str, top_value: float, config: HistoriesConfig) -> str:
    """The summary line of the runs at the toppling intensity: who topples (when), who stands."""
    okt = top_df[top_df["status"] == "ok"]
    tops = okt[okt["toppled"].astype(bool)]
    stands = okt[~okt["toppled"].astype(bool)]
    line = f"At {_units.label(top_key, with_unit=False)} = {top_value:.4g} {_units.unit(top_key)} ({config.toppling_scale:g}×): "
    if len(tops):
        line += (
            f"{', '.join(tops['engine'])} topple (t = {tops['toppled_at_s'].min():.3f}–"
            f"{tops['toppled_at_s'].max():.3f} s)"
        )
    if len(stands):
        line += ("; " if len(tops) else "") + f"{', '.join(stands['engine'])} stand"
    return line + "."


def _nan(x: float | None) -> float:
    return float("nan") if x is None else float(x)


def _json_num(x: float) -> float | None:
    return None if x is None or not math.isfinite(x) else float(x)


def _com_table(runs: dict[str, Any], shown: list[str], k: int) -> Any:
    import pandas as pd

    parts = []
    for name in shown:
        traj = runs[name][0]
        if traj is None or runs[name][1] != "ok" or traj.t.size == 0:
            continue
        keep = _downsample(traj.t.size, k)
        parts.append(
            pd.DataFrame(
                {
                    "t": traj.t[keep],
                    "engine": name,
                    "com_x_m": traj.com[keep, 0],
                    "com_y_m": traj.com[keep, 1],
                    "com_z_m": traj.com[keep, 2],
                }
            )
        )
    return (
        pd.concat(parts, ignore_index=True)
        if parts
        else pd.DataFrame(columns=["t", "engine", "com_x_m", "com_y_m", "com_z_m"])
    )


def _fmt(x: Any, spec: str) -> str:
    try:
        xf = float(x)
    except (TypeError, ValueError):
        return "—"
    return "—" if not math.isfinite(xf) else format(xf, spec)


def _summary(metrics: Any, ref_used: str | None, scn: Scenario, cfg: HistoriesConfig) -> list[str]:
    vals = ", ".join(f"{k} = {v:g}" for k, v in cfg.values.items()) or "as given"
    out = [
        f"**Rocking histories** of `{scn.name}` ({vals}); reference: {ref_used or 'none'}",
        "",
        "| engine | peak θ/α | peak err | RMS θ err to 1st impact (rad) | uplift s | 1st impact s | "
        "rebound 1 | energy drift | wall s |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for _, r in metrics.iterrows():
        if r.get("status") != "ok":
            out.append(f"| {r['engine']} | {r.get('status')} | | | | | | | |")
            continue
        pe = r.get("peak_rel_error", float("nan"))
        out.append(
            f"| {r['engine']} | {_fmt(r['peak_theta_over_alpha'], '.4f')} | "
            f"{'—' if not math.isfinite(pe) else f'{pe:+.2%}'} | "
            f"{_fmt(r.get('rms_theta_err_to_impact1_rad'), '.2e')} | {_fmt(r['uplift_t_s'], '.4f')} | "
            f"{_fmt(r['impact1_t_s'], '.4f')} | {_fmt(r['rebound1'], '.4f')} | "
            f"{_fmt(r['energy_drift_rel'], '.2e')} | {_fmt(r['wall_s'], '.2f')} |"
        )
    return out


def _theta_figure(df: Any, ref_used: str | None, name: str, gm: Any = None) -> Figure:
    from pbr_xval.report.figures import plot_ground_motion
    from pbr_xval.report.style import engine_style, figure, rc

    fig = figure(figsize=(12, 4.8))
    with rc():
        gs = fig.add_gridspec(3, 2, width_ratios=[2.3, 1.0], height_ratios=[1.0, 1.0, 0.9])
        ax = fig.add_subplot(gs[0:2, 0])
        axd = fig.add_subplot(gs[2, 0], sharex=ax)
        for eng, sub in df.groupby("engine", sort=False):
            st = engine_style(str(eng), ref_used)
            ax.plot(
                sub["t"],
                sub["theta_over_alpha"],
                label=f"{eng} (reference)" if eng == ref_used else str(eng),
                **st,
            )
            if eng != ref_used and sub["dtheta_over_alpha"].notna().any():
                axd.plot(sub["t"], sub["dtheta_over_alpha"], color=st["color"], lw=1.1, label=str(eng))
        for y in (-1.0, 1.0):
            ax.axhline(y, color="0.5", lw=0.8, ls=":")
        ax.set_ylabel("θ / α [–]")
        ax.set_title(f"rocking angle θ/α — {name}")
        ax.legend(fontsize=8, ncol=2, loc="upper right")
        ax.tick_params(labelbottom=False)
        if not df["dtheta_over_alpha"].notna().any():
            axd.text(
                0.5,
                0.5,
                "no analytical reference applies: no difference panel",
                transform=axd.transAxes,
                ha="center",
                va="center",
                color="0.4",
            )
        axd.axhline(0.0, color="k", lw=0.8)
        axd.set_ylabel(f"(θ − θ_{ref_used or 'ref'}) / α", fontsize=9)
        axd.set_xlabel("t [s]")
        axd.set_title("difference to the reference", fontsize=10)
        if gm is not None:
            ga = [fig.add_subplot(gs[i, 1]) for i in range(3)]
            for g in ga[1:]:
                g.sharex(ga[0])
            plot_ground_motion(ga, gm)
        for a in fig.get_axes():
            a.grid(True, alpha=0.3, lw=0.6)
    return Figure(
        name="histories_theta",
        figure=fig,
        table="histories_theta",
        caption="Left: rocking angle θ normalised by the critical angle α of the side the rock leans to "
        + (
            f"(black: the analytical reference {ref_used}; dotted: ±1, toppling); below, each engine's "
            "difference to the reference on the engine's own times. "
            if ref_used
            else "(dotted: ±1, toppling; no analytical reference applies to this rock). "
        )
        + "Right: the ground motion along the shaking direction (acceleration, velocity, displacement; "
        "data in the ground_motion table).",
    )


def _toppling_figure(df: Any, runs: Any, ref_used: str | None, key: str, value: float) -> Figure:
    from pbr_xval.report.style import engine_style, subplots

    fig, ax = subplots(figsize=(6.0, 3.4))
    for eng, sub in df.groupby("engine", sort=False):
        st = engine_style(str(eng), ref_used)
        y = sub["theta_over_alpha"].clip(-1.6, 1.6)
        ax.plot(sub["t"], y, label=str(eng), **st)
        r = runs[runs["engine"] == eng]
        if len(r) and bool(r["toppled"].iloc[0]) and math.isfinite(float(r["toppled_at_s"].iloc[0])):
            ax.axvline(float(r["toppled_at_s"].iloc[0]), color=st["color"], lw=0.8, ls=":")
    for y0 in (-1.0, 1.0):
        ax.axhline(y0, color="0.5", lw=0.8, ls=":")
    ax.set_ylim(-1.7, 1.7)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("θ / α [–] (clipped at ±1.6)")
    ax.set_title(f"a toppling history: {_units.label(key, with_unit=False)} = {value:.4g} {_units.unit(key)}")
    ax.legend(fontsize=8, loc="lower left")
    return Figure(
        name="toppling_theta",  # = its table: one CSV
        figure=fig,
        table="toppling_theta",
        caption="The same engines at a higher intensity: θ/α until the rock topples (|θ/α| = 1; vertical "
        "dotted lines: each engine's toppling time).",
    )


def _com_figure(df: Any, name: str) -> Figure:
    from pbr_xval.report.style import engine_colour, subplots

    fig, (a1, a2) = subplots(1, 2, figsize=(6.4, 3.4))
    for eng, sub in df.groupby("engine", sort=False):
        c = engine_colour(str(eng))
        x = (sub["com_x_m"] - sub["com_x_m"].iloc[0]) * 1e3
        y = (sub["com_y_m"] - sub["com_y_m"].iloc[0]) * 1e3
        z = (sub["com_z_m"] - sub["com_z_m"].iloc[0]) * 1e3
        a1.plot(x, y, color=c, lw=1.2, label=str(eng))
        a2.plot(x, z, color=c, lw=1.2, label=str(eng))
    a1.set_aspect("equal", adjustable="datalim")  # x and y on one scale: a 60 µm drift looks like one
    a1.set_xlabel("Δx [mm]")
    a1.set_ylabel("Δy [mm]")
    a1.set_title("COM, plan view (equal axes)", fontsize=10)
    a2.set_xlabel("Δx [mm]")
    a2.set_ylabel("Δz [mm]")
    a2.set_title("COM, side view", fontsize=10)
    a1.legend(fontsize=7)
    return Figure(
        name="histories_com",
        figure=fig,
        table="histories_com",
        caption=f"Centre-of-mass displacement from its start in the pedestal frame ({name}); the plan view "
        "has equal x and y scales.",
    )
