"""Solver choice: calibrate engines × settings on a catalog subset against a reference engine,
recommend the cheapest within an accuracy budget, project the full catalog's cost.

Metric: when every calibration rock has at least ``[choose] min_runs_for_fit`` runs and both the
reference's and the candidate's PGA fragility fits succeed (status ``ok``), the metric is the
largest |θ/θ_ref − 1| over the rocks (``fragility_median``); otherwise it is the fraction of
runs whose toppled/not outcome agrees with the reference (``outcome_agreement``), passing when
≥ 1 − budget. The report states which metric was used.
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path
from typing import Any

import numpy as np

from pbr_xval.catalog.spec import Catalog
from pbr_xval.catalog.store import load_results, write_text_atomic
from pbr_xval.catalog.sweep import run_chunks
from pbr_xval.catalog.tasks import ChunkSpec, build_chunks, run_chunk

__all__ = ["choose", "format_choice", "write_choice"]


def _subset(cat: Catalog) -> tuple[list[str], list[dict[str, Any]]]:
    c = cat.choose
    ids = [r["id"] for r in cat.rocks]
    rocks = [i for i in c.rocks if i in ids] if isinstance(c.rocks, list) else ids[: c.rocks]
    k = min(c.motions, len(cat.motions))
    idx = sorted({round(v) for v in np.linspace(0, len(cat.motions) - 1, k)})
    return rocks, [cat.motions[i] for i in idx]


def _engine_ok(name: str) -> str | None:
    from pbr_xval.catalog.tasks import worker_engine

    try:
        worker_engine(name)
        return None
    except Exception as exc:
        return f"{type(exc).__name__}: {exc}"


def _pick_reference(cat: Catalog, rocks: list[str], motions: list[dict[str, Any]]) -> tuple[str, str]:
    """(engine, why): the configured reference if it imports, applies and is fast enough."""
    c = cat.choose
    ref, fb = c.reference_engine, c.fallback_engine
    err = _engine_ok(ref)
    if err:
        return fb, f"reference engine {ref!r} unavailable ({err}); fell back to {fb!r}"
    probe = build_chunks(
        cat, engines=[ref], chunk_size=1, rocks=rocks[:1], motions=motions[-1:], tag="choose"
    )[0]
    t0 = time.perf_counter()
    rows, _ = run_chunk(probe)
    dt = time.perf_counter() - t0
    if rows[0]["status"] != "ok":
        return (
            fb,
            f"reference engine {ref!r} cannot run the calibration set ({rows[0]['status']}: {rows[0]['message'][:120]}); fell back to {fb!r}",
        )
    if dt > c.reference_max_seconds:
        return (
            fb,
            f"reference engine {ref!r} took {dt:.1f} s per simulation (> {c.reference_max_seconds} s); fell back to {fb!r}",
        )
    return ref, f"reference engine {ref!r} ({dt:.2f} s for a probe simulation)"


def _candidates(cat: Catalog) -> list[tuple[str, str | None, dict[str, Any]]]:
    from pbr_xval.catalog.tasks import worker_engine

    c = cat.choose
    out: list[tuple[str, str | None, dict[str, Any]]] = []
    for name in c.engines or cat.engines:
        try:
            eng = worker_engine(name)
        except Exception:
            continue
        profs = eng.profiles() if hasattr(eng, "profiles") else {"default": eng.default_settings()}
        names = [p for p in c.profiles if p in profs] or [getattr(eng, "default_profile", next(iter(profs)))]
        for p in names:
            if "timestep" in profs[p]:
                for dt in c.timesteps:
                    out.append((name, p, {"timestep": dt}))
            else:
                out.append((name, p, {}))
    return out


def choose(
    cat: Catalog, budget: float, out: str | Path, *, workers: int | None = None, console: Any = None
) -> dict[str, Any]:
    """Run the calibration and return the report dict (see :func:`format_choice`)."""
    from pbr_xval.catalog.fragility import fit_lognormal

    out = Path(out)
    store_dir = out / "_choose"
    rocks, motions = _subset(cat)
    ref, ref_why = _pick_reference(cat, rocks, motions)
    chunks: list[ChunkSpec] = build_chunks(cat, engines=[ref], rocks=rocks, motions=motions, tag="choose")
    cands = _candidates(cat)
    cand_keys = []
    for name, prof, s in cands:
        cs = build_chunks(
            cat, engines=[name], profile=prof, rocks=rocks, motions=motions, settings={name: s}, tag="choose"
        )
        chunks += cs
        cand_keys.append((cs[0].engine_label, prof or "", cs[0].settings))
    summary = run_chunks(
        chunks,
        store_dir,
        workers=workers,
        console=console,
        progress=console is not None,
        description="calibration",
    )
    df = load_results(store_dir)
    ref_label = ref.rsplit(":", 1)[-1]
    ref_chunk_settings = json.dumps(
        build_chunks(cat, engines=[ref], rocks=rocks[:1], motions=motions[:1])[0].settings,
        sort_keys=True,
        separators=(",", ":"),
    )
    rdf = df[(df["engine"] == ref_label) & (df["profile"] == "") & (df["settings"] == ref_chunk_settings)]
    rdf = rdf.drop_duplicates(["rock_id", "motion_id"]).set_index(["rock_id", "motion_id"])
    c = cat.choose
    use_fit = all(
        (rdf.loc[r]["status"] == "ok").sum() >= c.min_runs_for_fit
        for r in rocks
        if r in rdf.index.get_level_values(0)
    )
    ref_fits = {}
    if use_fit:
        for r in rocks:
            g = rdf.loc[r]
            g = g[g["status"] == "ok"]
            f = fit_lognormal(
                g["pga"].to_numpy(), g["toppled"].to_numpy(), "pga", min_runs=c.min_runs_for_fit
            )
            ref_fits[r] = f
            if f.status != "ok":
                use_fit = False
    metric = "fragility_median" if use_fit else "outcome_agreement"
    results = []
    for (name, prof, s), (label, p, settings) in zip(cands, cand_keys, strict=True):
        sj = json.dumps(settings, sort_keys=True, separators=(",", ":"))
        g = df[(df["engine"] == label) & (df["profile"] == p) & (df["settings"] == sj)].drop_duplicates(
            ["rock_id", "motion_id"]
        )
        g = g.set_index(["rock_id", "motion_id"])
        common = g.index.intersection(rdf.index)
        okmask = (g.loc[common, "status"] == "ok") & (rdf.loc[common, "status"] == "ok")
        n_ok = int(okmask.sum())
        agree = (
            float((g.loc[common, "toppled"][okmask] == rdf.loc[common, "toppled"][okmask]).mean())
            if n_ok
            else math.nan
        )
        s_per_sim = float(g["wall_s"][g["status"] == "ok"].mean()) if n_ok else math.nan
        entry: dict[str, Any] = {"engine": name, "profile": prof, "settings": s, "n_runs": len(g), "n_compared": n_ok,
                                 "agreement": agree, "s_per_sim": s_per_sim}  # fmt: skip
        if metric == "fragility_median":
            diffs = {}
            for r in rocks:
                gr = g.loc[r] if r in g.index.get_level_values(0) else None
                if gr is None:
                    diffs[r] = math.nan
                    continue
                gr = gr[gr["status"] == "ok"]
                f = fit_lognormal(
                    gr["pga"].to_numpy(), gr["toppled"].to_numpy(), "pga", min_runs=c.min_runs_for_fit
                )
                diffs[r] = f.theta / ref_fits[r].theta - 1.0 if f.status == "ok" else math.nan
            entry["median_rel_diff"] = diffs
            worst = max((abs(v) for v in diffs.values()), default=math.nan)
            entry["error"] = worst if all(v == v for v in diffs.values()) else math.inf
            entry["passes"] = bool(entry["error"] <= budget)
        else:
            entry["error"] = 1.0 - agree if agree == agree else math.inf
            entry["passes"] = bool(
                n_ok > 0 and entry["error"] <= budget + 1e-12 and n_ok == len(common) and len(common) > 0
            )
        results.append(entry)
    passing = [e for e in results if e["passes"] and e["s_per_sim"] == e["s_per_sim"]]
    rec = min(passing, key=lambda e: e["s_per_sim"]) if passing else None
    n_sims = len(cat.rocks) * len(cat.motions)
    proj = None
    if rec is not None:
        core_s = n_sims * rec["s_per_sim"]
        proj = {
            "n_rocks": len(cat.rocks), "n_motions": len(cat.motions), "n_simulations": n_sims,
            "s_per_sim": rec["s_per_sim"], "core_hours": core_s / 3600.0, "cores": c.cores,
            "wall_hours": core_s / 3600.0 / c.cores,
        }  # fmt: skip
    return {
        "catalog": cat.name,
        "budget": budget,
        "metric": metric,
        "metric_note": (
            "largest |θ_PGA/θ_PGA,ref − 1| over the calibration rocks (lognormal MLE)"
            if metric == "fragility_median"
            else "fraction of calibration runs whose toppled/not outcome differs from the reference (too few runs per rock for a fragility fit, or a degenerate reference fit)"
        ),
        "reference": ref,
        "reference_note": ref_why,
        "calibration": {"rocks": rocks, "motions": [m["id"] for m in motions], "chunks": summary.to_dict()},
        "candidates": results,
        "recommendation": rec,
        "projection": proj,
    }


def format_choice(res: dict[str, Any]) -> str:
    lines = [
        f"## Solver choice for catalog `{res['catalog']}`",
        "",
        f"- reference: {res['reference_note']}",
        f"- calibration subset: {len(res['calibration']['rocks'])} rocks × {len(res['calibration']['motions'])} motions",
        f"- metric: **{res['metric']}** — {res['metric_note']}; budget {res['budget']:g}",
        "",
        "| engine | profile | settings | error | agreement | s/sim | passes |",
        "|---|---|---|---|---|---|---|",
    ]
    for e in sorted(
        res["candidates"], key=lambda e: e["s_per_sim"] if e["s_per_sim"] == e["s_per_sim"] else math.inf
    ):
        lines.append(
            f"| {e['engine']} | {e['profile']} | {json.dumps(e['settings'])} | {e['error']:.4g} | {e['agreement']:.3f} | "
            f"{e['s_per_sim']:.4g} | {'yes' if e['passes'] else 'no'} |"
        )
    lines.append("")
    rec = res["recommendation"]
    if rec is None:
        lines.append("**No candidate meets the budget**; loosen the budget or add finer settings.")
    else:
        p = res["projection"]
        lines += [
            f"**Recommendation:** `{rec['engine']}` profile `{rec['profile']}` settings `{json.dumps(rec['settings'])}` "
            f"(error {rec['error']:.4g} ≤ {res['budget']:g}, {rec['s_per_sim']:.4g} s per simulation).",
            "",
            f"Projected full catalog: {p['n_rocks']} rocks × {p['n_motions']} motions = {p['n_simulations']} simulations, "
            f"{p['core_hours']:.3g} core-hours, {p['wall_hours']:.3g} h wall on {p['cores']} cores.",
        ]
    return "\n".join(lines) + "\n"


def write_choice(res: dict[str, Any], out: str | Path) -> tuple[Path, Path]:
    out = Path(out)
    md = write_text_atomic(out / "choose.md", format_choice(res))
    js = write_text_atomic(out / "choose.json", json.dumps(res, indent=2, default=str, allow_nan=True))
    return md, js
