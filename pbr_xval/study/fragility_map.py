"""Fragility maps: toppling and peak COM displacement over a 2-D grid of scenario parameters.

For every variant (a set of scenario overrides, e.g. the seed's curved-base radii r = 1.81,
3.62, 7.24 m) × engine × cell (x, y) the scenario is run once and two numbers are kept:
whether the rock toppled, and the peak horizontal displacement of its centre of mass from the
start, clamped at ``clamp`` (a toppled rock counts as ``clamp``) — the quantity the seed's
curved-base maps plot (science.md §8: H = 14.73 m, h = 3.38 m, triangular velocity pulse,
PGV × T, clamped at 5 m).

Agreement with the analytical map (``reference_engine``, default ``curved_base``) is one number
per engine and variant: the fraction of cells on the same side of the toppling line; the mean
|Δ peak displacement| over the cells where neither toppled is reported beside it.

Each cell is a pure function of (scenario dict, engine, settings), so ``max_workers`` > 1 runs
the cells in a process pool (spawn context).
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable, Sequence
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from pbr_xval import units as _units
from pbr_xval.scenario import Scenario
from pbr_xval.study.base import Figure, StudyResult

__all__ = ["FragilityConfig", "run", "run_cell"]


class FragilityConfig(BaseModel):
    """Configuration of the fragility study.

    Attributes
    ----------
    x, y : dotted scenario keys of the map axes; x_values, y_values : their grid values.
    metric : what the maps colour (``peak_com_disp`` in m, or ``toppled`` 0/1).
    clamp : peak COM displacement ceiling, m (toppled cells count as ``clamp``).
    variants : scenario overrides, one map row each (``[]``: the scenario as given).
    reference_engine : the analytical map the engines are compared with.
    settings : per-engine settings overrides; max_workers : process pool size (1: in process).
    """

    model_config = ConfigDict(extra="forbid")

    type: Literal["fragility"] = "fragility"
    x: str = "excitation.pgv"
    y: str = "excitation.period"
    x_values: list[float] = Field(min_length=1)
    y_values: list[float] = Field(min_length=1)
    metric: Literal["toppled", "peak_com_disp"] = "peak_com_disp"
    clamp: float = Field(5.0, gt=0)
    variants: list[dict[str, Any]] = Field(default_factory=list)
    reference_engine: str | None = "curved_base"
    settings: dict[str, dict[str, Any]] = Field(default_factory=dict)
    max_workers: int = Field(1, ge=1)


def run_cell(
    scenario_data: dict[str, Any], base_dir: str, engine: str, settings: dict[str, Any] | None, clamp: float
) -> dict[str, Any]:
    """Simulate one cell; never raises. Returns status, message, toppled, peak_com_disp_m, wall_s, settings, versions.

    ``scenario_data`` is ``Scenario.model_dump(mode="json")``; ``base_dir`` resolves relative paths.
    """
    from pathlib import Path

    from pbr_xval.engine import EngineNotAvailable, NotApplicable
    from pbr_xval.runner import run_scene
    from pbr_xval.scenario import scenario_from_dict
    from pbr_xval.scene import compile_scene

    t0 = time.perf_counter()
    out: dict[str, Any] = {
        "status": "ok",
        "message": "",
        "toppled": False,
        "peak_com_disp_m": float("nan"),
        "wall_s": float("nan"),
        "settings": {},
        "versions": {},
    }
    try:
        scn = scenario_from_dict(scenario_data)
        scn._base_dir = Path(base_dir)
        scene = compile_scene(scn)
        traj = run_scene(scene, engine, settings)
    except (EngineNotAvailable, NotApplicable) as exc:
        kind = "not available" if isinstance(exc, EngineNotAvailable) else "not applicable"
        return out | {"status": "skipped", "message": f"{kind}: {exc}", "wall_s": time.perf_counter() - t0}
    except Exception as exc:
        return out | {
            "status": "failed",
            "message": f"{type(exc).__name__}: {exc}",
            "wall_s": time.perf_counter() - t0,
        }
    out.update(wall_s=traj.wall_time, settings=traj.settings, versions=traj.versions)
    if not traj.ok:
        return out | {"status": "failed", "message": traj.message}
    if traj.t.size:
        d = np.hypot(traj.com[:, 0] - traj.com[0, 0], traj.com[:, 1] - traj.com[0, 1])
        peak = float(np.max(d))
    else:
        peak = 0.0
    out["toppled"] = bool(traj.toppled)
    out["peak_com_disp_m"] = clamp if traj.toppled else min(peak, clamp)
    return out


def _edges(v: np.ndarray) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    if v.size == 1:
        return np.array([v[0] * 0.9, v[0] * 1.1]) if v[0] else np.array([-0.5, 0.5])
    mid = 0.5 * (v[1:] + v[:-1])
    return np.concatenate([[v[0] - (mid[0] - v[0])], mid, [v[-1] + (v[-1] - mid[-1])]])


def _variant_label(v: dict[str, Any]) -> str:
    return ", ".join(f"{k}={val}" for k, val in v.items()) if v else "base"


def _no_cell(status: str, message: str) -> dict[str, Any]:
    """The result of a cell that was not simulated (engine skipped) or whose worker crashed."""
    return {
        "status": status,
        "message": message,
        "toppled": False,
        "peak_com_disp_m": float("nan"),
        "wall_s": float("nan"),
        "settings": {},
        "versions": {},
    }


def _fit_curves(
    cells: Any,
    config: FragilityConfig,
    variants: list[dict[str, Any]],
    run_engines: list[str],
    tables: dict[str, Any],
    figs: list[Figure],
    notes: list[str],
) -> list[str]:
    """P(topple) over the x intensity measure, pooled over the y grid: a figure and table of
    lognormal fits (added to ``figs``, ``tables``); the summary's fit lines."""
    fit_lines: list[str] = []
    try:  # probability of toppling over the x intensity measure, pooled over the y grid
        from pbr_xval.report.figures import fragility_curves

        ffig, fits = fragility_curves(
            cells,
            config.x,
            [_variant_label(v) for v in variants],
            run_engines,
            group_note=f"pooled over {_units.label(config.y)} = "
            + ", ".join(f"{v:g}" for v in sorted(set(config.y_values))),
        )
        tables["fragility_fits"] = fits
        figs.append(
            Figure(
                name="fragility_fits",  # = its table: one CSV
                figure=ffig,
                table="fragility_fits",
                caption=f"Probability of toppling against {_units.label(config.x)}: dots, the fraction of "
                f"runs that toppled at each level (over the {_units.label(config.y, with_unit=False)} grid); "
                "lines, lognormal fits by maximum likelihood (pbr_xval.catalog.fragility.fit_lognormal, "
                "median θ and dispersion β in the legend); shaded, 90 % bootstrap band (40 refits, "
                "runs resampled). Degenerate data (none or all toppled, complete separation, fewer than "
                "3 levels) get no fit.",
            )
        )
        for _, f in fits.iterrows():
            if f["status"] == "ok":
                fit_lines.append(
                    f"{f['engine']} ({f['variant']}): θ = {f['theta']:.3g} {_units.unit(config.x)}, β = {f['beta']:.2f}"
                )
    except Exception as exc:  # a fit must never sink the maps
        notes.append(f"fragility curves not drawn: {type(exc).__name__}: {exc}")
    return fit_lines


