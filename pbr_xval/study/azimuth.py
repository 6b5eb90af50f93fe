"""Azimuth study: the toppling level for every direction of shaking, beside its physical bound.

A rock is not equally fragile in every direction (the seed paper asks for the sensitivity to
direction, period, amplitude and friction). For each shaking azimuth φ the study sets
``excitation.azimuth_deg = φ`` and, for every engine, searches the minimum toppling value of
``param`` (a pulse amplitude or PGV at fixed pulse shape, a record's ``target_pga``,
``target_pgv`` or ``scale``) with :func:`pbr_xval.study.threshold_search.find_threshold`.

Every level is also expressed as the peak ground acceleration (PGA, m/s²) of the motion at that
level, and compared with the quasi-static uplift bound

    a_min(φ) = min(g·tan α_u(φ), g·tan α_u(φ + π)),   tan α_u = ρ(φ)/h_G

(:meth:`pbr_xval.geometry.stability.StabilityTable.shaking_bound`): below it the contact forces
hold the rock on its base in both senses of the shaking, so no engine may topple it there.
``ratio_to_bound`` = PGA at the level / a_min(φ) must be ≥ 1 (within the search tolerance).

Directions: φ in degrees, 0 along +x of the scene (the scan's x for a scanned rock), counter-
clockwise seen from above (+x toward +y) — the scenario's ``excitation.azimuth_deg``.

Tables
------
``azimuth`` — one row per (engine, φ): status, minimum and its ± tolerance (param units), PGA
at the minimum, the bound, their ratio, the tilt-table angles toward ±φ, simulations, wall time.
``bound`` — the bound a_min(φ) on 360 directions (the polar curve).
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any, Literal, cast

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from pbr_xval.engine import EngineNotAvailable, NotApplicable, get_engine
from pbr_xval.scenario import Scenario
from pbr_xval.study.base import Figure, StudyResult

if TYPE_CHECKING:
    from matplotlib.projections.polar import PolarAxes

__all__ = ["AzimuthConfig", "pga_of", "run"]

#: how φ is measured (written on the figure)
PHI_CONVENTION = "φ = 0 along +x; φ grows counter-clockwise seen from above (+x toward +y)"


class AzimuthConfig(BaseModel):
    """Configuration of the azimuth study.

    Attributes
    ----------
    param : dotted scenario key searched (it must scale the motion's PGA linearly: a pulse
        ``amplitude`` or ``pgv``, a record's ``target_pga``, ``target_pgv`` or ``scale``).
    directions : number of azimuths, evenly spaced on [0°, 360°); or ``azimuths_deg``.
    range_over_bound : search range per direction as multiples of the value at which the PGA
        equals that direction's bound a_min(φ) (default 0.8–4: the search starts below the bound,
        so an engine toppling there would be seen, not assumed away).
    lo, hi : a fixed search range (param units) for every direction instead.
    n_grid, rel_tol, max_simulations : passed to ``find_threshold``.
    settings : per-engine settings overrides.
    """

    model_config = ConfigDict(extra="forbid")

    type: Literal["azimuth"] = "azimuth"
    param: str = "excitation.amplitude"
    directions: int = Field(8, ge=1, le=360)
    azimuths_deg: list[float] | None = Field(None, min_length=1)
    range_over_bound: tuple[float, float] = (0.8, 4.0)
    lo: float | None = Field(None, gt=0)
    hi: float | None = Field(None, gt=0)
    n_grid: int = Field(6, ge=2)
    rel_tol: float = Field(0.01, gt=0, lt=1)
    max_simulations: int = Field(40, ge=2)
    settings: dict[str, dict[str, Any]] = Field(default_factory=dict)

    @model_validator(mode="after")
    def _ranges(self) -> AzimuthConfig:
        a, b = self.range_over_bound
        if not (0 < a < b and math.isfinite(b)):
            raise ValueError(
                f"range_over_bound must be two numbers 0 < lo < hi, found {list(self.range_over_bound)}"
            )
        if (self.lo is None) != (self.hi is None):
            raise ValueError("give both 'lo' and 'hi' (a fixed range), or neither (range_over_bound)")
        if self.lo is not None and self.hi is not None and not self.lo < self.hi:
            raise ValueError(f"lo = {self.lo} must be below hi = {self.hi}")
        return self

    def azimuths(self) -> list[float]:
        """The azimuths searched, degrees."""
        if self.azimuths_deg is not None:
            return [float(a) for a in self.azimuths_deg]
        return [360.0 * k / self.directions for k in range(self.directions)]


def pga_of(scenario: Scenario) -> float:
    """Peak horizontal ground acceleration (m/s²) of the scenario's motion (exact for pulses and
    records, finely sampled otherwise)."""
    from pbr_xval.motion.intensity import peak_ground_acceleration
    from pbr_xval.scene import compile_scene

    return float(peak_ground_acceleration(compile_scene(scenario).excitation.horizontal))


def _unit(param: str) -> str:
    try:
        from pbr_xval.units import unit as unit_of

        return str(unit_of(param))
    except Exception:
        return ""


def _directions(
    scenario: Scenario, azimuths: Any, config: AzimuthConfig, v0: float, bound_applies: bool
) -> list[dict[str, Any]]:
    """Per direction: the scenario, the uplift bound, the value at which PGA = bound, the search range."""
    from pbr_xval.scene import compile_scene

    per_dir: list[dict[str, Any]] = []
    for phi in azimuths:
        scn = scenario.with_value("excitation.azimuth_deg", float(phi))
        scene = compile_scene(scn)
        table = scene.rock.stability
        bound = (
            float(table.shaking_bound(math.radians(phi), scene.gravity)) if bound_applies else float("nan")
        )
        p1 = float(pga_of(scn))
        p2 = float(pga_of(scn.with_value(config.param, 2.0 * v0)))
        if not (p1 > 0 and abs(p2 / p1 - 2.0) < 1e-6):
            raise ValueError(
                f"study 'azimuth': key 'param' = {config.param!r} does not scale the PGA linearly "
                f"(PGA {p1:.6g} m/s² at {v0:.6g}, {p2:.6g} m/s² at twice that); expected an amplitude, "
                "pgv, target_pga, target_pgv or scale"
            )
        v_bound = v0 * bound / p1
        lo, hi = (
            (config.lo, config.hi)
            if config.lo is not None and config.hi is not None  # given together (validated)
            else (config.range_over_bound[0] * v_bound, config.range_over_bound[1] * v_bound)
        )
        per_dir.append(
            {
                "phi": float(phi),
                "scenario": scn,
                "bound": bound,
                "pga_per_unit": p1 / v0,
                "v_bound": v_bound,
                "lo": float(lo),
                "hi": float(hi),
                "alpha_u_plus": float(
                    np.degrees(np.arctan2(_ray(table, math.radians(phi)), table.com_height))
                ),
                "alpha_u_minus": float(
                    np.degrees(np.arctan2(_ray(table, math.radians(phi) + math.pi), table.com_height))
                ),
            }
        )
    return per_dir


def _dense_bounds(scene0: Any, bound_applies: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every degree of azimuth: the uplift bound (m/s², NaN where it does not apply) and the
    quasi-static toppling level of a rock rolling on its hull, g·tan α (not a bound)."""
    dense = np.radians(np.arange(0.0, 360.0, 1.0))
    st0 = scene0.rock.stability
    dense_bound = (
        np.asarray(st0.shaking_bound(dense, scene0.gravity), dtype=float)
        if bound_applies
        else np.full(dense.shape, np.nan)
    )
    # quasi-static toppling of a rock rolling on its hull (critical tilt α, smaller of ±φ): not a bound
    alpha2 = np.minimum(st0.alpha_at(dense), st0.alpha_at(dense + np.pi))
    dense_alpha = np.where(alpha2 < np.radians(80.0), scene0.gravity * np.tan(alpha2), np.nan)
    return dense, dense_bound, dense_alpha


