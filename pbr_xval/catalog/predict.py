"""``pbr-xval predict``: P(topple) of a scenario from its ``[uncertainty]`` ensemble.

The ensemble runs through the catalog machinery: the scenario (``[uncertainty]`` removed,
every table written out, file paths absolute) is one ``shape = "scenario"`` catalog rock, each
member one motion of ``kind = "scenario"`` carrying its index and sampled values (the chunk
worker applies them: :func:`pbr_xval.catalog.tasks.scenario_dict`). Chunks are one engine ×
one block of ``batch`` consecutive members, written to ``<out>/store/`` (resumable: a rerun,
or a run with more members, recomputes nothing already stored).

P(topple) comes from the k toppled of the n members that ran (failed runs are counted and left
out): the Jeffreys posterior mean (k + ½) / (n + 1) (:func:`pbr_xval.uncertainty.p_topple`: the
Bayes forecast under the Brier score; the raw share k / n is recorded beside it) with the Jeffreys
interval (:func:`pbr_xval.uncertainty.jeffreys_interval`) of the same posterior. The
adaptive mode adds members a batch at a time, in design order, and stops once the interval's
half-width is at most ``half_width`` or the interval lies entirely above or below 0.5.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd

from pbr_xval.uncertainty import EnsembleSpec, Member, jeffreys_interval, p_topple

__all__ = [
    "Estimate",
    "PredictResult",
    "ensemble_rock",
    "estimate",
    "member_motion",
    "run_members",
    "run_predict",
    "stop_rule",
    "write_predict",
]

LEVEL = 0.95


@dataclass(frozen=True)
class Estimate:
    """k toppled of n members that ran; P(topple) ``p`` = (k + ½) / (n + 1) (the Jeffreys posterior
    mean) with the Jeffreys interval [lo, hi]; ``share`` = k / n."""

    k: int
    n: int
    p: float
    lo: float
    hi: float

    @property
    def share(self) -> float:
        return self.k / self.n if self.n else math.nan

    @property
    def half_width(self) -> float:
        return (self.hi - self.lo) / 2

    def to_dict(self) -> dict[str, Any]:
        return {
            "k": self.k,
            "n": self.n,
            "p": self.p,
            "share": self.share,
            "lo": self.lo,
            "hi": self.hi,
            "half_width": self.half_width,
        }


def estimate(toppled: Sequence[bool], level: float = LEVEL) -> Estimate:
    k, n = int(sum(bool(x) for x in toppled)), len(toppled)
    lo, hi = jeffreys_interval(k, n, level)
    return Estimate(k=k, n=n, p=p_topple(k, n), lo=lo, hi=hi)


def stop_rule(est: Estimate, half_width: float | None) -> str | None:
    """Why an adaptive ensemble may stop now (None: keep adding members)."""
    if est.n == 0:
        return None
    if half_width is not None and est.half_width <= half_width:
        return f"half-width {est.half_width:.3f} ≤ {half_width:g}"
    if est.lo > 0.5:
        return f"decided: the interval lies entirely above 0.5 (lower end {est.lo:.3f})"
    if est.hi < 0.5:
        return f"decided: the interval lies entirely below 0.5 (upper end {est.hi:.3f})"
    return None


# ------------------------------------------------------------------ chunks
def _abs_paths(scn: Any, d: dict[str, Any]) -> dict[str, str]:
    """Make every referenced file's path absolute in ``d``; key → SHA-256 of the file."""
    from pbr_xval.hashing import file_sha256

    shas = {}
    for key, path in scn.referenced_files().items():
        node = d
        parts = key.split(".")
        for p in parts[:-1]:
            node = node[p]
        node[parts[-1]] = str(Path(path).resolve())
        shas[key] = file_sha256(path)
    return shas


