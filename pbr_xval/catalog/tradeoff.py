"""Speed–accuracy trade against experiments: ``pbr-xval choose --campaign``.

Every candidate setting (engine × profile × timestep × collision geometry) runs the campaign's
tests through the validation machinery (:mod:`pbr_xval.validation.execution`: corrected table
records, one chunk per test, the resumable Parquet store shared by every setting and by
``pbr-xval validate``). Each setting gets

* a **cost**: the mean engine wall time per test, s (the store's ``wall_s``: ``simulate`` only,
  without scene compilation or motion reading), and the sum over the tests;
* an **agreement** with the observed outcomes: the Brier score of its predictions (a
  deterministic run predicts P(topple) = 0 or 1, so its Brier score is its error rate) and F1
  (positive class "toppled").

The **Pareto front** holds the settings that no other setting beats on both cost and Brier. The
**recommendation** is the cheapest setting whose Brier is within the stated margin of the best
setting's: Brier_s − Brier_best ≤ k · SE, where SE is the standard error of the mean paired
difference d_i = (p_s,i − y_i)² − (p_best,i − y_i)² over the n tests both ran (k = 1 by default).
Costs are one run's timings: settings within the margin whose costs lie within :data:`COST_TIE`
of the cheapest one's are equally cheap, and of those the one with the lowest Brier is
recommended (a timing difference smaller than the timings' repeatability does not pick the less
accurate setting). A setting with a failed run is scored on the tests it ran but is never
recommended.
"""

from __future__ import annotations

import html
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pbr_xval.atomic import write_text_atomic

__all__ = [
    "COST_TIE",
    "Setting",
    "brier_f1",
    "candidate_settings",
    "choice_lines",
    "margin_rule",
    "pareto_front",
    "recommend",
    "run_tradeoff",
    "write_tradeoff",
]


#: relative cost difference within which two settings count as equally cheap: the repeatability
#: of the costs of one run. Three ``choose --campaign`` runs of the same 3,528 SP1 runs (18 settings,
#: the same predictions) on the same quiet machine differ in each setting's mean wall time per test
#: by −5.2 to +6.9 %, in the ratio of two settings' costs by up to 13 %; 15 % with a margin
#: (docs/catalogs.md, "Solver choice against experiments")
COST_TIE = 0.15


@dataclass(frozen=True)
class Setting:
    """One candidate: an engine, its profile (None: the engine's default) and setting overrides."""

    engine: str
    profile: str | None = None
    settings: dict[str, Any] = field(default_factory=dict)

    @property
    def settings_text(self) -> str:
        """``profile=faithful,timestep=0.001,collision=hull`` (no spaces: one token on a line)."""
        parts = [f"profile={self.profile}"] if self.profile else []
        parts += [f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in self.settings.items()]
        return ",".join(parts) or "default"

    @property
    def label(self) -> str:
        return f"{self.engine} {self.settings_text}"


def candidate_settings(
    engines: list[str],
    *,
    profiles: list[str] | None = None,
    timesteps: list[float] | None = None,
    collisions: list[str] | None = None,
) -> list[Setting]:
    """engines × profiles × timesteps × collisions; an axis an engine has no setting for is skipped.

    ``profiles`` None: each engine's default profile. ``timesteps`` None: the profile's own;
    ``collisions`` None: the profile's own (``auto``: the scene compiler's choice); an entry
    ``engine:kind`` (e.g. ``mujoco:coacd``) applies to that engine only.
    """
    from pbr_xval.engine import get_engine

    out: list[Setting] = []
    for name in engines:
        eng = get_engine(name)
        profs: dict[str, dict[str, Any]] = (
            eng.profiles() if hasattr(eng, "profiles") else {"default": eng.default_settings()}
        )
        default = str(getattr(eng, "default_profile", ""))
        names = [p for p in (profiles or []) if p in profs] or [
            default if default in profs else next(iter(profs))
        ]
        for p in names:
            keys = profs[p]
            dts: list[float | None] = list(timesteps) if (timesteps and "timestep" in keys) else [None]
            mine = [c.split(":", 1)[-1] for c in collisions or [] if ":" not in c or c.startswith(name + ":")]
            cols: list[str | None] = list(mine) if (mine and "collision" in keys) else [None]
            for dt in dts:
                for col in cols:
                    s: dict[str, Any] = {}
                    if dt is not None:
                        s["timestep"] = float(dt)
                    if col is not None:
                        s["collision"] = col
                    out.append(Setting(name, p, s))
    return out


