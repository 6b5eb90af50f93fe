"""The plain function behind ``pbr-xval validate`` (exit codes: 0 done, 1 some runs failed, 2 bad input)."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

__all__ = ["validate_command"]


def validate_command(
    campaign: Path,
    *,
    specimen: int,
    scenario: Path | None,
    engines: list[str],
    out: Path | None = None,
    tests: str | None = None,
    limit: int | None = None,
    folds: int = 4,
    highpass: float = 0.3,
    lowpass: float = 25.0,
    detrend: str = "linear",
    resample: float = 200.0,
    tail: float = 3.0,
    workers: int = 2,
    chunk_size: int = 1,
    baseline_source: str = "auto",
    sets: list[str] | None = None,
    console: Any = None,
    progress: bool = True,
    transfer: str | None = None,
    ensemble: bool = False,
    members: int | None = None,
) -> int:
    """Validate the inputs (campaign, scenario, engines) in full, run, score, write the report."""
    from rich.console import Console
    from rich.markup import escape

    from pbr_xval.cli._app import _parse_sets
    from pbr_xval.engine import get_engine
    from pbr_xval.scenario import ScenarioError, load_scenario
    from pbr_xval.validation.campaign import Baseline, CampaignError, load_campaign
    from pbr_xval.validation.report import brier_lines, evaluate, f1_lines, write_report
    from pbr_xval.validation.runner import run_campaign

    console = console or Console()
    err = Console(stderr=True)

    def fail(msg: str) -> int:
        err.print(f"[red]error:[/] {escape(msg)}")
        return 2

    if scenario is None:
        return fail("--scenario is required (the specimen's scenario TOML)")
    if not engines and not ensemble:
        return fail("give at least one --engine (e.g. --engine mujoco)")
    if baseline_source not in ("auto", "sheet", "record"):
        return fail(f"--baseline-source {baseline_source!r}: expected auto, sheet or record")
    if not (tail >= 0):
        return fail(f"--tail {tail!r}: expected a time >= 0 s")
    try:
        base = Baseline(
            detrend=detrend,
            highpass_hz=highpass or None,
            lowpass_hz=lowpass or None,
            resample_hz=resample or None,
        )
        camp = load_campaign(campaign, specimen)
        selection = [t.strip() for t in tests.split(",") if t.strip()] if tests else None
        camp = camp.select(selection, limit)
    except CampaignError as exc:
        return fail(str(exc))
    try:
        scn = load_scenario(scenario)
    except ScenarioError as exc:
        return fail(str(exc))
    try:
        settings = _parse_sets(sets)
    except Exception as exc:
        return fail(str(exc))
    ens_spec, engines = _ensemble_inputs(scn, scenario, engines, ensemble, members)
    if isinstance(ens_spec, str):
        return fail(ens_spec)
    for e in engines:
        try:
            get_engine(e)
        except Exception as exc:  # unknown engine or missing package: its install hint
            return fail(f"--engine {e}: {exc}")
    if transfer:
        bad_transfer = _check_transfer(transfer)
        if bad_transfer:
            return fail(bad_transfer)
    out = out or Path("reports") / f"validate_{scn.name}"
    console.print(
        f"campaign {escape(str(campaign))}: {len(camp)} tests of specimen {specimen} "
        f"({sum(t.toppled for t in camp.tests)} toppled), {len({t.motion for t in camp.tests})} records",
        soft_wrap=True,
    )
    t0 = time.perf_counter()
    try:
        rows, motions, summary = run_campaign(
            camp, scn, engines, out, baseline=base, settings={e: settings for e in engines}, tail=tail,
            chunk_size=chunk_size, workers=workers, progress=progress, console=err,
        )  # fmt: skip
    except ScenarioError as exc:
        return fail(str(exc))
    wall = time.perf_counter() - t0
    res = evaluate(camp, rows, motions, engines, folds=folds, baseline_source=baseline_source)
    if transfer:  # issue 22: the transferred logistic baseline, fitted on another specimen
        from pbr_xval.validation.report import add_transferred

        try:
            add_transferred(res, scenario, transfer, baseline=base)
        except Exception as exc:  # the runs are done: report without it rather than lose them
            err.print(
                f"[yellow]warning:[/] --transfer {escape(transfer)}: {escape(str(exc))}", soft_wrap=True
            )
    ens_meta: dict[str, Any] = {}
    if ens_spec is not None:  # issue 22: P(topple) per test from the [uncertainty] ensemble
        from pbr_xval.validation.ensemble import run_ensemble

        ens_meta = run_ensemble(
            res, camp, motions, scn, ens_spec, out, members=members, engines=engines,
            settings={e: settings for e in engines}, tail=tail, workers=workers, progress=progress, console=err,
        )  # fmt: skip
    meta = {
        "campaign": str(campaign),
        "campaign_form": camp.form,
        "specimen": specimen,
        "tests": len(camp),
        "records": len({t.motion for t in camp.tests}),
        "scenario": str(scenario),
        "scenario_hash": scn.content_hash(),
        "engines": ", ".join(engines),
        "engine_settings": settings,
        "baseline_correction": base.describe(),
        "tail_s": tail,
        "toppling": scn.toppling.model_dump(mode="json"),
        "wall_s": round(wall, 1),
        "chunks_run_skipped_failed": f"{summary.done}/{summary.skipped}/{summary.failed}",
        **ens_meta,
    }
    paths = write_report(res, out, meta)
    sc = res.scores
    for r in sc.itertuples():
        console.print(
            f"{r.model:>18s}  F1 {r.f1:.3f}  acc {r.accuracy:.3f}  prec {r.precision:.3f}  rec {r.recall:.3f}"
            f"  TP {r.tp} FP {r.fp} FN {r.fn} TN {r.tn}  {escape('[' + r.evaluated_on + ']')}",
            soft_wrap=True,
        )
    for line in f1_lines(res):
        print(line, flush=True)
    if ens_spec is not None:
        from pbr_xval.validation.ensemble import ensemble_lines

        for line in ensemble_lines(res):  # F1 ensemble (Brier ensemble is among the Brier lines)
            print(line, flush=True)
    for line in brier_lines(res):  # every model: engines (0/1), rules, logistic baselines
        print(line, flush=True)
    console.print(f"wrote {escape(str(paths['html']))}, outcomes.csv, scores.csv ({wall:.1f} s)")
    bad = sum(res.failures.values()) + summary.failed + int(ens_meta.get("ensemble_failed_runs", 0))
    if bad:
        err.print(f"[yellow]warning:[/] {bad} run(s)/chunk(s) failed; see outcomes.csv status columns")
        return 1
    return 0


def _ensemble_inputs(
    scn: Any, scenario: Path, engines: list[str], ensemble: bool, members: int | None
) -> tuple[Any, list[str]]:
    """(the [uncertainty] spec or None, the deterministic engines); an error message instead of the spec.

    Without ``--engine``, ``--ensemble`` runs the mixture's engines deterministically too (their
    ``F1 <engine>`` lines) and the mixture as the table gives it; with it, both are restricted.
    """
    if not ensemble:
        return None, engines
    from pbr_xval.uncertainty import ensemble_spec

    spec = ensemble_spec(scn)
    if spec is None:
        return f"--ensemble: {scenario} has no [uncertainty] table; expected one (docs/scenarios.md)", engines
    if members is not None and not 1 <= members <= 1_000_000:
        return f"--members {members}: expected 1 … 1000000 members per test", engines
    mix, _ = spec.mixture(engines)
    if not mix:
        return "--ensemble: no engine; give --engine, or engines = [...] in [uncertainty]", engines
    return spec, list(engines) or mix


def _check_transfer(spec: str) -> str | None:
    """What is wrong with ``--transfer CAMPAIGN:SPECIMEN:SCENARIO`` (None: nothing), before any run."""
    from pbr_xval.scenario import ScenarioError, load_scenario
    from pbr_xval.validation.campaign import CampaignError, load_campaign

    parts = spec.split(":")
    if len(parts) < 3 or not parts[-2].strip().isdigit():
        return f"--transfer {spec!r}: expected CAMPAIGN:SPECIMEN:SCENARIO (e.g. ../shared/data/shake_table:2:sp2.toml)"
    try:
        camp = load_campaign(":".join(parts[:-2]), int(parts[-2]))
        load_scenario(parts[-1])
    except (CampaignError, ScenarioError, OSError) as exc:
        return f"--transfer {spec}: {exc}"
    if len({int(t.toppled) for t in camp.tests}) < 2:
        return f"--transfer {spec}: the source specimen has one outcome only; a logistic law needs both"
    return None
