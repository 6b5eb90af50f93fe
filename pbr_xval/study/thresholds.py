"""Threshold study: every engine's toppling threshold(s) of one scenario parameter.

For each engine :func:`~pbr_xval.study.threshold_search.find_threshold` scans the parameter on a
geometric grid and bisects *every* transition (overturning is not monotonic in amplitude,
Zhang & Makris 2001), so the study reports every toppling band, not only the minimum. The
minimum is compared with an independent reference value (e.g. Housner's nonlinear 5.638 m/s²)
and with an analytical reference engine run on the same scenario.

Tables
------
``thresholds`` — one row per engine: minimum and its ± tolerance, number of bands,
simulations spent, wall time, relative errors, settings and versions (JSON).
``bands`` — one row per toppling band: start and end (NaN = still toppling at the top of the
scanned range) with their tolerances.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable, Sequence
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from pbr_xval import units as _units
from pbr_xval.engine import EngineNotAvailable, NotApplicable, get_engine
from pbr_xval.scenario import Scenario
from pbr_xval.study.base import ANALYTICAL_ENGINES, Figure, StudyResult, reference_candidates
from pbr_xval.study.threshold_search import ThresholdResult, find_threshold

__all__ = ["ThresholdsConfig", "param_unit", "run"]

#: analytical engines, tried in this order when the configured reference does not apply
ANALYTICAL = ANALYTICAL_ENGINES  # (old name)

_UNITS = {
    "amplitude": "m_s2",
    "pga": "m_s2",
    "target_pga": "m_s2",
    "pgv": "m_s",
    "target_pgv": "m_s",
    "period": "s",
    "pulse_duration": "s",
    "frequency": "Hz",
    "r": "m",
    "h": "m",
    "H": "m",
    "friction_static": "1",
    "scale": "1",
}


def param_unit(param: str) -> str:
    """Column-name unit suffix of a dotted scenario key (``excitation.amplitude`` → ``m_s2``)."""
    return _UNITS.get(param.rsplit(".", 1)[-1], "")


def _col(name: str, unit: str) -> str:
    return f"{name}_{unit}" if unit else name


class ThresholdsConfig(BaseModel):
    """Configuration of the threshold study.

    Attributes
    ----------
    param : dotted scenario key searched (e.g. ``excitation.amplitude``).
    lo, hi : scan range; default 0.5× and 2× the scenario's value.
    n_grid : coarse grid points (geometric); rel_tol : bisection tolerance (relative).
    reference : an independent published/analytical value to compare the minima with.
    reference_engine : analytical engine run on the same scenario as a second reference
        (``housner`` or ``curved_base``; when it does not apply the other one is tried).
    settings : per-engine settings overrides (may contain ``profile``).
    """

    model_config = ConfigDict(extra="forbid")

    type: Literal["thresholds"] = "thresholds"
    param: str = "excitation.amplitude"
    lo: float | None = Field(None, gt=0)
    hi: float | None = Field(None, gt=0)
    n_grid: int = Field(16, ge=2)
    rel_tol: float = Field(1e-4, gt=0, lt=1)
    reference: float | None = None
    reference_engine: str | None = "housner"
    settings: dict[str, dict[str, Any]] = Field(default_factory=dict)


def _nan(x: float | None) -> float:
    return float("nan") if x is None else float(x)


def _expected_sims(cfg: ThresholdsConfig, lo: float, hi: float) -> int:
    step = (hi / lo) ** (1.0 / max(cfg.n_grid - 1, 1)) - 1.0
    return cfg.n_grid + max(1, math.ceil(math.log2(max(step, cfg.rel_tol) / cfg.rel_tol)))


def run(
    config: ThresholdsConfig,
    scenario: Scenario,
    engines: Sequence[str],
    *,
    progress: Callable[[str, float], None] | None = None,
) -> StudyResult:
    """Find every engine's toppling bands in ``config.param``; see the module docstring."""
    import pandas as pd

    t_start = time.perf_counter()
    unit = param_unit(config.param)
    v0 = float(scenario.get_value(config.param))
    lo = 0.5 * v0 if config.lo is None else float(config.lo)
    hi = 2.0 * v0 if config.hi is None else float(config.hi)
    notes: list[str] = []
    order = list(dict.fromkeys(engines))
    ref_name = config.reference_engine
    candidates = reference_candidates(ref_name)
    n_total = max(len(order), 1) + (1 if ref_name and ref_name not in order else 0)
    expected = _expected_sims(config, lo, hi)

    results: dict[str, ThresholdResult] = {}
    failures: dict[str, str] = {}
    skipped: dict[str, str] = {}
    done = 0

    def search(name: str) -> ThresholdResult | None:
        nonlocal done
        if progress is not None:
            progress(f"thresholds: {name}", done / n_total)

        def cb(count: int, value: float, toppled: bool) -> None:
            if progress is not None:
                frac = min(count / expected, 0.99)
                progress(
                    f"thresholds: {name} #{count} {config.param}={value:.6g} "
                    f"{'topples' if toppled else 'stands'}",
                    (done + frac) / n_total,
                )

        try:
            get_engine(name)
            res = find_threshold(
                scenario,
                name,
                config.param,
                lo=lo,
                hi=hi,
                n_grid=config.n_grid,
                rel_tol=config.rel_tol,
                settings=config.settings.get(name),
                all_transitions=True,
                progress=cb,
            )
        except EngineNotAvailable as exc:
            skipped[name] = f"not available: {exc}"
            return None
        except NotApplicable as exc:
            skipped[name] = f"not applicable: {exc}"
            return None
        except Exception as exc:  # an engine failure is a result, not a crash
            failures[name] = f"{type(exc).__name__}: {exc}"
            return None
        finally:
            done += 1
        return res

    # the analytical reference engine (possibly not in the list of engines compared)
    ref_used = _search_reference(candidates, order, search, results, skipped, failures, notes)
    if ref_name and ref_used is None:
        notes.append("no analytical reference engine applies to this scenario")
    elif ref_used and ref_used != ref_name:
        notes.append(f"reference engine {ref_name!r} does not apply; using {ref_used!r}")

    for name in order:
        if name in results or name in skipped or name in failures:
            continue
        res = search(name)
        if res is not None:
            results[name] = res

    for name, why in skipped.items():
        notes.append(f"{name}: skipped ({why})")
    for name, why in failures.items():
        notes.append(f"{name}: FAILED ({why})")

    ref_min = results[ref_used].minimum if ref_used else None
    rows: list[dict[str, Any]] = []
    band_rows: list[dict[str, Any]] = []
    shown = [n for n in dict.fromkeys([*([ref_used] if ref_used else []), *order])]
    for name in shown:
        res = results.get(name)
        if res is None:
            rows.append(_missing_row(name, skipped, failures, config, unit))
            continue
        _result_rows(name, res, config, unit, ref_min, lo, rows, band_rows, notes)

    table = pd.DataFrame(rows)
    bands_df = pd.DataFrame(
        band_rows,
        columns=[
            "engine",
            "band",
            _col("band_start", unit),
            _col("band_end", unit),
            _col("start_tol", unit),
            _col("end_tol", unit),
        ],
    )
    figs = [_figure(table, bands_df, config, unit, ref_used, ref_min, lo, hi)]
    tables = {"thresholds": table, "bands": bands_df}
    _rock_contact(scenario, tables, figs, notes)

    summary = _summary_lines(rows, results, config, scenario, unit, lo, hi, ref_used)

    return StudyResult(
        kind="thresholds",
        title=f"Toppling thresholds: {config.param} — {scenario.name}",
        tables=tables,
        figures=figs,
        summary=summary,
        headline={n: (None if r.minimum is None else float(r.minimum)) for n, r in results.items()},
        provenance={
            "scenario": scenario.name,
            "scenario_hash": scenario.content_hash(),
            "config": config.model_dump(mode="json"),
            "scan": {"lo": lo, "hi": hi},
            "reference_engine": ref_used,
            "settings": {n: r.settings for n, r in results.items()},
            "versions": {n: r.versions for n, r in results.items()},
        },
        notes=notes,
        wall_time=time.perf_counter() - t_start,
    )