def brier_f1(observed: np.ndarray, p: np.ndarray) -> dict[str, float]:
    """Brier score and F1 (at p ≥ 0.5) of P(topple) ``p`` against 0/1 ``observed``
    (:func:`pbr_xval.validation.scores.probabilistic_scores`, scikit-learn's metrics)."""
    from pbr_xval.validation.scores import probabilistic_scores

    y = np.asarray(observed, dtype=int)
    if y.size == 0:
        return {"brier": math.nan, "f1": math.nan}
    d = probabilistic_scores(y, np.asarray(p, dtype=float))
    return {"brier": float(d["brier"]), "f1": float(d["f1"])}


def pareto_front(cost: np.ndarray, brier: np.ndarray) -> np.ndarray:
    """Boolean mask: no other point has cost ≤ and Brier ≤ with one of them strictly lower."""
    c, b = np.asarray(cost, float), np.asarray(brier, float)
    ok = np.isfinite(c) & np.isfinite(b)
    front = np.zeros(c.size, bool)
    for i in np.flatnonzero(ok):
        dom = ok & (c <= c[i]) & (b <= b[i]) & ((c < c[i]) | (b < b[i]))
        front[i] = not dom.any()
    return front


def margin_rule(k_se: float, cost_tie: float) -> str:
    """The recommendation rule of :func:`recommend` in words — the one wording the ``recommend``
    line, ``tradeoff.json``'s ``margin_rule`` and the page all print."""
    return (
        f"the cheapest setting whose Brier exceeds the best by at most {k_se:g} standard error of the mean "
        f"paired difference of squared errors over the tests both ran; costs within {100 * cost_tie:g} % of the "
        "cheapest such setting's count as equal (one run's timings), and of those the lowest Brier is taken; "
        "a setting with failed runs is never recommended"
    )


def recommend(
    table: pd.DataFrame, sq_err: pd.DataFrame, k_se: float = 1.0, cost_tie: float = COST_TIE
) -> tuple[pd.DataFrame, int | None]:
    """Mark each setting's paired difference to the best Brier and whether it is within k·SE.

    ``table``: one row per setting (``brier``, ``cost_s_per_test``, ``n_failed``); ``sq_err``:
    tests × settings (same column order as the rows of ``table``), (p − y)², NaN where not run.
    Returns the table with ``d_brier``, ``se_paired``, ``margin``, ``within`` and the row index
    of the recommendation (None when no setting qualifies): among the settings within the margin
    whose cost is at most (1 + ``cost_tie``) × the cheapest one's, the lowest Brier (then the
    lowest cost).
    """
    t = table.copy()
    eligible = (t["n_failed"] == 0) & t["brier"].notna() & t["cost_s_per_test"].notna()
    if not eligible.any():
        for c in ("d_brier", "se_paired", "margin"):
            t[c] = math.nan
        t["within"] = False
        return t, None
    best = int(t.loc[eligible, "brier"].idxmin())
    d_list, se_list = [], []
    for i in range(len(t)):
        both = sq_err.iloc[:, i].notna() & sq_err.iloc[:, best].notna()
        d = (sq_err.iloc[:, i] - sq_err.iloc[:, best])[both].to_numpy(float)
        d_list.append(float(d.mean()) if d.size else math.nan)
        se_list.append(float(d.std(ddof=1) / math.sqrt(d.size)) if d.size > 1 else math.nan)
    t["d_brier"] = d_list
    t["se_paired"] = se_list
    t["margin"] = [k_se * s if s == s else 0.0 for s in se_list]
    t["within"] = eligible & (t["d_brier"] <= t["margin"] + 1e-12)
    t["best"] = False
    t.loc[best, "best"] = True
    cand = t[t["within"]]
    if not len(cand):
        return t, None
    cheap = cand[cand["cost_s_per_test"] <= (1.0 + cost_tie) * float(cand["cost_s_per_test"].min())]
    return t, int(cheap.sort_values(["brier", "cost_s_per_test"], kind="stable").index[0])