def _summary_lines(
    scenario: Scenario, config: FragilityConfig, ref: str | None, agreement: Any, fit_lines: list[str]
) -> list[str]:
    """The study's summary: agreement with the reference per variant and engine, the fits."""
    summary = [
        f"**Fragility maps** of `{scenario.name}` over {_units.label(config.x)} × {_units.label(config.y)} "
        f"({len(config.x_values)}×{len(config.y_values)} cells); reference: {ref or 'none'}",
        "",
        "| variant | engine | agreement | mean abs Δ peak disp (m) | disagreeing cells | wall s |",
        "|---|---|---|---|---|---|",
    ]
    for _, r in agreement.iterrows():
        summary.append(
            f"| {r['variant']} | {r['engine']} | {_fmt(r['agreement'], '.0%')} | "
            f"{_fmt(r['mean_abs_dpeak_m'], '.3f')} | {r['n_disagree']} | {_fmt(r['wall_s'], '.1f')} |"
        )
    if fit_lines:
        summary.insert(
            1, "Lognormal fragility over " + _units.label(config.x) + ": " + "; ".join(fit_lines) + "."
        )
    return summary


def run(
    config: FragilityConfig,
    scenario: Scenario,
    engines: Sequence[str],
    *,
    progress: Callable[[str, float], None] | None = None,
) -> StudyResult:
    """Map every engine over the grid for every variant; see the module docstring."""
    import pandas as pd

    t_start = time.perf_counter()
    notes: list[str] = []
    order = list(dict.fromkeys(engines))
    ref = config.reference_engine
    run_engines = list(dict.fromkeys([*([ref] if ref else []), *order]))
    if ref and ref not in order:
        notes.append(f"reference engine {ref!r} run in addition to the engines compared")
    variants = config.variants or [{}]
    base_dir = str(scenario._base_dir)

    # validate every cell scenario up front (bad keys are a configuration error, not a result)
    jobs: list[tuple[str, str, float, float, dict[str, Any]]] = []
    for v in variants:
        vs = scenario
        for k, val in v.items():
            vs = vs.with_value(k, val)
        label = _variant_label(v)
        for xv in config.x_values:
            for yv in config.y_values:
                cs = vs.with_value(config.x, xv).with_value(config.y, yv)
                data = cs.model_dump(mode="json")
                for eng in run_engines:
                    jobs.append((label, eng, float(xv), float(yv), data))

    results: list[dict[str, Any] | None] = [None] * len(jobs)
    skip_engine: dict[str, str] = {}
    n = len(jobs)

    def report(i: int, done: int) -> None:
        if progress is not None:
            lab, eng, xv, yv, _ = jobs[i]
            progress(f"fragility: {lab} {eng} {config.x}={xv:g} {config.y}={yv:g}", done / max(n, 1))

    if config.max_workers <= 1:
        for i, (_, eng, _, _, data) in enumerate(jobs):
            if eng in skip_engine:
                results[i] = _no_cell("skipped", skip_engine[eng])
            else:
                cell = results[i] = run_cell(data, base_dir, eng, config.settings.get(eng), config.clamp)
                if cell["status"] == "skipped" and cell["message"].startswith("not available"):
                    skip_engine[eng] = cell["message"]
            report(i, i + 1)
    else:
        import multiprocessing as mp
        from concurrent.futures import ProcessPoolExecutor, as_completed

        from pbr_xval.lifeline import die_with_parent

        ctx = mp.get_context("spawn")
        with ProcessPoolExecutor(
            max_workers=config.max_workers,
            mp_context=ctx,
            initializer=die_with_parent,
            initargs=(os.getpid(),),
        ) as pool:
            futs = {
                pool.submit(run_cell, data, base_dir, eng, config.settings.get(eng), config.clamp): i
                for i, (_, eng, _, _, data) in enumerate(jobs)
            }
            for n_done, fut in enumerate(as_completed(futs)):
                i = futs[fut]
                try:
                    results[i] = fut.result()
                except Exception as exc:  # a crashed worker process
                    results[i] = _no_cell("failed", f"{type(exc).__name__}: {exc}")
                report(i, n_done + 1)

    rows = []
    settings_used: dict[str, Any] = {}
    versions_used: dict[str, Any] = {}
    for (label, eng, xv, yv, _), res in zip(jobs, results, strict=True):
        assert res is not None
        rows.append(
            {
                "variant": label,
                "engine": eng,
                "x": xv,
                "y": yv,
                "x_param": config.x,
                "y_param": config.y,
                "status": res["status"],
                "message": res["message"],
                "toppled": bool(res["toppled"]),
                "peak_com_disp_m": res["peak_com_disp_m"],
                "wall_s": res["wall_s"],
            }
        )
        if res["status"] == "ok":
            settings_used.setdefault(eng, res["settings"])
            versions_used.setdefault(eng, res["versions"])
    cells = pd.DataFrame(rows)

    # engines that never ran any cell
    for eng in run_engines:
        sub = cells[cells["engine"] == eng]
        if (sub["status"] == "skipped").all():
            notes.append(f"{eng}: skipped ({sub['message'].iloc[0]})")
        elif (sub["status"] == "failed").any():
            n_failed = int((sub["status"] == "failed").sum())
            notes.append(
                f"{eng}: FAILED in {n_failed} of {len(sub)} cells (first: {sub[sub['status'] == 'failed']['message'].iloc[0]})"
            )

    agreement = _agreement(cells, ref, [_variant_label(v) for v in variants], order)
    figs = [_figure(cells, agreement, config, [_variant_label(v) for v in variants], run_engines, ref)]
    tables = {"fragility_cells": cells, "fragility_agreement": agreement}
    fit_lines = _fit_curves(cells, config, variants, run_engines, tables, figs, notes)

    summary = _summary_lines(scenario, config, ref, agreement, fit_lines)
    headline: dict[str, Any] = {}
    for _, r in agreement.iterrows():
        headline.setdefault(r["engine"], {})[r["variant"]] = _json_num(r["agreement"])
    return StudyResult(
        kind="fragility",
        title=f"Fragility maps — {scenario.name}",
        tables=tables,
        figures=figs,
        summary=summary,
        headline=headline,
        provenance={
            "scenario": scenario.name,
            "scenario_hash": scenario.content_hash(),
            "config": config.model_dump(mode="json"),
            "reference_engine": ref,
            "settings": settings_used,
            "versions": versions_used,
        },
        notes=notes,
        wall_time=time.perf_counter() - t_start,
    )