def _summary_and_headline(
    table_df: Any, scenario: Scenario, config: AzimuthConfig, azimuths: Any, unit: str
) -> tuple[list[str], dict[str, Any]]:
    """The study's summary table and its headline (weakest direction and PGA range per engine)."""
    summary = [
        f"**Toppling level per shaking azimuth** of `{config.param}` on `{scenario.name}` "
        f"({len(azimuths)} directions; {PHI_CONVENTION}); PGA at the level vs the quasi-static "
        "uplift bound min(g·tan α_u(φ), g·tan α_u(φ+180°))",
        "",
        f"| engine | φ [deg] | status | minimum [{unit or '-'}] | ± | PGA [m/s²] | bound [m/s²] | PGA/bound | sims |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for _, r in table_df.iterrows():
        summary.append(
            f"| {r['engine']} | {r['phi_deg']:g} | {r['status']} | {_fmt(r[_c('minimum', unit)])} | "
            f"{_fmt(r[_c('tolerance', unit)], '.2g')} | {_fmt(r['pga_at_minimum_m_s2'], '.4g')} | "
            f"{r['bound_m_s2']:.4g} | {_fmt(r['ratio_to_bound'], '.3f')} | {r['n_simulations']} |"
        )
    headline: dict[str, Any] = {}
    for name, sub in table_df.groupby("engine", sort=False):
        ok = sub[np.isfinite(sub["pga_at_minimum_m_s2"].astype(float))]
        if len(ok):
            i = ok["pga_at_minimum_m_s2"].astype(float).idxmin()
            headline[str(name)] = {
                "weakest_phi_deg": float(ok.loc[i, "phi_deg"]),
                "min_pga_m_s2": float(ok.loc[i, "pga_at_minimum_m_s2"]),
                "max_pga_m_s2": float(ok["pga_at_minimum_m_s2"].astype(float).max()),
            }
    return summary, headline


def run(
    config: AzimuthConfig,
    scenario: Scenario,
    engines: Sequence[str],
    *,
    progress: Callable[[str, float], None] | None = None,
) -> StudyResult:
    """Toppling level per shaking azimuth for every engine; see the module docstring."""
    import pandas as pd

    from pbr_xval.scene import compile_scene
    from pbr_xval.study.threshold_search import find_threshold

    t_start = time.perf_counter()
    unit = _unit(config.param)
    azimuths = config.azimuths()
    order = list(dict.fromkeys(engines))
    notes: list[str] = []
    v0 = float(scenario.get_value(config.param))
    if not (v0 > 0 and math.isfinite(v0)):
        raise ValueError(
            f"scenario {scenario.name!r}: key {config.param!r} = {v0!r}; expected a positive number"
        )

    # the bound holds for a rigid rock starting at rest on a horizontal pedestal, no vertical shaking
    scene0 = compile_scene(scenario)
    why_not = []
    if scene0.pedestal.get("kind") not in ("plane", "box"):
        why_not.append("the pedestal is not flat")
    if scene0.excitation.vertical is not None:
        why_not.append("the motion has a vertical component")
    if scene0.theta0 != 0.0 or scene0.omega0 != 0.0:
        why_not.append("the rock does not start at rest")
    bound_applies = not why_not
    if not bound_applies:
        notes.append(f"no quasi-static uplift bound: {', '.join(why_not)}")
        if config.lo is None:
            raise ValueError(
                f"study 'azimuth' on {scenario.name!r}: {', '.join(why_not)}, so the uplift bound does not "
                "apply and cannot set the search range; give 'lo' and 'hi'"
            )

    per_dir = _directions(scenario, azimuths, config, v0, bound_applies)
    dense, dense_bound, dense_alpha = _dense_bounds(scene0, bound_applies)

    rows: list[dict[str, Any]] = []
    skipped: dict[str, str] = {}
    settings_used: dict[str, dict[str, Any]] = {}
    versions_used: dict[str, dict[str, str]] = {}
    n_total = max(len(order) * len(per_dir), 1)
    done = 0
    for name in order:
        try:
            get_engine(name)
        except EngineNotAvailable as exc:
            skipped[name] = f"not available: {exc}"
            done += len(per_dir)
            continue
        for d in per_dir:
            if progress is not None:
                progress(f"azimuth: {name} φ = {d['phi']:g}°", done / n_total)

            def cb(
                count: int, value: float, toppled: bool, _n: str = name, _p: float = d["phi"], _d: int = done
            ) -> None:
                if progress is not None:
                    frac = min(count / config.max_simulations, 0.99)
                    progress(
                        f"azimuth: {_n} φ = {_p:g}° #{count} {config.param}={value:.4g} "
                        f"{'topples' if toppled else 'stands'}",
                        (_d + frac) / n_total,
                    )

            t0 = time.perf_counter()
            row: dict[str, Any] = {"engine": name, "phi_deg": d["phi"]}
            try:
                res = find_threshold(
                    d["scenario"],
                    name,
                    config.param,
                    lo=d["lo"],
                    hi=d["hi"],
                    n_grid=config.n_grid,
                    rel_tol=config.rel_tol,
                    settings=config.settings.get(name),
                    all_transitions=False,
                    progress=cb,
                    max_simulations=config.max_simulations,
                    physics_bound=False,
                )
            except NotApplicable as exc:
                skipped[name] = f"not applicable: {exc}"
                done += len(per_dir)
                break
            except Exception as exc:  # an engine failure is a result, not a crash
                row.update(status="failed", message=f"{type(exc).__name__}: {exc}")
                rows.append(_fill(row, d, unit, time.perf_counter() - t0))
                done += 1
                continue
            mn, tol = res.minimum, res.tolerance
            settings_used.setdefault(name, dict(res.settings))
            versions_used.setdefault(name, dict(res.versions))
            row.update(_bracket_runs(res))
            row.update(
                status=res.status,
                message=res.message(),
                minimum=mn,
                tolerance=tol,
                n_simulations=res.n_simulations,
                settings=json.dumps(res.settings, sort_keys=True, default=str),
                versions=json.dumps(res.versions, sort_keys=True, default=str),
            )
            rows.append(_fill(row, d, unit, time.perf_counter() - t0))
            done += 1
    for name, why in skipped.items():
        notes.append(f"{name}: skipped ({why})")

    cols = _columns(unit)
    table_df = pd.DataFrame(rows, columns=cols)
    bound_df = pd.DataFrame(
        {"phi_deg": np.degrees(dense), "bound_m_s2": dense_bound, "critical_tilt_accel_m_s2": dense_alpha}
    )
    below = table_df[(table_df["status"] == "bracketed") & (table_df["ratio_to_bound_lo"] < 1.0)]
    for _, r in below.iterrows():
        notes.append(
            f"{r['engine']} at φ = {r['phi_deg']:g}°: toppled at PGA {r['pga_at_minimum_m_s2']:.4g} m/s², "
            f"below the quasi-static uplift bound {r['bound_m_s2']:.4g} m/s² — not physical for a rigid rock"
        )
    fig = _figure(table_df, bound_df, scenario.name, config.param)
    summary, headline = _summary_and_headline(table_df, scenario, config, azimuths, unit)
    return StudyResult(
        kind="azimuth",
        title=f"Toppling level per shaking azimuth: {config.param} — {scenario.name}",
        tables={"azimuth": table_df, "bound": bound_df},
        figures=[fig],
        summary=summary,
        headline=headline,
        provenance={
            "scenario": scenario.name,
            "scenario_hash": scenario.content_hash(),
            "config": config.model_dump(mode="json"),
            "phi_convention": PHI_CONVENTION,
            "ranges": {f"{d['phi']:g}": [d["lo"], d["hi"]] for d in per_dir},
            "settings": settings_used,
            "versions": versions_used,
        },
        notes=notes,
        wall_time=time.perf_counter() - t_start,
    )


def _bracket_runs(res: Any) -> dict[str, Any]:
    """What the rock did in the two runs that bracket the minimum: regime, impacts, peak tilt."""
    tr = next((t for t in res.transitions if not t.below_toppled), None)
    out: dict[str, Any] = {}
    if tr is None:
        return out
    for side, run in (("below", tr.lo_run), ("above", tr.hi_run)):
        if run is None:
            continue
        out[f"regime_{side}"] = run.regime
        out[f"impacts_{side}"] = int(run.impacts)
        out[f"peak_ratio_{side}"] = float(run.peak_ratio)
        if side == "above":
            out["toppled_at_s"] = float("nan") if run.toppled_at is None else float(run.toppled_at)
    return out


def _ray(table: Any, phi: float) -> float:
    from pbr_xval.geometry.stability import ray_lever

    return float(ray_lever(table.polygon, table._com_xy, np.array([math.cos(phi), math.sin(phi)])))


def _c(name: str, unit: str) -> str:
    u = unit.replace("/", "_").replace("²", "2").replace(" ", "")
    return f"{name}_{u}" if u else name


def _columns(unit: str) -> list[str]:
    return [
        "engine",
        "phi_deg",
        "status",
        "message",
        _c("minimum", unit),
        _c("tolerance", unit),
        "pga_at_minimum_m_s2",
        "pga_tolerance_m_s2",
        "bound_m_s2",
        "ratio_to_bound",
        "ratio_to_bound_lo",
        "alpha_u_plus_deg",
        "alpha_u_minus_deg",
        _c("search_lo", unit),
        _c("search_hi", unit),
        "n_simulations",
        "regime_below",
        "regime_above",
        "impacts_below",
        "impacts_above",
        "peak_ratio_below",
        "toppled_at_s",
        "wall_s",
        "settings",
        "versions",
    ]


def _fill(row: dict[str, Any], d: dict[str, Any], unit: str, wall: float) -> dict[str, Any]:
    mn = row.pop("minimum", None)
    tol = row.pop("tolerance", None)
    nan = float("nan")
    pga = nan if mn is None else mn * d["pga_per_unit"]
    ptol = nan if tol is None else tol * d["pga_per_unit"]
    out = {
        "engine": row["engine"],
        "phi_deg": row["phi_deg"],
        "status": row.get("status", ""),
        "message": row.get("message", ""),
        _c("minimum", unit): nan if mn is None else float(mn),
        _c("tolerance", unit): nan if tol is None else float(tol),
        "pga_at_minimum_m_s2": pga,
        "pga_tolerance_m_s2": ptol,
        "bound_m_s2": d["bound"],
        "ratio_to_bound": pga / d["bound"] if d["bound"] > 0 else nan,
        "ratio_to_bound_lo": (pga - (0.0 if math.isnan(ptol) else ptol)) / d["bound"]
        if d["bound"] > 0
        else nan,
        "alpha_u_plus_deg": d["alpha_u_plus"],
        "alpha_u_minus_deg": d["alpha_u_minus"],
        _c("search_lo", unit): d["lo"],
        _c("search_hi", unit): d["hi"],
        "n_simulations": int(row.get("n_simulations", 0)),
        "regime_below": row.get("regime_below", ""),
        "regime_above": row.get("regime_above", ""),
        "impacts_below": row.get("impacts_below", -1),
        "impacts_above": row.get("impacts_above", -1),
        "peak_ratio_below": row.get("peak_ratio_below", nan),
        "toppled_at_s": row.get("toppled_at_s", nan),
        "wall_s": wall,
        "settings": row.get("settings", "{}"),
        "versions": row.get("versions", "{}"),
    }
    return out


def _fmt(x: Any, spec: str = ".6g") -> str:
    try:
        xf = float(x)
    except (TypeError, ValueError):
        return "—"
    return "—" if not math.isfinite(xf) else format(xf, spec)


def _figure(table: Any, bound: Any, name: str, param: str) -> Figure:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax0 = plt.subplots(subplot_kw={"projection": "polar"}, figsize=(6.4, 6.4))
    ax = cast("PolarAxes", ax0)  # projection="polar" makes a PolarAxes; the stub says Axes
    ax.set_theta_zero_location("E")
    ax.set_theta_direction(1)
    phi_b = np.radians(np.append(bound["phi_deg"].to_numpy(float), 360.0))
    b = np.append(bound["bound_m_s2"].to_numpy(float), bound["bound_m_s2"].to_numpy(float)[0])
    if np.isfinite(b).any():
        ax.plot(
            phi_b, b, "k-", lw=1.2, label="quasi-static uplift bound min(g·tan α_u(φ), g·tan α_u(φ+180°))"
        )
    ga = np.append(
        bound["critical_tilt_accel_m_s2"].to_numpy(float),
        bound["critical_tilt_accel_m_s2"].to_numpy(float)[0],
    )
    ax.plot(
        phi_b,
        ga,
        "--",
        color="0.5",
        lw=1,
        label="g·tan α(φ), α the smaller critical tilt toward ±φ (not a bound)",
    )
    for i, (eng, sub) in enumerate(table.groupby("engine", sort=False)):
        sub = sub.sort_values("phi_deg")
        ok = sub[np.isfinite(sub["pga_at_minimum_m_s2"].astype(float))]
        if ok.empty:
            continue
        ph = np.radians(ok["phi_deg"].to_numpy(float))
        pga = ok["pga_at_minimum_m_s2"].to_numpy(float)
        ax.plot(ph, pga, "o", color=f"C{i}", ms=5, label=f"{eng}: PGA at the minimum toppling level")
        if len(sub) == len(ok) and len(ok) > 2:  # every direction bracketed: a guide to the eye
            ph_c, pga_c = np.append(ph, ph[0] + 2 * np.pi), np.append(pga, pga[0])
            fine = np.linspace(ph_c[0], ph_c[-1], 60 * len(ph_c))
            ax.plot(fine, np.interp(fine, ph_c, pga_c), ":", color=f"C{i}", lw=1)
        tol = ok["pga_tolerance_m_s2"].to_numpy(float)
        ax.errorbar(
            np.radians(ok["phi_deg"].to_numpy(float)), ok["pga_at_minimum_m_s2"].to_numpy(float),
            yerr=np.nan_to_num(tol), fmt="none", ecolor=f"C{i}", capsize=2,
        )  # fmt: skip
    ax.set_rmin(0.0)
    ax.set_title(f"{name}: toppling PGA per shaking azimuth [m/s²]", pad=18)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.06), fontsize=7)
    fig.text(0.5, 0.005, PHI_CONVENTION + " (the scenario's excitation.azimuth_deg)", ha="center", fontsize=7)
    fig.tight_layout(rect=(0, 0.02, 1, 1))
    return Figure(
        name="azimuth",
        figure=fig,
        table="azimuth",
        caption=(
            f"Minimum toppling level of {param} per shaking azimuth φ, as the PGA of the motion at that "
            "level (m/s², radius), for each engine (error bars: ± search tolerance; dotted: linear in φ between the directions searched); black: the quasi-static "
            "uplift bound, below which a rigid rock cannot leave its base in either sense of the shaking; "
            "dashed grey: g·tan α of the critical tilt of a rock rolling on its hull (quasi-static toppling, "
            "not a bound: a dynamic pulse can topple a rough-based rock below it). " + PHI_CONVENTION + "."
        ),
    )