def run_tradeoff(
    campaign: Any,
    scn: Any,
    settings: list[Setting],
    work: Path,
    *,
    baseline: Any,
    tail: float = 3.0,
    output_dt: float = 0.01,
    workers: int | None = None,
    executor: str = "local",
    k_se: float = 1.0,
    cost_tie: float = COST_TIE,
    progress: bool = True,
    console: Any = None,
) -> dict[str, Any]:
    """Run every setting on every test of ``campaign`` into ``work/store`` (resumable); score them.

    Returns ``{"table": per-setting DataFrame, "tests": long DataFrame (setting × test),
    "recommendation": row index or None, "k_se": k_se, "summary": sweep summary dict}``.
    """
    from pbr_xval.catalog.store import load_results
    from pbr_xval.catalog.sweep import run_chunks
    from pbr_xval.validation.execution import build_validation_chunks, prepare_motions

    motions = prepare_motions(campaign, baseline, work / "motions")
    per: list[list[Any]] = []
    chunks: list[Any] = []
    for s in settings:
        cs = build_validation_chunks(
            campaign, motions, scn, [s.engine], settings={s.engine: dict(s.settings)}, tail=tail,
            output_dt=output_dt, profile=s.profile,
        )  # fmt: skip
        per.append(cs)
        chunks += cs
    summary = run_chunks(
        chunks, work / "store", executor=executor, workers=workers, progress=progress, console=console,
        description="choose",
    )  # fmt: skip
    rows = load_results(work / "store")
    obs = pd.Series({t.test: int(t.toppled) for t in campaign.tests}, name="observed")
    rec_of = {t.test: t.motion for t in campaign.tests}
    long_parts, summ, sq = [], [], {}
    for i, (s, cs) in enumerate(zip(settings, per, strict=True)):
        hashes = {c.content_hash() for c in cs}
        r = rows[rows["chunk_hash"].isin(hashes)].copy()
        r["test"] = r["motion_params"].map(lambda v: str(json.loads(v)["test"]))
        r = r.drop_duplicates("test", keep="last").set_index("test").reindex(obs.index)
        ok = r["status"] == "ok"
        p = r["toppled"].where(ok).astype(float)
        sq[i] = (p - obs) ** 2
        okt = ok.to_numpy(bool)
        sc = brier_f1(obs[okt].to_numpy(), p[okt].to_numpy())
        wall = r["wall_s"].where(ok).astype(float)
        y, q = obs[okt].to_numpy(bool), p[okt].to_numpy(float) >= 0.5
        summ.append({
            "engine": s.engine, "profile": s.profile or "", "settings": s.settings_text,
            "settings_json": json.dumps(s.settings, sort_keys=True), "n_tests": len(obs),
            "n_ok": int(okt.sum()), "n_failed": int(len(obs) - okt.sum()),
            "cost_s_per_test": float(wall.mean()) if okt.any() else math.nan,
            "cost_s_total": float(wall.sum()) if okt.any() else math.nan,
            "brier": sc["brier"], "f1": sc["f1"],
            "tp": int((y & q).sum()), "fp": int((~y & q).sum()), "fn": int((y & ~q).sum()), "tn": int((~y & ~q).sum()),
        })  # fmt: skip
        long_parts.append(pd.DataFrame({
            "engine": s.engine, "settings": s.settings_text, "test": obs.index, "record": [rec_of[t] for t in obs.index],
            "observed": obs.to_numpy(), "predicted": r["toppled"].where(ok).map(lambda v: "" if v != v else int(bool(v))).to_numpy(),
            "status": r["status"].fillna("missing").to_numpy(), "wall_s": wall.to_numpy(),
            "message": r["message"].fillna("").map(lambda m: str(m).splitlines()[0][:200] if m else "").to_numpy(),
            "pga_m_s2": r["pga"].to_numpy(float), "peak_tilt_rad": r["peak_tilt"].to_numpy(float),
        }))  # fmt: skip
    table = pd.DataFrame(summ)
    table["pareto"] = pareto_front(table["cost_s_per_test"].to_numpy(), table["brier"].to_numpy())
    table, rec = recommend(table, pd.DataFrame(sq), k_se, cost_tie)
    return {
        "table": table,
        "tests": pd.concat(long_parts, ignore_index=True),
        "recommendation": rec,
        "k_se": k_se,
        "cost_tie": cost_tie,
        "summary": summary.to_dict(),
    }