def _json_num(x: Any) -> float | None:
    try:
        xf = float(x)
    except (TypeError, ValueError):
        return None
    return xf if math.isfinite(xf) else None


def _fmt(x: Any, spec: str) -> str:
    xf = _json_num(x)
    return "—" if xf is None else format(xf, spec)


def _agreement(cells: Any, ref: str | None, variants: list[str], engines: list[str]) -> Any:
    import pandas as pd

    cols = [
        "variant",
        "engine",
        "n_cells",
        "n_compared",
        "agreement",
        "n_disagree",
        "mean_abs_dpeak_m",
        "toppled_fraction",
        "wall_s",
    ]
    rows = []
    for var in variants:
        base = cells[(cells["variant"] == var) & (cells["engine"] == ref)] if ref else None
        for eng in engines:
            sub = cells[(cells["variant"] == var) & (cells["engine"] == eng)]
            row: dict[str, Any] = {
                "variant": var,
                "engine": eng,
                "n_cells": len(sub),
                "toppled_fraction": float(sub.loc[sub["status"] == "ok", "toppled"].mean())
                if (sub["status"] == "ok").any()
                else float("nan"),
                "wall_s": float(sub["wall_s"].sum(skipna=True)),
            }
            if base is None or base.empty:
                row.update(n_compared=0, agreement=float("nan"), n_disagree=0, mean_abs_dpeak_m=float("nan"))
                rows.append(row)
                continue
            m = sub.merge(base, on=["x", "y"], suffixes=("", "_ref"))
            m = m[(m["status"] == "ok") & (m["status_ref"] == "ok")]
            same = m["toppled"] == m["toppled_ref"]
            stand = m[~m["toppled"] & ~m["toppled_ref"]]
            row.update(
                n_compared=len(m),
                agreement=float(same.mean()) if len(m) else float("nan"),
                n_disagree=int((~same).sum()),
                mean_abs_dpeak_m=float((stand["peak_com_disp_m"] - stand["peak_com_disp_m_ref"]).abs().mean())
                if len(stand)
                else float("nan"),
            )
            rows.append(row)
    return pd.DataFrame(rows, columns=cols)


