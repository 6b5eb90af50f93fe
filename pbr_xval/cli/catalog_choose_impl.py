"""The plain function behind ``pbr-xval choose --campaign`` (exit codes: 0 done, 1 no
recommendation / failed runs, 2 bad input)."""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

__all__ = ["choose_campaign_command"]


def _floats(text: str | None, what: str) -> list[float] | None:
    if not text:
        return None
    out = []
    for v in text.split(","):
        v = v.strip()
        try:
            x = float(v)
        except ValueError:
            raise ValueError(
                f"{what} {v!r}: expected a number (comma-separated list, e.g. 1e-3,2e-3)"
            ) from None
        if not (x > 0 and math.isfinite(x)):
            raise ValueError(f"{what} {v!r}: expected a positive time step in s")
        out.append(x)
    return out


def _words(text: str | None) -> list[str] | None:
    return [w.strip() for w in text.split(",") if w.strip()] if text else None


def choose_campaign_command(
    campaign: Path,
    *,
    specimen: int,
    scenario: Path | None,
    engines: list[str] | None = None,
    profiles: str | None = None,
    timesteps: str | None = None,
    collisions: str | None = None,
    tests: str | None = None,
    limit: int | None = None,
    margin_se: float = 1.0,
    out: Path | None = None,
    work: Path | None = None,
    workers: int = 2,
    tail: float = 3.0,
    console: Any = None,
    progress: bool = True,
) -> int:
    """Validate the inputs, run engines × profiles × dt × collision on the campaign, print the
    ``choice`` / ``recommend`` lines and write the report folder."""
    from rich.markup import escape

    from pbr_xval.catalog.tradeoff import candidate_settings, choice_lines, run_tradeoff, write_tradeoff
    from pbr_xval.console import make_console
    from pbr_xval.engine import get_engine
    from pbr_xval.scenario import ScenarioError, load_scenario
    from pbr_xval.settings_spec import COLLISION
    from pbr_xval.validation.campaign import Baseline, CampaignError, load_campaign

    console = make_console(console)
    err = make_console(stderr=True)

    def fail(msg: str) -> int:
        err.print(f"[red]error:[/] {escape(msg)}", soft_wrap=True)
        return 2

    if scenario is None:
        return fail("--scenario is required with --campaign (the specimen's scenario TOML)")
    if not (margin_se >= 0 and math.isfinite(margin_se)):
        return fail(f"--margin-se {margin_se!r}: expected a number of standard errors ≥ 0")
    if workers < 1:
        return fail(f"--workers {workers}: expected at least 1 worker process")
    try:
        dts = _floats(timesteps, "--timestep")
    except ValueError as exc:
        return fail(str(exc))
    cols = _words(collisions)
    for c in cols or []:
        if c.split(":", 1)[-1] not in (COLLISION.choices or ()):
            return fail(f"--collision {c!r}: expected one of {', '.join(map(str, COLLISION.choices or ()))}")
    engines = engines or ["mujoco", "pybullet"]
    for e in engines:
        try:
            get_engine(e)
        except Exception as exc:
            return fail(f"--engine {e}: {exc}")
    try:
        camp = load_campaign(campaign, specimen)
        selection = _words(tests)
        camp = camp.select(selection, limit)
    except CampaignError as exc:
        return fail(str(exc))
    try:
        scn = load_scenario(scenario)
    except ScenarioError as exc:
        return fail(str(exc))
    cands = candidate_settings(engines, profiles=_words(profiles), timesteps=dts, collisions=cols)
    out = out or Path("reports") / f"tradeoff_{scn.name}"
    work = work or out
    base = Baseline()
    console.print(
        f"campaign {escape(str(campaign))}: {len(camp)} tests of specimen {specimen} "
        f"({sum(t.toppled for t in camp.tests)} toppled); {len(cands)} settings → {len(camp) * len(cands)} runs "
        f"(store {escape(str(work / 'store'))}, resumable)",
        soft_wrap=True,
    )
    t0 = time.perf_counter()
    try:
        res = run_tradeoff(
            camp, scn, cands, work, baseline=base, tail=tail, workers=workers, k_se=margin_se,
            progress=progress, console=err,
        )  # fmt: skip
    except ScenarioError as exc:
        return fail(str(exc))
    wall = time.perf_counter() - t0
    import os

    meta = {
        "campaign": str(campaign),
        "specimen": specimen,
        "scenario": str(scenario),
        "scenario_hash": scn.content_hash(),
        "tests": len(camp),
        "test_ids": " ".join(t.test for t in camp.tests),
        "toppled_observed": sum(t.toppled for t in camp.tests),
        "settings_run": len(cands),
        "baseline_correction": base.describe(),
        "tail_s": tail,
        "margin": f"{margin_se:g} standard error of the mean paired difference of squared errors",
        "wall_s": round(wall, 1),
        "load_average_at_end": " ".join(f"{x:.1f}" for x in os.getloadavg()),
        "cpus": os.cpu_count(),
    }
    paths = write_tradeoff(res, out, meta)
    for line in choice_lines(res):
        print(line, flush=True)
    console.print(
        f"wrote {escape(str(paths['html']))}, settings.csv, tests.csv, tradeoff.json ({wall:.1f} s)"
    )
    t = res["table"]
    if res["recommendation"] is None or int(t["n_failed"].sum()):
        return 1
    return 0