def ensemble_rock(scn: Any) -> dict[str, Any]:
    """The catalog rock that carries a scenario for its members (every table written out).

    The files' SHA-256 and the base scenario's hash are part of the rock (so of every chunk's
    hash): a changed mesh or record is recomputed, a moved one is not.
    """
    import re

    from pbr_xval.uncertainty import base_tables

    d = base_tables(scn)
    shas = _abs_paths(scn, d)
    mu = float(scn.contact.friction_static)
    return {
        "id": re.sub(r"[^A-Za-z0-9_.\-]", "_", scn.name),
        "shape": "scenario",
        "scenario": d,
        "files_sha256": shas,
        "friction_min": mu,
        "friction_max": mu,
    }


def member_motion(scn: Any, m: Member) -> dict[str, Any]:
    """Member ``m`` as a ``kind = "scenario"`` catalog motion (the scenario's own excitation)."""
    return {
        "id": f"m{m.index:04d}",
        "kind": "scenario",
        "member": m.index,
        "values": m.values,
        # the design size matters for a Latin hypercube only: a Sobol or random member is the same
        # in any ensemble size, so its chunks are reused when members are added
        "params": {k: v for k, v in m.to_dict().items() if k != "design_members" or m.sampling == "lhs"},
        "duration": float(scn.duration),
    }