def _figure(
    cells: Any, agreement: Any, cfg: FragilityConfig, variants: list[str], engines: list[str], ref: str | None
) -> Figure:
    from matplotlib.patches import Rectangle

    from pbr_xval.report.style import axis_label, subplots

    xs = np.asarray(sorted(set(cfg.x_values)), dtype=float)
    ys = np.asarray(sorted(set(cfg.y_values)), dtype=float)
    xe, ye = _edges(xs), _edges(ys)
    nr, nc = len(variants), len(engines)
    fig, axes = subplots(
        nr, nc, figsize=(2.9 * nc + 1.2, 2.5 * nr + 0.6), squeeze=False, sharex=True, sharey=True
    )
    vmax = 1.0 if cfg.metric == "toppled" else cfg.clamp
    mesh = None
    for i, var in enumerate(variants):
        refsub = cells[(cells["variant"] == var) & (cells["engine"] == ref)] if ref else None
        for j, eng in enumerate(engines):
            ax = axes[i, j]
            sub = cells[(cells["variant"] == var) & (cells["engine"] == eng)]
            z = np.full((ys.size, xs.size), np.nan)
            top = np.zeros((ys.size, xs.size), dtype=bool)
            for _, r in sub.iterrows():
                if r["status"] != "ok":
                    continue
                ix, iy = int(np.searchsorted(xs, r["x"])), int(np.searchsorted(ys, r["y"]))
                z[iy, ix] = float(r["toppled"]) if cfg.metric == "toppled" else r["peak_com_disp_m"]
                top[iy, ix] = bool(r["toppled"])
            mesh = ax.pcolormesh(
                xe, ye, np.ma.masked_invalid(z), cmap="viridis", vmin=0.0, vmax=vmax, shading="flat"
            )
            # toppling region: hatched
            for iy in range(ys.size):
                for ix in range(xs.size):
                    if top[iy, ix]:
                        ax.add_patch(
                            Rectangle(
                                (xe[ix], ye[iy]),
                                xe[ix + 1] - xe[ix],
                                ye[iy + 1] - ye[iy],
                                fill=False,
                                hatch="//",
                                edgecolor="w",
                                lw=0,
                            )
                        )
            # cells where the engine disagrees with the reference: red outline
            if refsub is not None and eng != ref and not refsub.empty:
                mm = sub.merge(refsub, on=["x", "y"], suffixes=("", "_ref"))
                for _, r in mm.iterrows():
                    if r["status"] == "ok" and r["status_ref"] == "ok" and r["toppled"] != r["toppled_ref"]:
                        ix, iy = int(np.searchsorted(xs, r["x"])), int(np.searchsorted(ys, r["y"]))
                        ax.add_patch(
                            Rectangle(
                                (xe[ix], ye[iy]),
                                xe[ix + 1] - xe[ix],
                                ye[iy + 1] - ye[iy],
                                fill=False,
                                edgecolor="r",
                                lw=2.0,
                            )
                        )
            ag = agreement[(agreement["variant"] == var) & (agreement["engine"] == eng)]
            tag = ""
            if eng != ref and len(ag) and _json_num(ag["agreement"].iloc[0]) is not None:
                tag = f" — agree {ag['agreement'].iloc[0]:.0%}"
            if (sub["status"] != "ok").all():
                ax.text(
                    0.5,
                    0.5,
                    str(sub["status"].iloc[0]) if len(sub) else "no data",
                    transform=ax.transAxes,
                    ha="center",
                    va="center",
                )
            ax.set_title(
                f"{eng}{' (ref)' if eng == ref else ''}{tag}" + (f"\n{var}" if nr > 1 else ""), fontsize=10
            )
            ax.grid(False)
            if i == nr - 1:
                ax.set_xlabel(axis_label(cfg.x))
            if j == 0:
                ax.set_ylabel(axis_label(cfg.y))
    if mesh is not None:
        cb = fig.colorbar(mesh, ax=axes, shrink=0.8)
        cb.set_label(
            "toppled" if cfg.metric == "toppled" else f"peak COM displacement [m] (clamped at {cfg.clamp:g})"
        )
    return Figure(
        name="fragility_cells",  # = its table: one CSV
        figure=fig,
        table="fragility_cells",
        caption=(
            "Rows: variants; columns: engines. Colour: "
            + (
                "toppled (1) or not (0)"
                if cfg.metric == "toppled"
                else f"peak horizontal COM displacement, clamped at {cfg.clamp:g} m (toppled = clamp)"
            )
            + "; hatched: toppled; red outline: the engine disagrees with the reference on toppling."
        ),
    )