def _num(v: float, fmt: str) -> str:
    return "nan" if v != v else format(v, fmt)


def choice_lines(res: dict[str, Any]) -> list[str]:
    """``choice <engine> <settings> cost <s per test> Brier <v> F1 <v> …`` per setting, then ``recommend …``."""
    t = res["table"]
    lines = []
    for r in t.itertuples():
        lines.append(
            f"choice {r.engine} {r.settings} cost {_num(r.cost_s_per_test, '.4g')} Brier {_num(r.brier, '.4f')} "
            f"F1 {_num(r.f1, '.4f')} n {r.n_ok}/{r.n_tests} dBrier {_num(r.d_brier, '+.4f')} margin {_num(r.margin, '.4f')}"
            + (" pareto" if r.pareto else "")
            + (" best" if r.best else "")
            + ("" if r.n_failed == 0 else f" failed {r.n_failed}")
        )
    i = res["recommendation"]
    if i is None:
        lines.append("recommend none (every setting had failed runs)")
    else:
        r = t.loc[i]
        b = t[t["best"]].iloc[0]
        lines.append(
            f"recommend {r.engine} {r.settings} cost {r.cost_s_per_test:.4g} Brier {r.brier:.4f} F1 {_num(r.f1, '.4f')} "
            f"(best {b.engine} {b.settings} Brier {b.brier:.4f}; margin {r.margin:.4f} on {r.n_ok} tests; "
            f"rule: {margin_rule(res['k_se'], res['cost_tie'])})"
        )
    return lines


def _figure(res: dict[str, Any], title: str) -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import ScalarFormatter

    t = res["table"]
    fig, ax = plt.subplots(figsize=(8.4, 5.6))
    markers = {"mujoco": "o", "pybullet": "s", "dart": "^", "reference": "D", "housner": "v"}
    best = t[t["best"]] if "best" in t else t.iloc[:0]
    if len(best):
        ax.axhline(float(best["brier"].iloc[0]), color="C3", lw=0.8, ls=":", label="best Brier")
    for j, (eng, g) in enumerate(t.groupby("engine", sort=False)):
        g = g[g["cost_s_per_test"].notna() & g["brier"].notna()]
        # the bar reaches down by the margin (k SE of the paired difference to the best): a setting
        # whose bar reaches the best Brier line is within the margin
        ax.errorbar(
            g["cost_s_per_test"], g["brier"], yerr=[g["margin"].fillna(0.0), np.zeros(len(g))], fmt="none",
            ecolor=f"C{j}", elinewidth=0.8, capsize=2, alpha=0.7,
        )  # fmt: skip
        ax.scatter(g["cost_s_per_test"], g["brier"], marker=markers.get(str(eng), "P"), s=46, color=f"C{j}",
                   label=str(eng), zorder=3)  # fmt: skip
        dy = 4 if j % 2 else -10
        for r in g.itertuples():
            short = (
                r.settings if t["profile"].nunique() > 1 else r.settings.replace(f"profile={r.profile},", "")
            )
            short = short.replace("profile=", "").replace("timestep=", "dt=").replace("collision=", "")
            ax.annotate(
                short, (r.cost_s_per_test, r.brier), fontsize=7, xytext=(5, dy), textcoords="offset points"
            )
    f = t[t["pareto"]].sort_values("cost_s_per_test")
    ax.step(
        f["cost_s_per_test"],
        f["brier"],
        where="post",
        color="0.3",
        lw=1.2,
        ls="--",
        label="Pareto front",
        zorder=2,
    )
    i = res["recommendation"]
    if i is not None:
        r = t.loc[i]
        ax.scatter(
            [r.cost_s_per_test],
            [r.brier],
            s=220,
            facecolors="none",
            edgecolors="C3",
            lw=2,
            label="recommended",
            zorder=4,
        )
    c = t["cost_s_per_test"].to_numpy(float)
    if np.all(c[np.isfinite(c)] > 0) and np.nanmax(c) > 4 * np.nanmin(c):
        ax.set_xscale("log")
        ax.xaxis.set_major_formatter(ScalarFormatter())
        ax.xaxis.set_minor_formatter(ScalarFormatter())
        ax.tick_params(axis="x", which="minor", labelsize=7)
    ax.set_xlabel("cost: engine wall time per test, s")
    ax.set_ylabel("Brier score (0/1 predictions: error rate), dimensionless")
    ax.set_title(
        title + f"\nbars: {res['k_se']:g} SE of the paired Brier difference to the best", fontsize=10
    )
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig  # fmt: skip


