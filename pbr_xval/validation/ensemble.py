"""``pbr-xval validate --ensemble``: every test's P(topple) from the scenario's ``[uncertainty]``.

Each test × member is one catalog motion (the test's corrected table record, the member's index
and sampled values); the rock is the specimen's scenario with every table written out
(:func:`pbr_xval.catalog.predict.ensemble_rock`). The chunk worker applies the member's values,
then replaces the excitation by the test's motion — keeping the member's shaking azimuth — as
for a deterministic test (:func:`pbr_xval.catalog.tasks.scenario_dict`). Chunks are one test ×
one engine × one block of members, written to the same store as the deterministic runs
(``<out>/store/``): a rerun, or a larger selection of tests, recomputes nothing already stored.

A test's P(topple) is the share of toppled members among those that ran (NaN when none ran);
each member's engine is drawn from the mixture (``[uncertainty].engines``, restricted by
``--engine``). Every member of every test is written to ``ensemble_members.csv`` (test, member,
engine, sampled values, outcome, PGA, PGV), the input of ``pbr-xval fragility --ensemble``.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pbr_xval.uncertainty import EnsembleSpec, Member

__all__ = ["add_ensemble_model", "ensemble_counts", "ensemble_p", "run_campaign_ensemble"]

MODEL = "ensemble"


def build_ensemble_chunks(
    campaign: Any,
    motions: dict[str, Any],
    scn: Any,
    members: list[Member] | dict[str, list[Member]],
    *,
    settings: dict[str, dict[str, Any]] | None = None,
    tail: float = 3.0,
    output_dt: float = 0.01,
    block: int = 16,
    profile: str | None = None,
) -> list[Any]:
    """One chunk per test × engine × block of ``block`` member indices.

    ``members``: one list shared by every test, or test → its own members (``per_test``).
    """
    from pbr_xval.catalog.predict import ensemble_rock
    from pbr_xval.catalog.tasks import ChunkSpec
    from pbr_xval.validation.execution import _safe

    rock = ensemble_rock(scn)
    chunks = []
    for t in campaign.tests:
        mf = motions[t.test]
        groups: dict[tuple[str, int], list[dict[str, Any]]] = {}
        for m in members[t.test] if isinstance(members, dict) else members:
            assert m.engine is not None
            prm = {k: v for k, v in m.to_dict().items() if k != "design_members" or m.sampling == "lhs"}
            groups.setdefault((m.engine, m.index // block), []).append(
                {
                    "id": f"test{_safe(t.test)}__m{m.index:04d}",
                    "kind": "record",
                    "excitation": {"type": "record", "format": "table", "units": "m/s2", "dt": mf.dt},
                    "params": {"test": t.test, "motion": t.motion, **prm},
                    "path": str(mf.path),
                    "sha256": mf.sha256,
                    "duration": mf.duration,
                    "member": m.index,
                    "values": m.values,
                }
            )
        for (eng, _b), mlist in sorted(groups.items(), key=lambda kv: (kv[0][1], kv[0][0])):
            chunks.append(
                ChunkSpec(
                    catalog=f"validate_ensemble_{rock['id']}", rock=rock, motions=mlist, engine=eng,
                    profile=profile, settings=dict((settings or {}).get(eng, {})), duration="auto",
                    tail=float(tail), settle_time=float(scn.settle_time), output_dt=float(output_dt),
                    catalog_seed=int(scn.seed), tag="validate_ensemble",
                )
            )  # fmt: skip
    return chunks


def run_campaign_ensemble(
    campaign: Any,
    motions: dict[str, Any],
    scn: Any,
    spec: EnsembleSpec,
    out: Path,
    *,
    members: int | None = None,
    engines: list[str] | None = None,
    settings: dict[str, dict[str, Any]] | None = None,
    tail: float = 3.0,
    output_dt: float = 0.01,
    workers: int | None = None,
    executor: str = "local",
    progress: bool = True,
    console: Any = None,
    half_width: float | None = None,
    batch: int = 4,
) -> tuple[pd.DataFrame, Any]:
    """Run every test × member (resuming); (one row per test × member, sweep summary).

    Adaptive (``half_width`` given): members are run in batches of ``batch`` (in the design's
    order) and a test gets its next batch only while its P(topple) is undecided by the rule of
    ``pbr-xval predict`` (:func:`pbr_xval.catalog.predict.stop_rule`): it stops once the Jeffreys
    95 % interval's half-width is at most ``half_width`` or the interval lies entirely above or
    below 0.5, or at ``members``. Members go where the outcome is uncertain; chunks are one
    batch each, so a rerun with the same settings recomputes nothing.
    """
    from pbr_xval.catalog.sweep import run_chunks

    eng_list, _ = spec.mixture(engines)
    mlist: list[Member] | dict[str, list[Member]] = spec.sample(members=members, engines=eng_list)
    if spec.per_test:  # field mode: every test draws its own members
        mlist = {
            t.test: spec.for_test(t.test).sample(members=members, engines=eng_list) for t in campaign.tests
        }
    per_test = mlist if isinstance(mlist, dict) else {t.test: mlist for t in campaign.tests}
    if half_width is None:
        chunks = build_ensemble_chunks(
            campaign, motions, scn, mlist, settings=settings, tail=tail, output_dt=output_dt
        )
        summary = run_chunks(
            chunks, out / "store", executor=executor, workers=workers, progress=progress, console=console,
            description="validate --ensemble",
        )  # fmt: skip
    else:
        chunks, summary = _run_adaptive(
            campaign, motions, scn, per_test, out, half_width=half_width, batch=batch, settings=settings,
            tail=tail, output_dt=output_dt, workers=workers, executor=executor, progress=progress,
            console=console,
        )  # fmt: skip
    rows = chunk_rows(out / "store", chunks)
    recs = []
    for r in rows.itertuples():
        prm = json.loads(r.motion_params)
        rec: dict[str, Any] = {
            "test": str(prm["test"]),
            "record": prm["motion"],
            "member": int(prm["member"]),
            "engine": r.engine,
            "seed": prm["seed"],
        }
        rec.update({f"value:{k}": v for k, v in prm["values"].items()})
        rec.update(
            toppled=bool(r.toppled), status=str(r.status), pga_m_s2=r.pga, pgv_m_s=r.pgv, mu=r.mu,
            peak_tilt_rad=r.peak_tilt, toppled_at_s=r.toppled_at, wall_s=r.wall_s,
        )  # fmt: skip
        recs.append(rec)
    df = pd.DataFrame(recs)
    if not df.empty:
        df = df.drop_duplicates(["test", "member"]).sort_values(["test", "member"]).reset_index(drop=True)
    return df, summary


def _run_adaptive(
    campaign: Any,
    motions: dict[str, Any],
    scn: Any,
    per_test: dict[str, list[Member]],
    out: Path,
    *,
    half_width: float,
    batch: int,
    **kw: Any,
) -> tuple[list[Any], Any]:
    """Batches of members for the tests still undecided; (every chunk run, summed summary)."""
    from pbr_xval.catalog.sweep import LocalPool

    run_kw = {k: kw.pop(k) for k in ("executor", "workers", "progress", "console")}
    if run_kw.get("executor", "local") != "local":
        return _adaptive_batches(campaign, motions, scn, per_test, out, half_width, batch, run_kw, kw)
    # one pool for every batch: the workers start once and keep their caches
    with LocalPool(run_kw.get("workers")) as pool:
        return _adaptive_batches(
            campaign, motions, scn, per_test, out, half_width, batch, {**run_kw, "pool": pool}, kw
        )


def _adaptive_batches(
    campaign: Any, motions: dict[str, Any], scn: Any, per_test: dict[str, list[Member]], out: Path,
    half_width: float, batch: int, run_kw: dict[str, Any], kw: dict[str, Any],
) -> tuple[list[Any], Any]:  # fmt: skip
    from pbr_xval.catalog.predict import estimate, stop_rule
    from pbr_xval.catalog.sweep import run_chunks

    n_max = max((len(v) for v in per_test.values()), default=0)
    active = [t for t in campaign.tests]
    all_chunks: list[Any] = []
    done = skipped = failed = 0
    summary: Any = None
    for start in range(0, n_max, batch):
        if not active:
            break
        sub = campaign.select(tests=[t.test for t in active])
        batch_members = {t.test: per_test[t.test][start : start + batch] for t in active}
        chunks = build_ensemble_chunks(sub, motions, scn, batch_members, block=batch, **kw)
        summary = run_chunks(
            chunks, out / "store", description=f"validate --ensemble (members {start}–{start + batch - 1}, "
            f"{len(active)} undecided tests)", **run_kw,
        )  # fmt: skip
        done, skipped, failed = done + summary.done, skipped + summary.skipped, failed + summary.failed
        all_chunks += chunks
        rows = chunk_rows(out / "store", all_chunks)
        tests = [json.loads(m)["test"] for m in rows["motion_params"]]
        outcome = rows.assign(test=[str(t) for t in tests])
        outcome = outcome[outcome["status"] == "ok"]
        by_test = outcome.groupby("test")["toppled"].apply(lambda x: [bool(v) for v in x]).to_dict()
        active = [t for t in active if stop_rule(estimate(by_test.get(t.test, [])), half_width) is None]
    if summary is not None:
        summary = dataclasses.replace(summary, done=done, skipped=skipped, failed=failed)
    return all_chunks, summary


def chunk_rows(store: Path, chunks: list[Any]) -> pd.DataFrame:
    """The stored rows of ``chunks`` (files read in path order, as :func:`load_results` orders them).

    Reads only these chunks' files: the adaptive ensemble asks after every batch, and the store
    also holds the deterministic runs and every earlier batch (the same rows as reading the
    whole store and keeping these chunks' hashes).
    """
    import pyarrow.dataset as ds

    from pbr_xval.catalog import store as st

    hashes = {c.content_hash() for c in chunks}
    files = sorted({p for p in (st.chunk_path(store, c) for c in chunks) if p.is_file()})
    if not files:
        return st._schema().empty_table().to_pandas()
    table = ds.dataset([str(f) for f in files], format="parquet", schema=st._schema()).to_table()
    rows = table.to_pandas()
    return rows[rows["chunk_hash"].isin(hashes)]


def ensemble_counts(member_rows: pd.DataFrame, tests: list[str]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per test (in ``tests`` order): members that toppled (k), members that ran (n), failed runs.

    ``toppled`` may be booleans (the store) or their text (``ensemble_members.csv`` read back:
    "True", "1", "1.0" count as toppled)."""
    k = np.zeros(len(tests), dtype=int)
    n_ok = np.zeros(len(tests), dtype=int)
    n_bad = np.zeros(len(tests), dtype=int)
    if member_rows.empty:
        return k, n_ok, n_bad
    toppled = member_rows["toppled"].astype(str).str.lower().isin(("true", "1", "1.0"))
    g = member_rows.assign(toppled=toppled).groupby("test")
    for j, t in enumerate(tests):
        if t not in g.groups:
            continue
        sub = g.get_group(t)
        ok = sub["status"] == "ok"
        n_ok[j], n_bad[j] = int(ok.sum()), int((~ok).sum())
        k[j] = int(sub.loc[ok, "toppled"].sum())
    return k, n_ok, n_bad


def ensemble_p(member_rows: pd.DataFrame, tests: list[str]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per test (in ``tests`` order): P(topple) = (k + ½) / (n + 1), the Jeffreys posterior mean of
    the k toppled of the n members that ran (:func:`pbr_xval.uncertainty.p_topple`; NaN when no
    member ran), members that ran, failed runs."""
    from pbr_xval.uncertainty import p_topple

    k, n_ok, n_bad = ensemble_counts(member_rows, tests)
    p = np.array([p_topple(int(a), int(b)) for a, b in zip(k, n_ok, strict=True)], dtype=float)
    return p, n_ok, n_bad


def add_ensemble_model(res: Any, p: np.ndarray, n_ok: np.ndarray, *, evaluated_on: str) -> None:
    """Add the ensemble's P(topple) to a validation result (``p_ensemble``, a scores row)."""
    from pbr_xval.validation import campaign_report as report

    add_model = getattr(report, "add_model", None)
    if add_model is not None:
        add_model(res, MODEL, p, kind="ensemble", evaluated_on=evaluated_on)
    else:  # scores without the report's probabilistic models: the same row, computed here
        from pbr_xval.validation.metrics import score
        from pbr_xval.validation.scores import probabilistic_scores

        obs = res.outcomes["observed"].to_numpy(int)
        res.outcomes[f"p_{MODEL}"] = p
        ok = np.isfinite(p)
        s = score(obs[ok].astype(bool), p[ok] >= 0.5).to_dict()
        prob = probabilistic_scores(obs[ok], p[ok])
        row = {"model": MODEL, "kind": "ensemble", "evaluated_on": evaluated_on, **s}
        row.update({k: prob[k] for k in ("brier", "log_loss", "auc")})
        res.scores = pd.concat([res.scores, pd.DataFrame([row])], ignore_index=True)
    res.outcomes[f"members_{MODEL}"] = n_ok


def ensemble_lines(res: Any) -> list[str]:
    """``F1 ensemble <v>``, and ``Brier ensemble <v>`` unless the report prints every model's Brier."""
    from pbr_xval.validation import campaign_report as report

    s = res.scores.set_index("model")
    lines = [f"F1 {MODEL} {s.loc[MODEL, 'f1']:.4f}"]
    if not hasattr(report, "brier_lines"):
        lines.append(f"Brier {MODEL} {s.loc[MODEL, 'brier']:.4f}")
    return lines


def run_ensemble(
    res: Any,
    campaign: Any,
    motions: dict[str, Any],
    scn: Any,
    spec: EnsembleSpec,
    out: Path,
    *,
    members: int | None = None,
    engines: list[str] | None = None,
    settings: dict[str, dict[str, Any]] | None = None,
    tail: float = 3.0,
    workers: int | None = None,
    executor: str = "local",
    progress: bool = True,
    console: Any = None,
    half_width: float | None = None,
    batch: int = 4,
) -> dict[str, Any]:
    """Run the ensemble of every test, add the ``ensemble`` model to ``res``, write
    ``ensemble_members.csv``; returns what the report records about it (``half_width``: the
    adaptive mode of :func:`run_campaign_ensemble`)."""
    import time

    from pbr_xval.atomic import write_text_atomic

    t0 = time.perf_counter()
    df, summary = run_campaign_ensemble(
        campaign, motions, scn, spec, out, members=members, engines=engines, settings=settings, tail=tail,
        workers=workers, executor=executor, progress=progress, console=console, half_width=half_width,
        batch=batch,
    )  # fmt: skip
    tests = [t.test for t in campaign.tests]
    p, n_ok, n_bad = ensemble_p(df, tests)
    n = int(members or spec.members)
    eng_list, weights = spec.mixture(engines)
    how = (
        f"{n} members"
        if half_width is None
        else (
            f"up to {n} members, adaptive: batches of {batch} until the Jeffreys 95 % half-width ≤ {half_width:g} "
            f"or the interval excludes 0.5; mean {float(np.mean(n_ok)):.1f} members per test"
        )
    )
    add_ensemble_model(
        res, p, n_ok,
        evaluated_on=(
            f"all tests (no fitting): (k + 1/2) / (n + 1) of k toppled of {how} ({spec.sampling}, seed {spec.seed})"
        ),
    )  # fmt: skip
    out.mkdir(parents=True, exist_ok=True)
    write_text_atomic(out / "ensemble_members.csv", df.to_csv(index=False), hidden=True)
    return {
        "ensemble_members": n,
        "ensemble_engines": ", ".join(eng_list),
        "ensemble_engine_weights": weights,
        "ensemble_uncertainty": spec.normalised(),
        "ensemble_failed_runs": int(n_bad.sum()) + int(summary.failed),
        "ensemble_chunks_run_skipped_failed": f"{summary.done}/{summary.skipped}/{summary.failed}",
        "ensemble_wall_s": round(time.perf_counter() - t0, 1),
        "ensemble_adaptive": None if half_width is None else {"half_width": half_width, "batch": batch},
        "ensemble_member_runs": int(n_ok.sum() + n_bad.sum()),
    }