def member_chunks(
    rock: dict[str, Any],
    motions: list[tuple[Member, dict[str, Any]]],
    *,
    batch: int,
    settings: dict[str, dict[str, Any]] | None,
    profile: str | None,
    duration: float | str,
    tail: float,
    seed: int,
    settle_time: float,
    output_dt: float,
    catalog: str,
    tag: str,
) -> list[Any]:
    """One chunk per engine × block of ``batch`` member indices ([k·batch, (k+1)·batch))."""
    from pbr_xval.catalog.tasks import ChunkSpec

    groups: dict[tuple[str, int], list[dict[str, Any]]] = {}
    for m, mot in motions:
        assert m.engine is not None
        groups.setdefault((m.engine, m.index // batch), []).append(mot)
    out = []
    for (eng, _blk), mlist in sorted(groups.items(), key=lambda kv: (kv[0][1], kv[0][0])):
        out.append(
            ChunkSpec(
                catalog=catalog, rock=rock, motions=mlist, engine=eng, profile=profile,
                settings=dict((settings or {}).get(eng, {})), duration=duration, tail=float(tail),
                settle_time=float(settle_time), output_dt=float(output_dt), catalog_seed=int(seed), tag=tag,
            )
        )  # fmt: skip
    return out


def run_members(
    scn: Any,
    members: list[Member],
    store: Path,
    *,
    batch: int = 4,
    settings: dict[str, dict[str, Any]] | None = None,
    profile: str | None = None,
    workers: int | None = None,
    executor: str = "local",
    progress: bool = True,
    console: Any = None,
    pool: Any = None,
) -> tuple[pd.DataFrame, Any]:
    """Run ``members`` of ``scn`` into ``store`` (resuming); (one row per member, sweep summary).

    ``pool``: a :class:`~pbr_xval.catalog.sweep.LocalPool` kept across calls (adaptive batches).
    """
    from pbr_xval.catalog.store import load_results
    from pbr_xval.catalog.sweep import run_chunks

    rock = ensemble_rock(scn)
    chunks = member_chunks(
        rock, [(m, member_motion(scn, m)) for m in members], batch=batch, settings=settings, profile=profile,
        duration=float(scn.duration), tail=0.0, seed=int(scn.seed), settle_time=float(scn.settle_time),
        output_dt=float(scn.output_dt), catalog=f"predict_{rock['id']}", tag="predict",
    )  # fmt: skip
    summary = run_chunks(
        chunks, store, executor=executor, workers=workers, progress=progress, console=console,
        description="predict", pool=pool,
    )  # fmt: skip
    hashes = {c.content_hash() for c in chunks}
    rows = load_results(store)
    rows = rows[rows["chunk_hash"].isin(hashes)].copy()
    return member_table(rows, members), summary


def member_table(rows: pd.DataFrame, members: list[Member]) -> pd.DataFrame:
    """One row per member: index, engine, sampled values (``value:<key>``), outcome and run facts."""
    want = {m.index: m for m in members}
    recs = []
    for r in rows.itertuples():
        prm = json.loads(r.motion_params)
        i = int(prm["member"])
        m = want.get(i)
        if m is None or m.engine != r.engine:
            continue
        rec: dict[str, Any] = {"member": i, "engine": r.engine}
        rec.update({f"value:{k}": v for k, v in m.values.items()})
        rec.update(
            toppled=bool(r.toppled), status=str(r.status), toppled_at_s=r.toppled_at, peak_tilt_rad=r.peak_tilt,
            pga_m_s2=r.pga, pgv_m_s=r.pgv, wall_s=r.wall_s, message=r.message, ensemble_seed=m.seed,
            sampling=m.sampling, design_members=m.design_members,
        )  # fmt: skip
        recs.append(rec)
    df = pd.DataFrame(recs)
    if df.empty:
        return pd.DataFrame(columns=["member", "engine", "toppled", "status"])
    return df.drop_duplicates("member").sort_values("member").reset_index(drop=True)


def run_member(
    scn: Any,
    spec: EnsembleSpec,
    index: int,
    *,
    members: int | None = None,
    engines: list[str] | None = None,
    settings: dict[str, Any] | None = None,
) -> tuple[Member, Any]:
    """Re-run member ``index`` in this process: (member, trajectory), bit for bit the ensemble's run.

    The trajectory's ``scene_info["ensemble_member"]`` records the member (index, engine,
    values, seed, sampling) and the base scenario's hash; its ``scenario_hash`` is the member's
    own scenario's.
    """
    from pbr_xval.runner import run_scene
    from pbr_xval.scene import compile_scene
    from pbr_xval.uncertainty import member_scenario

    eng_list, _ = spec.mixture(engines)
    m = spec.member(index, members=members, engines=eng_list)
    if m.engine is None:
        raise ValueError("no engine: give one, or engines = [...] in [uncertainty]")
    mscn = member_scenario(scn, m)
    traj = run_scene(compile_scene(mscn), m.engine, settings)
    traj.scene_info["ensemble_member"] = {**m.to_dict(), "base_scenario_hash": scn.content_hash()}
    return m, traj


# ------------------------------------------------------------------ predict
@dataclass
class PredictResult:
    scenario: str
    scenario_hash: str
    spec: dict[str, Any]
    engines: list[str]
    weights: list[float] | None
    members: pd.DataFrame
    overall: Estimate
    per_engine: dict[str, Estimate]
    failed: int
    requested: int
    stop: str
    batches: list[dict[str, Any]] = field(default_factory=list)
    wall_s: float = 0.0
    chunks_failed: int = 0

    def to_dict(self) -> dict[str, Any]:
        return {
            "scenario": self.scenario,
            "scenario_hash": self.scenario_hash,
            "uncertainty": self.spec,
            "engines": self.engines,
            "engine_weights": self.weights,
            "interval": f"Jeffreys {int(LEVEL * 100)} % (Beta(k + 1/2, n - k + 1/2) quantiles)",
            "estimate": "Jeffreys posterior mean (k + 1/2) / (n + 1); share = k / n",
            "p_topple": self.overall.to_dict(),
            "per_engine": {e: v.to_dict() for e, v in self.per_engine.items()},
            "members_run": len(self.members),
            "members_requested": self.requested,
            "failed_runs": self.failed,
            "stop": self.stop,
            "batches": self.batches,
            "wall_s": self.wall_s,
        }


def _estimates(df: pd.DataFrame, engines: list[str]) -> tuple[Estimate, dict[str, Estimate], int]:
    ok = df[df["status"] == "ok"] if len(df) else df
    overall = estimate(list(ok["toppled"]) if len(ok) else [])
    per = {e: estimate(list(ok.loc[ok["engine"] == e, "toppled"]) if len(ok) else []) for e in engines}
    return overall, per, int(len(df) - len(ok))


def run_predict(
    scn: Any,
    out: Path,
    *,
    spec: EnsembleSpec,
    members: int | None = None,
    engines: list[str] | None = None,
    half_width: float | None = None,
    batch: int = 4,
    settings: dict[str, dict[str, Any]] | None = None,
    profile: str | None = None,
    workers: int | None = None,
    executor: str = "local",
    progress: bool = True,
    console: Any = None,
    on_batch: Callable[[int, Estimate], None] | None = None,
) -> PredictResult:
    """Run the ensemble (all ``members`` at once, or adaptively with ``half_width``)."""
    n_max = int(members or spec.members)
    eng_list, weights = spec.mixture(engines)
    all_members = spec.sample(members=n_max, engines=eng_list)
    store = out / "store"
    t0 = time.perf_counter()
    batches: list[dict[str, Any]] = []
    failed_chunks = 0
    if half_width is None:
        df, summary = run_members(
            scn, all_members, store, batch=batch, settings=settings, profile=profile, workers=workers,
            executor=executor, progress=progress, console=console,
        )  # fmt: skip
        failed_chunks = summary.failed
        overall, per, failed = _estimates(df, eng_list)
        stop = f"all {n_max} members run"
    else:
        import contextlib

        from pbr_xval.catalog.sweep import LocalPool

        stop = ""
        upto = 0
        df = pd.DataFrame()
        # one pool for every batch: the workers start once (not once per batch of members)
        pool_ctx: Any = LocalPool(workers) if executor == "local" else contextlib.nullcontext()
        with pool_ctx as pool:
            while upto < n_max:
                upto = min(n_max, upto + batch)
                df, summary = run_members(
                    scn, all_members[:upto], store, batch=batch, settings=settings, profile=profile,
                    workers=workers, executor=executor, progress=progress, console=console, pool=pool,
                )  # fmt: skip
                failed_chunks += summary.failed
                overall, per, failed = _estimates(df, eng_list)
                batches.append({"members": upto, **overall.to_dict()})
                if on_batch is not None:
                    on_batch(upto, overall)
                rule = stop_rule(overall, half_width)
                if rule is not None:
                    stop = f"{rule} after {upto} members"
                    break
        if not stop:
            stop = f"the member limit ({n_max}) was reached with half-width {overall.half_width:.3f} > {half_width:g}"
    return PredictResult(
        scenario=scn.name, scenario_hash=scn.content_hash(), spec=spec.normalised(), engines=eng_list,
        weights=weights, members=df, overall=overall, per_engine=per, failed=failed, requested=n_max,
        stop=stop, batches=batches, wall_s=time.perf_counter() - t0, chunks_failed=failed_chunks,
    )  # fmt: skip


def format_predict(res: PredictResult) -> list[str]:
    o = res.overall
    lines = [
        f"P(topple) = {o.p:.3f} [{o.lo:.3f}, {o.hi:.3f}] (Jeffreys 95 % interval, P its posterior mean "
        f"(k + ½) / (n + 1); {o.k} of {o.n} members toppled)"
    ]
    for e, est in res.per_engine.items():
        share = est.n / o.n if o.n else 0.0
        lines.append(
            f"  {e}: P = {est.p:.3f} [{est.lo:.3f}, {est.hi:.3f}] (n = {est.n}, {100 * share:.0f} % of members)"
        )
    if res.failed:
        lines.append(f"  {res.failed} member run(s) failed and are left out (see members.csv)")
    lines.append(f"stopped: {res.stop}")
    return lines


def write_predict(res: PredictResult, out: Path) -> dict[str, Path]:
    """``members.csv`` (one row per member, units in the column names) and ``predict.json``."""
    from pbr_xval.atomic import write_text_atomic

    out.mkdir(parents=True, exist_ok=True)
    csv_path = out / "members.csv"
    js_path = out / "predict.json"
    write_text_atomic(csv_path, res.members.to_csv(index=False), hidden=True)
    d = res.to_dict()
    d["members"] = json.loads(res.members.to_json(orient="records"))
    write_text_atomic(js_path, json.dumps(d, indent=2, default=str) + "\n", hidden=True)
    return {"csv": csv_path, "json": js_path}