def _engine_versions(engine: str) -> str:
    try:
        from pbr_xval.engine import get_engine

        v = get_engine(engine).versions()
        return ", ".join(f"{k} {x}" for k, x in v.items())
    except Exception as exc:  # a missing engine package: say so, never an empty panel
        return f"versions unavailable ({type(exc).__name__})"


def verdict_html(res: dict[str, Any], meta: dict[str, Any]) -> str:
    """The first screen of a ``choose --campaign`` page: what ran, the answer, the disagreements, the settings.

    Tolerance: a setting agrees with the best when its Brier exceeds the best by at most ``k_se``
    standard errors of the mean paired difference of squared errors over the tests (the measured
    spread of Brier on this campaign), as the recommendation rule says.
    """
    t = res["table"]
    i = res["recommendation"]
    n_tests, k = meta.get("tests", ""), res["k_se"]
    best = t[t.get("best", False) == True] if "best" in t else t.iloc[:0]  # noqa: E712
    ran = (
        f"Ran: {len(t)} settings (engine × profile × time step × collision geometry) on {n_tests} shake-table "
        f"tests of specimen {html.escape(str(meta.get('specimen', '')))} "
        f"({html.escape(str(meta.get('scenario', '')))}); cost = mean engine wall time per test, s; "
        "Brier of the 0/1 predictions against the lab's outcomes."
    )
    if i is None:
        answer = "No setting qualifies (every setting had failed runs or no score): no recommendation."
    else:
        r = t.loc[i]
        answer = (
            f"Recommended: <b>{html.escape(str(r['engine']))} {html.escape(str(r['settings']))}</b> — "
            f"{r['cost_s_per_test']:.3g} s per test, Brier {r['brier']:.3f}, F1 {r['f1']:.3f}"
        )
        if len(best):
            b = best.iloc[0]
            answer += (
                f"; the best Brier is {b['brier']:.3f} ({html.escape(str(b['engine']))} "
                f"{html.escape(str(b['settings']))}, {b['cost_s_per_test']:.3g} s per test)"
            )
        answer += "."
    beyond = t[(~t["within"].astype(bool)) & t["brier"].notna()] if "within" in t else t.iloc[:0]
    failed = t[t["n_failed"] > 0] if "n_failed" in t else t.iloc[:0]
    fail_items = "".join(
        f"<li>{html.escape(str(r.engine))} {html.escape(str(r.settings))}: {int(r.n_failed)} of "
        f"{int(r.n_tests)} runs failed (reasons below) — not scored, never recommended</li>"
        for r in failed.itertuples()
        if not (r.brier == r.brier)
    )
    if len(beyond) or fail_items:
        items = fail_items + "".join(
            f"<li>{html.escape(str(r.engine))} {html.escape(str(r.settings))}: Brier {r.brier:.3f}, "
            f"{r.d_brier:+.3f} vs the best (margin {r.margin:.3f}), F1 {r.f1:.3f}"
            + (f", {int(r.n_failed)} failed runs" if r.n_failed else "")
            + "</li>"
            for r in beyond.itertuples()
        )
        dis = f"<h3>Disagreement beyond tolerance</h3><ul>{items}</ul>"
    else:
        dis = "<p>Disagreement beyond tolerance: none — every setting is within the margin of the best.</p>"
    engines: dict[str, list[str]] = {}
    for r in t.itertuples():
        engines.setdefault(str(r.engine), []).append(str(r.settings))
    panel = "".join(
        f"<li><b>{html.escape(e)}</b> {html.escape(_engine_versions(e))} — {html.escape('; '.join(v))}</li>"
        for e, v in engines.items()
    )
    return (
        f'<section id="verdict"><h2>Verdict</h2><h3>Engines and settings</h3><ul>{panel}</ul>'
        f"<p>{ran}</p><p>{answer}</p>{dis}"
        f"<p>Tolerance: {k:g} standard error of the mean paired difference of squared errors to the best "
        "setting, over the tests both ran (the measured spread of Brier on this campaign).</p></section>"
    )