def _search_reference(
    candidates: list[str],
    order: list[str],
    search: Callable[[str], ThresholdResult | None],
    results: dict[str, ThresholdResult],
    skipped: dict[str, str],
    failures: dict[str, str],
    notes: list[str],
) -> str | None:
    """Search the analytical reference engine (possibly not among the engines compared): the first
    candidate that gives a result; the next one only while the previous does not apply."""
    ref_used: str | None = None
    for cand in candidates:
        if cand in order:
            res = search(cand)
            if res is not None:
                results[cand] = res
                ref_used = cand
                return ref_used
            if cand in skipped and skipped[cand].startswith("not applicable"):
                continue
            return ref_used
        res = search(cand)
        if res is not None:
            results[cand] = res
            ref_used = cand
            notes.append(f"reference engine {cand!r} run in addition to the engines compared")
            return ref_used
        reason = skipped.pop(cand, None) or failures.pop(cand, "")
        notes.append(f"reference engine {cand!r} not used: {reason}")
        if not reason.startswith("not applicable"):
            return ref_used
    return ref_used


def _missing_row(
    name: str, skipped: dict[str, str], failures: dict[str, str], config: ThresholdsConfig, unit: str
) -> dict[str, Any]:
    """The ``thresholds`` row of an engine that gave no result (skipped or failed)."""
    return {
        "engine": name,
        "status": "skipped" if name in skipped else "failed",
        "message": skipped.get(name) or failures.get(name, ""),
        "profile": (config.settings.get(name) or {}).get("profile", ""),
        "param": config.param,
        _col("minimum", unit): float("nan"),
        _col("tolerance", unit): float("nan"),
        "n_bands": 0,
        "n_simulations": 0,
        "wall_s": float("nan"),
        "rel_error_vs_reference": float("nan"),
        "rel_error_vs_reference_engine": float("nan"),
        "settings": json.dumps(config.settings.get(name) or {}, sort_keys=True, default=str),
        "versions": "{}",
    }


