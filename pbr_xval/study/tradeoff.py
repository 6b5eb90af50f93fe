"""Speed–accuracy trade: what does each engine's threshold cost at a given accuracy?

For every engine × settings point (time step × profile × solver iterations × extra variants)
the toppling threshold of ``param`` is found by a narrow geometric scan plus bisection
(:func:`pbr_xval.study.threshold_search.find_threshold`, only the first stand→topple transition)
in a worker process (:mod:`pbr_xval.study.workers`: a crash or hang is a recorded point, not
a dead study). Each point gets its relative error against the reference (an analytical value
or the reference engine's threshold) and its cost: wall time per simulation and for the
whole search. The Pareto front per engine is the set of non-dominated points in
(wall time per simulation, |error|); the recommendation per engine and error budget is the
cheapest point whose |error| is within the budget.

Points whose predicted cost exceeds ``max_wall_per_point`` (extrapolated from the cost per
simulation of the previous, coarser time step of the same engine/variant, ∝ 1/dt) are
skipped and recorded with the reason.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from pbr_xval.scenario import Scenario
from pbr_xval.study.base import Figure, StudyResult, clamped_progress

__all__ = ["TradeoffConfig", "pareto_front", "recommend", "run", "threshold_point"]

#: solver-iteration setting of each engine (where one exists)
ITERATION_KEYS: dict[str, str] = {
    "pybullet": "num_solver_iterations",
    "mujoco": "iterations",
    "reference": "iterations",
    "dart": "pgs_iterations",
}


class TradeoffConfig(BaseModel):
    """Speed–accuracy trade study."""

    model_config = ConfigDict(extra="forbid")

    type: Literal["tradeoff"] = "tradeoff"
    param: str = "excitation.amplitude"
    reference: float | None = Field(
        None, description="reference threshold (e.g. 5.638); None: the reference engine's"
    )
    reference_engine: str = "housner"
    timesteps: list[float] = Field(default_factory=lambda: [1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 1e-4, 1e-5])
    iterations: dict[str, list[int]] = Field(
        default_factory=lambda: {"pybullet": [10], "mujoco": [10]},
        description="extra solver-iteration values per engine (key from ITERATION_KEYS)",
    )
    profiles: list[str] = Field(default_factory=lambda: ["faithful", "engine-default"])
    extra: list[dict[str, Any]] = Field(
        default_factory=list, description="more settings variants, e.g. {'collision': 'hull'}"
    )
    lo: float | None = Field(None, description="scan start; default 0.8 × reference")
    hi: float | None = Field(None, description="scan end; default 1.25 × reference")
    n_grid: int = Field(5, ge=2)
    rel_tol: float = 5e-4
    budgets: list[float] = Field(default_factory=lambda: [0.005, 0.01, 0.02])
    max_wall_per_point: float = Field(600.0, description="skip points predicted to take longer (s)")
    timeout_per_point: float = Field(1800.0, description="kill a search after this long (s)")
    max_workers: int = Field(1, ge=1)


# ----------------------------------------------------------------- pure helpers
def pareto_front(cost: Sequence[float], error: Sequence[float]) -> np.ndarray:
    """Boolean mask of the non-dominated points (minimising both ``cost`` and ``error``).

    A point is dominated when another is no worse in both and strictly better in one.
    Non-finite points are never on the front.
    """
    c = np.asarray(cost, dtype=float)
    e = np.asarray(error, dtype=float)
    ok = np.isfinite(c) & np.isfinite(e)
    mask = np.zeros(c.size, dtype=bool)
    for i in np.nonzero(ok)[0]:
        dominated = ok & (c <= c[i]) & (e <= e[i]) & ((c < c[i]) | (e < e[i]))
        mask[i] = not dominated.any()
    return mask


def recommend(
    points: Any, budgets: Sequence[float], *, cost: str = "wall_s_per_sim", error: str = "abs_rel_error"
) -> Any:
    """Per engine and budget: the cheapest point with |error| ≤ budget (a DataFrame row per pair).

    ``points`` is a DataFrame with columns ``engine``, ``setting``, ``cost`` and ``error``
    (and optionally ``rel_error``, ``timestep_s``, ``profile``). Rows without a finite
    cost/error are ignored; an engine with no point within a budget gets ``setting=None``.
    """
    import pandas as pd

    rows = []
    for eng, grp in points.groupby("engine", sort=False):
        g = grp[np.isfinite(grp[cost].astype(float)) & np.isfinite(grp[error].astype(float))]
        for b in budgets:
            within = g[g[error] <= b]
            if within.empty:
                rows.append(
                    {
                        "engine": eng,
                        "budget": b,
                        "setting": None,
                        "rel_error": None,
                        cost: None,
                        "timestep_s": None,
                        "profile": None,
                    }
                )
                continue
            best = within.sort_values([cost, error]).iloc[0]
            rows.append(
                {
                    "engine": eng,
                    "budget": b,
                    "setting": best["setting"],
                    "rel_error": float(best["rel_error"]) if "rel_error" in best else float(best[error]),
                    cost: float(best[cost]),
                    "timestep_s": best.get("timestep_s"),
                    "profile": best.get("profile"),
                }
            )
    return pd.DataFrame(rows)


def _predict_cost(history: Sequence[tuple[float, float]], dt: float) -> float:
    """Wall time per simulation at ``dt`` from measured (dt, cost) pairs: cost = a + b/dt.

    With two or more points the fixed part ``a`` and the per-step part ``b`` are fitted to the
    last two; with one point half the cost is assumed fixed (so the prediction errs high,
    but not by the full 1/dt factor of a pure per-step model).
    """
    if not history:
        return 0.0
    if len(history) >= 2:
        (d1, c1), (d2, c2) = history[-2], history[-1]
        if d1 != d2:
            b = (c2 - c1) / (1 / d2 - 1 / d1)
            a = c2 - b / d2
            if b > 0 and a >= 0:
                return a + b / dt
    d, c = history[-1]
    return 0.5 * c + 0.5 * c * (d / dt)


def _fmt_setting(variant: Mapping[str, Any]) -> str:
    return ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in variant.items())


# --------------------------------------------------------------- worker target
def threshold_point(
    scenario: dict[str, Any],
    source: str | None,
    engine: str,
    settings: dict[str, Any],
    param: str,
    lo: float,
    hi: float,
    n_grid: int,
    rel_tol: float,
) -> dict[str, Any]:
    """One threshold search (runs in a worker); JSON-able result."""
    from pbr_xval.study.threshold_search import find_threshold
    from pbr_xval.study.workers import _scenario_from_payload, resolve_engine

    scn = _scenario_from_payload(scenario, source)
    eng = resolve_engine(engine)
    res = find_threshold(
        scn,
        eng,
        param,
        lo=lo,
        hi=hi,
        n_grid=n_grid,
        rel_tol=rel_tol,
        settings=settings,
        all_transitions=False,
    )
    below = bool(res.grid_toppled.size and res.grid_toppled[0])
    from pbr_xval.jsonio import jsonable as _jsonable

    return {
        "minimum": res.minimum,
        "tolerance": res.tolerance,
        "toppled_at_lo": below,
        "never_toppled": res.minimum is None,
        "n_simulations": res.n_simulations,
        "wall_s": res.wall_time,
        "settings": _jsonable(res.settings),
        "versions": dict(res.versions),
    }


# ------------------------------------------------------------------------ run
def _variants(cfg: TradeoffConfig, name: str, eng: Any) -> list[tuple[float | None, str, dict[str, Any]]]:
    """(timestep, profile, overrides) for every point of one engine, coarse dt first."""
    profiles = eng.profiles() if hasattr(eng, "profiles") else {"faithful": eng.default_settings()}
    default = eng.default_settings()
    has_dt = "timestep" in default
    extras: list[dict[str, Any]] = [{}]
    key = ITERATION_KEYS.get(name)
    if key and key in default:
        extras += [{key: int(n)} for n in cfg.iterations.get(name, []) if int(n) != default.get(key)]
    extras += [dict(x) for x in cfg.extra if all(k in default for k in x)]
    out = []
    for prof in cfg.profiles:
        if prof not in profiles:
            continue
        for ex in extras:
            dts: list[float | None] = [*sorted(cfg.timesteps, reverse=True)] if has_dt else [None]
            for dt in dts:
                out.append((dt, prof, ex))
    return out


def run(
    config: TradeoffConfig,
    scenario: Scenario,
    engines: Sequence[str],
    *,
    progress: Callable[[str, float], None] | None = None,
) -> StudyResult:
    import pandas as pd

    from pbr_xval.study.workers import CallTask, run_many, scenario_payload

    t_start = time.perf_counter()
    cfg = config
    result = StudyResult(kind="tradeoff", title=f"Speed–accuracy trade of the {cfg.param} threshold")
    data, source = scenario_payload(scenario)
    result.provenance = {
        "scenario_hash": scenario.content_hash(),
        "scenario": scenario.name,
        "param": cfg.param,
        "engines": {},
    }

    say = clamped_progress(progress)

    # ---- reference
    got = _reference_threshold(cfg, scenario, data, source, result, say)
    if got is None:
        result.wall_time = time.perf_counter() - t_start
        return result
    ref, ref_source = got
    lo = cfg.lo if cfg.lo is not None else 0.8 * ref
    hi = cfg.hi if cfg.hi is not None else 1.25 * ref
    result.provenance.update(reference=ref, reference_source=ref_source, lo=lo, hi=hi, rel_tol=cfg.rel_tol)

    # ---- plan points per engine
    plans, labels = _plans(engines, cfg, result)
    n_total = sum(len(p) for p in plans.values()) or 1

    rows: list[dict[str, Any]] = []
    done = 0
    # series = (engine, profile, overrides) — timesteps run coarse to fine so costs extrapolate
    series = _series(plans)

    # run series in parallel (one series at a time per worker); within a series sequentially
    active: dict[int, dict[str, Any]] = {}
    queue = list(range(len(series)))
    state: dict[int, dict[str, Any]] = {
        i: {"pos": 0, "last_cost": None, "last_dt": None, "last_n": None, "history": []}
        for i in range(len(series))
    }

    def next_task(i: int) -> CallTask | None:
        nonlocal done
        name, prof, ex, dts = series[i]
        st = state[i]
        while st["pos"] < len(dts):
            dt = dts[st["pos"]]
            st["pos"] += 1
            row = _blank_row(labels[name], dt, prof, ex)
            if st["last_cost"] is not None and dt is not None and st["last_dt"]:
                predicted = _predict_cost(st["history"], dt) * (st["last_n"] or 1)
                if predicted > cfg.max_wall_per_point:
                    row.update(
                        status="skipped",
                        note=f"predicted {predicted:.0f} s > max_wall_per_point {cfg.max_wall_per_point:g} s",
                    )
                    rows.append(row)
                    done += 1
                    continue
            settings = {"profile": prof} | ({"timestep": dt} if dt is not None else {}) | ex
            return CallTask(
                "pbr_xval.study.tradeoff:threshold_point",
                {
                    "scenario": data,
                    "source": source,
                    "engine": name,
                    "settings": settings,
                    "param": cfg.param,
                    "lo": lo,
                    "hi": hi,
                    "n_grid": cfg.n_grid,
                    "rel_tol": cfg.rel_tol,
                },
                tag=(i, row),
                timeout=cfg.timeout_per_point,
            )
        return None

    def feed() -> list[CallTask]:
        tasks = []
        while queue and len(active) < cfg.max_workers:
            i = queue.pop(0)
            t = next_task(i)
            if t is not None:
                active[i] = {}
                tasks.append(t)
        return tasks

    # simple scheduler: keep up to max_workers series in flight, each one search at a time
    pending = feed()
    while pending:
        new: list[CallTask] = []
        for r in run_many(pending, cfg.max_workers):
            i, row = r.tag
            st = state[i]
            done += 1
            _record_point(r, row, st, ref, lo, hi, result)
            rows.append(row)
            say(f"{row['engine']} {row['setting']}: {row['status']}", done / n_total)
            t = next_task(i)
            if t is not None:
                new.append(t)
            else:
                active.pop(i, None)
        active_free = cfg.max_workers - len(new)
        while queue and active_free > 0:
            i = queue.pop(0)
            t = next_task(i)
            if t is not None:
                new.append(t)
                active_free -= 1
        pending = new

    df = pd.DataFrame(rows)
    if df.empty:
        df = pd.DataFrame(columns=["engine", "setting", "status"])
        result.tables["tradeoff_points"] = df
        result.notes.append("no points were run")
        result.wall_time = time.perf_counter() - t_start
        return result
    recs = _front_and_recommendations(df, ref, cfg)
    result.tables["tradeoff_points"] = df
    result.tables["tradeoff_recommendations"] = recs

    _summarise(result, df, recs, ref, ref_source, lo, hi, cfg)

    # ---- figure
    try:
        result.figures.append(_figure(df, ref))
    except Exception as exc:  # pragma: no cover - plotting must never kill a study
        result.notes.append(f"figure failed: {exc}")
    result.wall_time = time.perf_counter() - t_start
    return result


def _blank_row(label: str, dt: float | None, prof: str, ex: dict[str, Any]) -> dict[str, Any]:
    """The row of one point before its search: engine label, setting, nothing measured yet."""
    variant = ({"timestep": dt} if dt is not None else {}) | {"profile": prof} | ex
    return {
        "engine": label,
        "setting": _fmt_setting(variant),
        "timestep_s": dt,
        "profile": prof,
        "variant": _fmt_setting(ex) if ex else "",
        "status": "",
        "threshold": None,
        "tolerance": None,
        "rel_error": None,
        "abs_rel_error": None,
        "n_simulations": None,
        "wall_s_per_sim": None,
        "wall_s_search": None,
        "note": "",
    }


def _plans(
    engines: Sequence[str], cfg: TradeoffConfig, result: StudyResult
) -> tuple[dict[str, list[tuple[float | None, str, dict[str, Any]]]], dict[str, str]]:
    """(points to run per engine, engine labels); engines not available are noted and skipped."""
    from pbr_xval.engine import EngineNotAvailable
    from pbr_xval.study.workers import engine_label, resolve_engine

    plans: dict[str, list[tuple[float | None, str, dict[str, Any]]]] = {}
    labels: dict[str, str] = {}
    for name in engines:
        try:
            eng = resolve_engine(name)
        except EngineNotAvailable as exc:
            result.notes.append(f"{name}: not available ({exc}); skipped")
            continue
        labels[name] = engine_label(name)
        plans[name] = _variants(cfg, labels[name], eng)
        result.provenance["engines"][labels[name]] = {"versions": eng.versions()}
    return plans, labels


def _record_point(
    r: Any, row: dict[str, Any], st: dict[str, Any], ref: float, lo: float, hi: float, result: StudyResult
) -> None:
    """Fill ``row`` from one threshold search ``r``; update the series state ``st`` (costs) and the
    provenance (settings) in place."""
    if r.ok:
        v = r.value
        n = v["n_simulations"] or 1
        row.update(
            n_simulations=v["n_simulations"],
            wall_s_search=v["wall_s"],
            wall_s_per_sim=v["wall_s"] / n,
        )
        st.update(last_cost=v["wall_s"] / n, last_dt=row["timestep_s"], last_n=n)
        if row["timestep_s"]:
            st["history"].append((float(row["timestep_s"]), v["wall_s"] / n))
        if v["never_toppled"]:
            row.update(
                status="out_of_range",
                rel_error=math.inf,
                abs_rel_error=math.inf,
                note=f"never toppled up to {hi:.6g}",
            )
        elif v["toppled_at_lo"]:
            row.update(
                status="out_of_range",
                threshold=lo,
                rel_error=-math.inf,
                abs_rel_error=math.inf,
                note=f"toppled already at {lo:.6g}",
            )
        else:
            err = v["minimum"] / ref - 1
            row.update(
                status="ok",
                threshold=v["minimum"],
                tolerance=v["tolerance"],
                rel_error=err,
                abs_rel_error=abs(err),
            )
        result.provenance["engines"].setdefault(row["engine"], {}).setdefault("settings", {})[
            row["setting"]
        ] = v["settings"]
    else:
        row.update(status=r.status, note=r.message.splitlines()[0][:300] if r.message else "")
        st.update(last_cost=None)


def _series(
    plans: dict[str, list[tuple[float | None, str, dict[str, Any]]]],
) -> list[tuple[str, str, dict[str, Any], list[float | None]]]:
    """The plans grouped into series (engine, profile, overrides, timesteps coarse to fine)."""
    series: list[tuple[str, str, dict[str, Any], list[float | None]]] = []
    for name, plan in plans.items():
        seen: dict[tuple[str, str], list[float | None]] = {}
        exs: dict[tuple[str, str], dict[str, Any]] = {}
        for dt, prof, ex in plan:
            k = (prof, repr(sorted(ex.items())))
            seen.setdefault(k, []).append(dt)
            exs[k] = ex
        for (prof, kk), dts in seen.items():
            series.append((name, prof, exs[(prof, kk)], dts))
    return series


def _reference_threshold(
    cfg: TradeoffConfig,
    scenario: Scenario,
    data: Any,
    source: Any,
    result: StudyResult,
    say: Callable[[str, float], None],
) -> tuple[float, str] | None:
    """(reference threshold, where it comes from): the config's value, else the reference engine's
    search (its settings and versions go into ``result.provenance``); None, with a note, if it gave none."""
    from pbr_xval.study.workers import CallTask, run_many

    ref = cfg.reference
    ref_source = "analytical (config)"
    if ref is None:
        v0 = float(scenario.get_value(cfg.param))
        lo0, hi0 = (cfg.lo or 0.5 * v0), (cfg.hi or 2.0 * v0)
        say(f"reference threshold ({cfg.reference_engine})", 0.0)
        r = next(
            iter(
                run_many(
                    [
                        CallTask(
                            "pbr_xval.study.tradeoff:threshold_point",
                            {
                                "scenario": data,
                                "source": source,
                                "engine": cfg.reference_engine,
                                "settings": {},
                                "param": cfg.param,
                                "lo": lo0,
                                "hi": hi0,
                                "n_grid": max(cfg.n_grid, 8),
                                "rel_tol": cfg.rel_tol / 10,
                            },
                            timeout=cfg.timeout_per_point,
                        )
                    ]
                )
            )
        )
        if not r.ok or r.value.get("minimum") is None:
            result.notes.append(
                f"reference engine {cfg.reference_engine!r} gave no threshold: {r.message or r.value}"
            )
            return None
        ref = float(r.value["minimum"])
        ref_source = f"{cfg.reference_engine} engine"
        result.provenance["engines"][cfg.reference_engine] = {
            "settings": r.value["settings"],
            "versions": r.value["versions"],
        }
    return ref, ref_source


def _front_and_recommendations(df: Any, ref: float, cfg: TradeoffConfig) -> Any:
    """Mark each engine's Pareto front in ``df`` (column ``on_front``), insert the reference column;
    the recommended setting per engine and error budget."""
    import pandas as pd

    df["on_front"] = False
    for _eng_name, grp in df.groupby("engine"):
        ok = grp["status"] == "ok"
        sub = grp[ok]
        if not sub.empty:
            mask = pareto_front(sub["wall_s_per_sim"].astype(float), sub["abs_rel_error"].astype(float))
            df.loc[sub.index[mask], "on_front"] = True
    df.insert(0, "reference_m_s2" if cfg.param == "excitation.amplitude" else "reference", ref)
    ok_df = df[df["status"] == "ok"].copy()
    for c in ("wall_s_per_sim", "abs_rel_error", "rel_error"):
        ok_df[c] = ok_df[c].astype(float)
    recs = (
        recommend(ok_df, cfg.budgets)
        if not ok_df.empty
        else pd.DataFrame(
            columns=["engine", "budget", "setting", "rel_error", "wall_s_per_sim", "timestep_s", "profile"]
        )
    )
    return recs


def _summarise(
    result: StudyResult,
    df: Any,
    recs: Any,
    ref: float,
    ref_source: str,
    lo: float,
    hi: float,
    cfg: TradeoffConfig,
) -> None:
    """The summary lines, notes and headline of a trade study (``result`` is filled in place)."""
    result.summary.append(
        f"Reference threshold {ref:.5g} ({ref_source}); search in [{lo:.4g}, {hi:.4g}], "
        f"rel. tol {cfg.rel_tol:g}."
    )
    head: dict[str, Any] = {"reference": ref, "recommendations": {}}
    budgets = sorted({float(b) for b in recs["budget"]}) if len(recs) else []
    cells: dict[str, dict[float, str]] = {}
    for _, rr in recs.iterrows():
        b = float(rr["budget"])
        cells.setdefault(str(rr["engine"]), {})[b] = (
            "no setting tried reaches it"
            if rr["setting"] is None
            else f"at least cost {rr['setting']} (err {rr['rel_error']:+.2%}, "
            f"{rr['wall_s_per_sim']:.3g} s per simulation)"
        )
        head["recommendations"].setdefault(rr["engine"], {})[f"{b:g}"] = (
            None
            if rr["setting"] is None
            else {
                "setting": rr["setting"],
                "rel_error": rr["rel_error"],
                "wall_s_per_sim": rr["wall_s_per_sim"],
            }
        )
    for eng_name, by_b in cells.items():  # one line per engine; budgets sharing a setting merged
        groups: dict[str, list[float]] = {}
        for b in budgets:
            if b in by_b:
                groups.setdefault(by_b[b], []).append(b)
        parts = [f"≤ {', '.join(f'{b:.1%}' for b in bs)}: {text}" for text, bs in groups.items()]
        result.summary.append(f"{eng_name}: " + "; ".join(parts))
    n_skip = int((df["status"] == "skipped").sum())
    bad = df[~df["status"].isin(["ok", "skipped"])]
    if n_skip:
        result.summary.append(
            f"{n_skip} point(s) skipped as too expensive (> {cfg.max_wall_per_point:g} s predicted)."
        )
    for _, b in bad.iterrows():
        result.notes.append(f"{b['engine']} {b['setting']}: {b['status']} {b['note']}")
    result.headline = head


def _figure(df: Any, ref: float) -> Figure:
    from pbr_xval.report.style import engine_colour, log_ticks, subplots

    fig, ax = subplots(figsize=(6.4, 4.2))
    ok = df[df["status"] == "ok"]
    floor = 1e-6
    for eng, grp in ok.groupby("engine"):
        colour = engine_colour(str(eng))
        x = grp["wall_s_per_sim"].astype(float)
        y = np.maximum(grp["abs_rel_error"].astype(float), floor)
        ax.scatter(x, y, color=colour, alpha=0.3, s=18)
        front = grp[grp["on_front"]].sort_values("wall_s_per_sim")
        ax.plot(
            front["wall_s_per_sim"].astype(float),
            np.maximum(front["abs_rel_error"].astype(float), floor),
            "-o",
            color=colour,
            label=str(eng),
            ms=5,
        )
    ax.set_xscale("log")
    ax.set_yscale("log")
    # labels only on 1-2-5 ticks, none on the minor ones (they overlapped within a decade)
    log_ticks(ax.xaxis)
    log_ticks(ax.yaxis, percent=True)
    ax.tick_params(axis="x", labelrotation=0)
    ax.set_xlabel("wall time per simulation [s]")
    ax.set_ylabel("|threshold error| [%]")
    ax.set_title(f"cost vs accuracy (reference {ref:.5g} m/s²)", fontsize=10)
    if len(ok):
        ax.legend(fontsize=8)
    return Figure(
        "tradeoff_points",  # = its table: one CSV
        fig,
        "tradeoff_points",
        "Threshold error vs cost per simulation; lines are each engine's Pareto front, faint dots "
        "every setting tried (errors below 1e-4 % drawn at 1e-4 %).",
    )
