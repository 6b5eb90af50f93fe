"""The plain function behind ``pbr-xval predict`` (exit codes: 0 done, 1 some runs failed, 2 bad input)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

__all__ = ["predict_command"]


def predict_command(
    scenario: Path,
    *,
    members: int | None = None,
    engines: list[str] | None = None,
    out: Path | None = None,
    workers: int = 2,
    half_width: float | None = None,
    batch: int = 4,
    engine_set: list[str] | None = None,
    profile: str | None = None,
    console: Any = None,
    progress: bool = True,
    executor: str = "local",
    member: int | None = None,
) -> int:
    """Check every input, run the ensemble, print P(topple) and write members.csv / predict.json."""
    from rich.markup import escape

    from pbr_xval.console import make_console
    from pbr_xval.engine import get_engine
    from pbr_xval.registry import registered_names
    from pbr_xval.scenario import ScenarioError, load_scenario
    from pbr_xval.uncertainty import ensemble_spec

    console = make_console(console)
    err = make_console(stderr=True)

    def fail(msg: str) -> int:
        err.print(f"[red]error:[/] {escape(msg)}", soft_wrap=True)
        return 2

    try:
        scn = load_scenario(scenario)
    except ScenarioError as exc:
        return fail(str(exc))
    spec = ensemble_spec(scn)
    if spec is None:
        return fail(
            f"{scenario}: no [uncertainty] table; expected one (docs/scenarios.md) to predict P(topple)"
        )
    if members is not None and not 1 <= members <= 1_000_000:
        return fail(f"--members {members}: expected 1 … 1000000")
    if workers < 1:
        return fail(f"--workers {workers}: expected at least 1 worker process")
    if batch < 1:
        return fail(f"--batch {batch}: expected at least 1 member per batch")
    if half_width is not None and not (0 < half_width < 0.5 and math.isfinite(half_width)):
        return fail(f"--half-width {half_width!r}: expected a number in (0, 0.5)")
    known = registered_names()
    for e in engines or []:
        if e not in known:
            return fail(f"--engine {e!r}: unknown engine; expected one of {', '.join(known)}")
    eng_list, _ = spec.mixture(engines)
    if not eng_list:
        return fail(f"{scenario}: no engine: give --engine, or engines = [...] in [uncertainty]")
    for e in eng_list:
        try:
            get_engine(e)
        except Exception as exc:  # unknown engine or missing package: its install hint
            return fail(f"engine {e}: {exc}")
    try:
        from pbr_xval.cli._app import _parse_sets

        sets = _parse_sets(engine_set)
    except Exception as exc:
        return fail(str(exc))
    if profile:
        sets["profile"] = profile
    n = int(members or spec.members)
    if member is not None:
        return _one_member(scn, spec, member, n, eng_list, sets, out, console, fail)
    out = out or Path("reports") / f"predict_{scn.name}"
    if out.exists() and not out.is_dir():
        return fail(f"--out {out}: is a file; expected a folder")
    console.print(
        escape(
            f"{scenario}: ensemble of up to {n} members ({spec.sampling}, seed {spec.seed}) over "
            f"{len(spec.dists)} uncertain key(s) [{', '.join(spec.keys)}] × engines {', '.join(eng_list)}"
            + (f"; adaptive to half-width {half_width:g}" if half_width else "")
        ),
        soft_wrap=True,
        highlight=False,
    )
    from pbr_xval.catalog.predict import format_predict, run_predict, write_predict

    def on_batch(k: int, est: Any) -> None:
        console.print(
            f"  {k} members: P = {est.p:.3f} [{est.lo:.3f}, {est.hi:.3f}] (half-width {est.half_width:.3f})",
            highlight=False,
        )

    try:
        res = run_predict(
            scn, out, spec=spec, members=n, engines=eng_list, half_width=half_width, batch=batch,
            settings={e: sets for e in eng_list}, workers=workers, executor=executor, progress=progress,
            console=err, on_batch=on_batch if half_width else None,
        )  # fmt: skip
    except ScenarioError as exc:
        return fail(str(exc))
    paths = write_predict(res, out)
    for line in format_predict(res):
        print(line, flush=True)
    console.print(f"wrote {escape(str(paths['csv']))} and {escape(str(paths['json']))} ({res.wall_s:.1f} s)")
    return 1 if (res.failed or res.chunks_failed) else 0


def _one_member(
    scn: Any, spec: Any, member: int, n: int, engines: list[str], sets: dict[str, Any], out: Path | None,
    console: Any, fail: Any,
) -> int:  # fmt: skip
    """``predict --member I``: re-run one member here and write its trajectory."""
    import json

    from rich.markup import escape

    from pbr_xval.catalog.predict import run_member
    from pbr_xval.engine import EngineNotAvailable, EngineSettingsError, NotApplicable
    from pbr_xval.scenario import ScenarioError

    if not 0 <= member < n:
        return fail(f"--member {member}: expected 0 ≤ member < {n} (the ensemble's members)")
    try:
        m, traj = run_member(scn, spec, member, members=n, engines=engines, settings=sets)
    except (ScenarioError, EngineNotAvailable, EngineSettingsError, NotApplicable, ValueError) as exc:
        return fail(str(exc))
    path = out if out is not None and out.suffix == ".parquet" else (
        (out or Path("reports") / f"predict_{scn.name}") / f"member_{member:04d}.{m.engine}.parquet"
    )  # fmt: skip
    path.parent.mkdir(parents=True, exist_ok=True)
    traj.save_parquet(path)
    ta = traj.toppled_at
    console.print(
        escape(f"member {member} ({m.engine}): values {json.dumps(m.values)}; seed {m.seed}, {m.sampling}"),
        soft_wrap=True,
        highlight=False,
    )
    print(
        f"member {member}: {'toppled at ' + format(ta, '.6g') + ' s' if ta is not None else 'stood'}; "
        f"peak tilt {float(traj.tilt().max()) if traj.t.size else float('nan'):.6g} rad; status {traj.status}",
        flush=True,
    )
    console.print(f"trajectory written to {escape(str(path))} (scenario hash {traj.scenario_hash[:12]})")
    return 0 if traj.ok else 1