def _result_rows(
    name: str,
    res: ThresholdResult,
    config: ThresholdsConfig,
    unit: str,
    ref_min: float | None,
    lo: float,
    rows: list[dict[str, Any]],
    band_rows: list[dict[str, Any]],
    notes: list[str],
) -> None:
    """Append one engine's row of ``thresholds`` and its rows of ``bands`` (and a note if it
    toppled already at the bottom of the scan)."""
    bands = res.bands()
    mn = res.minimum
    rows.append(
        {
            "engine": name,
            "status": "ok" if mn is not None else res.status,
            "message": "" if mn is not None else res.message(),
            "profile": str(res.settings.get("profile", "")),
            "param": config.param,
            _col("minimum", unit): _nan(mn),
            _col("tolerance", unit): _nan(res.tolerance)
            if not (res.grid_toppled.size and res.grid_toppled[0])
            else 0.0,
            "n_bands": len(bands),
            "resolution": res.resolution,
            "n_simulations": res.n_simulations,
            "wall_s": res.wall_time,
            "rel_error_vs_reference": (mn / config.reference - 1.0)
            if (mn is not None and config.reference)
            else float("nan"),
            "rel_error_vs_reference_engine": (mn / ref_min - 1.0)
            if (mn is not None and ref_min)
            else float("nan"),
            "settings": json.dumps(res.settings, sort_keys=True, default=str),
            "versions": json.dumps(res.versions, sort_keys=True, default=str),
        }
    )
    if res.grid_toppled.size and res.grid_toppled[0]:
        notes.append(f"{name}: already toppling at the bottom of the scan ({lo:.6g}); the minimum is ≤ that")
    for i, b in enumerate(bands):
        band_rows.append(
            {
                "engine": name,
                "band": i,
                _col("band_start", unit): _nan(b.start),
                _col("band_end", unit): _nan(b.end),
                _col("start_tol", unit): _nan(b.start_tol),
                _col("end_tol", unit): _nan(b.end_tol),
            }
        )


def _rock_contact(scenario: Scenario, tables: dict[str, Any], figs: list[Figure], notes: list[str]) -> None:
    """The rock and its contact patch (what was tested): a figure and its table, or a note."""
    try:  # the rock and its contact patch: what was tested
        from pbr_xval.report.figures import rock_figure
        from pbr_xval.scene import compile_scene

        rfig, rdata = rock_figure(compile_scene(scenario), scenario.name)
        tables["rock_contact"] = rdata
        figs.append(
            Figure(
                name="rock_contact",  # = its table: one CSV
                figure=rfig,
                table="rock_contact",
                caption="The rock at rest: side view and plan view on equal axes; red: the contact "
                "patch (support polygon), +: centre of mass.",
            )
        )
    except Exception as exc:  # a picture must never sink the study
        notes.append(f"rock picture not drawn: {type(exc).__name__}: {exc}")