def write_tradeoff(res: dict[str, Any], out: Path, meta: dict[str, Any]) -> dict[str, Path]:
    """``index.html`` (Pareto plot inline), ``pareto.png``, ``settings.csv``, ``tests.csv``, ``tradeoff.json``."""
    import base64
    import io

    import matplotlib.pyplot as plt

    out.mkdir(parents=True, exist_ok=True)
    t = res["table"]
    lines = choice_lines(res)
    paths = {
        "settings": write_text_atomic(out / "settings.csv", t.to_csv(index=False)),
        "tests": write_text_atomic(out / "tests.csv", res["tests"].to_csv(index=False)),
    }
    i = res["recommendation"]
    doc = {
        **meta,
        "cost": "mean engine wall time per test (simulate only), s, on this machine",
        "brier": "mean (p − y)² with p = 0/1 predicted toppled, y = observed (= error rate)",
        "margin_rule": margin_rule(res["k_se"], res["cost_tie"]),
        "settings": json.loads(t.to_json(orient="records")),
        "recommendation": None if i is None else json.loads(t.loc[[i]].to_json(orient="records"))[0],
        "lines": lines,
        "runs": res["summary"],
    }  # fmt: skip
    paths["json"] = write_text_atomic(out / "tradeoff.json", json.dumps(doc, indent=2, default=str))
    fig = _figure(
        res,
        f"{meta.get('scenario', '')}: {meta.get('tests', '')} tests of specimen {meta.get('specimen', '')}",
    )
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    plt.close(fig)
    (out / "pareto.png").write_bytes(buf.getvalue())
    paths["png"] = out / "pareto.png"
    img = base64.b64encode(buf.getvalue()).decode()
    show = t.drop(columns=["settings_json"]).copy()
    tl = res["tests"]
    bad = tl[tl["status"] != "ok"].groupby(["engine", "settings"])["message"].agg(lambda m: sorted(set(m))[0])
    fails = "".join(
        f"<li>{html.escape(f'{e} {st}')}: {html.escape(str(m))}</li>" for (e, st), m in bad.items()
    )
    fails_html = f"<h2>Failed runs (first reason per setting)</h2><ul>{fails}</ul>" if fails else ""
    meta_rows = "".join(
        f"<tr><th>{html.escape(str(k))}</th><td>{html.escape(str(v))}</td></tr>" for k, v in meta.items()
    )
    rec_line = html.escape(lines[-1])
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>pbr-xval choose: speed–accuracy trade</title>
<style>body{{font-family:sans-serif;max-width:1200px;margin:1em auto;padding:0 1em}}
table{{border-collapse:collapse;font-size:13px}}td,th{{border:1px solid #ccc;padding:2px 6px;text-align:right}}
th{{background:#f4f4f4}}code{{background:#f4f4f4}}</style></head><body>
<h1>Speed–accuracy trade against the experiments</h1>
{verdict_html(res, meta)}
<p><b><code>{rec_line}</code></b></p>
<details><summary>Run details</summary><table>{meta_rows}</table></details>
<h2>Pareto front: cost vs Brier</h2>
<p>x: mean engine wall time per test, s (the simulation only, on this machine at the load stated above);
y: Brier score of the 0/1 predictions against the observed outcomes (equal to the error rate).
The recommendation is {html.escape(margin_rule(res["k_se"], res["cost_tie"]))}.</p>
<img alt="Pareto front, cost vs Brier" src="data:image/png;base64,{img}">
<h2>Settings</h2>
{show.to_html(index=False, escape=True, float_format=lambda v: f"{v:.4g}")}
{fails_html}
<h2>Printed lines</h2>
<pre>{html.escape(chr(10).join(lines))}</pre>
<p>Per test and setting: <code>tests.csv</code>; per setting: <code>settings.csv</code>; everything: <code>tradeoff.json</code>.</p>
</body></html>
"""  # fmt: skip
    paths["html"] = write_text_atomic(out / "index.html", page)
    return paths