def _summary_lines(
    rows: list[dict[str, Any]],
    results: dict[str, ThresholdResult],
    config: ThresholdsConfig,
    scenario: Scenario,
    unit: str,
    lo: float,
    hi: float,
    ref_used: str | None,
) -> list[str]:
    """The study's summary: the table of minima per engine, the reference, non-monotonic engines."""
    summary = [
        f"**Thresholds** of `{config.param}` on `{scenario.name}` (scan {lo:.6g}–{hi:.6g}, "
        f"rel. tol {config.rel_tol:g})",
        "",
        f"| engine | minimum [{_units.unit(config.param)}] | ± | bands | sims | vs reference | "
        f"vs {ref_used or '—'} | wall s |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        mn = r[_col("minimum", unit)]
        if r["status"] in ("skipped", "failed"):
            summary.append(f"| {r['engine']} | {r['status']} | | | | | | |")
            continue
        summary.append(
            f"| {r['engine']} | {_fmt(mn)} | {_fmt(r[_col('tolerance', unit)], '.2g')} | {r['n_bands']} | "
            f"{r['n_simulations']} | {_pct(r['rel_error_vs_reference'])} | "
            f"{_pct(r['rel_error_vs_reference_engine'])} | {r['wall_s']:.1f} |"
        )
    if config.reference is not None:
        summary.append("")
        summary.append(f"Reference value: {config.reference:g}.")
    multi = [n for n, r in results.items() if len(r.bands()) > 1]
    if multi:
        summary.append(f"Non-monotonic (more than one toppling band): {', '.join(multi)}.")
    return summary


def _fmt(x: float, spec: str = ".6g") -> str:
    return "—" if x is None or not math.isfinite(x) else format(x, spec)


def _pct(x: float) -> str:
    return "—" if x is None or not math.isfinite(x) else f"{x:+.3%}"


def _figure(
    table: Any,
    bands: Any,
    cfg: ThresholdsConfig,
    unit: str,
    ref_used: str | None,
    ref_min: float | None,
    lo: float,
    hi: float,
) -> Figure:
    import numpy as np

    from pbr_xval.report.style import axis_label, engine_colour, subplots

    mcol, tcol = _col("minimum", unit), _col("tolerance", unit)
    ok = table[np.isfinite(table[mcol])]
    multi = bool((table["n_bands"] > 1).any())
    ncols = 2 if multi else 1
    fig, axes = subplots(1, ncols, figsize=(6.0 if ncols == 1 else 7.4, 3.6), squeeze=False)
    ax = axes[0, 0]
    y = np.arange(len(ok))[::-1]
    for yi, (_, r) in zip(y, ok.iterrows(), strict=True):
        ax.errorbar(
            r[mcol],
            yi,
            xerr=0.0 if not np.isfinite(r[tcol]) else r[tcol],
            fmt="o",
            capsize=5,
            ms=6,
            color=engine_colour(r["engine"]),
        )
    drawn = ["dots: each engine's minimum toppling value, bars: ± its bisection bracket"]
    if cfg.reference is not None:
        ax.axvline(cfg.reference, color="k", lw=1.2, ls="-", label=f"reference {cfg.reference:g}")
        drawn.append(f"solid line: the reference value {cfg.reference:g} {_units.unit(cfg.param)}")
    if ref_min is not None and ref_used is not None:
        ax.axvline(ref_min, color="0.45", lw=1.2, ls="--", label=f"{ref_used} {ref_min:.6g}")
        drawn.append(f"dashed line: the {ref_used} engine's threshold on the same scenario")
    ax.set_yticks(y, list(ok["engine"]))
    ax.set_xlabel(axis_label(cfg.param, unit.replace("_", "/")))
    ax.set_title("minimum toppling value per engine")
    if len(ok):
        span = float(ok[mcol].max() - ok[mcol].min())
        refs = [v for v in (cfg.reference, ref_min) if v is not None]
        err = ok[tcol].fillna(0.0)
        lo_x = min([float((ok[mcol] - err).min()), *refs])
        hi_x = max([float((ok[mcol] + err).max()), *refs])
        pad = max(span, hi_x - lo_x, 1e-3 * abs(hi_x)) * 0.08
        ax.set_xlim(lo_x - pad, hi_x + pad)
    ax.set_ylim(-0.6, len(ok) - 0.4)
    ax.ticklabel_format(axis="x", style="plain", useOffset=False)
    if cfg.reference is not None or ref_min is not None:
        ax.legend(loc="best", fontsize=8, framealpha=0.9)
    if multi:
        ax2 = axes[0, 1]
        names = list(table["engine"])[::-1]  # top to bottom in table order, as on the left
        for i, name in enumerate(names):
            sub = bands[bands["engine"] == name]
            for _, b in sub.iterrows():
                end = b[_col("band_end", unit)]
                end = hi if not np.isfinite(end) else end
                start = b[_col("band_start", unit)]
                start = lo if not np.isfinite(start) else start
                ax2.plot(
                    [start, end],
                    [i, i],
                    lw=8,
                    color=engine_colour(name),
                    solid_capstyle="butt",
                )
        ax2.set_yticks(range(len(names)), names)
        ax2.set_xlim(lo, hi)
        ax2.set_xlabel(axis_label(cfg.param, unit.replace("_", "/")))
        ax2.set_title("toppling bands in the scanned range")
        if cfg.reference is not None:
            ax2.axvline(cfg.reference, color="k", lw=1)
        drawn.append("right: every toppling band found in the scanned range")
    return Figure(
        name="thresholds",
        figure=fig,
        table="thresholds",
        caption=f"Minimum toppling value of {_units.label(cfg.param)} per engine. " + "; ".join(drawn) + ".",
    )
