"""The bodies of ``pbr-xval engines | check | run | threshold`` (declared in :mod:`pbr_xval.cli.simulate`).

Like every command group: the typer wrapper in ``simulate.py`` holds the options and the help, the
``*_command`` function here does the work (imports inside, so ``pbr-xval --help`` loads no engine).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import typer
from rich.markup import escape
from rich.table import Table

from pbr_xval.cli._app import _fail, _load, _parse_sets, console, err

#: ``threshold`` exit statuses besides 0 (bracketed), 1 (engine failure) and 2 (bad input)
EXIT_TOPPLES_AT_LO = 3
EXIT_NEVER_TOPPLED = 4


def engines_command() -> None:
    """``pbr-xval engines``: list the registered engines, whether they import, and their versions."""
    from pbr_xval.engine import list_engines

    table = Table(title="pbr-xval engines")
    for col in ("engine", "available", "versions / install hint"):
        table.add_column(col)
    for name, info in list_engines().items():
        if info["available"]:
            ver = ", ".join(f"{k} {v}" for k, v in info["versions"].items())
            table.add_row(name, "[green]yes[/]", ver)
        else:
            table.add_row(name, "[red]no[/]", info["error"])
    console.print(table)


def check_command(scenario: Path) -> None:
    """``pbr-xval check``: validate a scenario file and print the resolved model (defaults filled in)."""
    scn = _load(scenario)
    from pbr_xval.scene import compile_scene

    try:
        scene = compile_scene(scn)
    except (ValueError, OSError) as exc:
        raise _fail(f"{scenario}: {exc}") from None
    console.print(f"[bold]{scenario}[/] is valid. Content hash: {scn.content_hash()}")
    console.print_json(json.dumps(scn.normalised()))
    info = scene.info()
    console.print(
        f"rock: {info['rock_shape']}, mass {info['mass_kg']:.6g} kg, COM {[f'{c:.4g}' for c in info['com_m']]} m; "
        f"critical tilt toward −d/+d: {info['alpha_left_rad']:.6g} / {info['alpha_right_rad']:.6g} rad; "
        f"uplift acceleration {info['uplift_accel_m_s2']:.6g} m/s²"
    )
    for r in scene.reductions:
        console.print(f"  model: {r['what']}: {r['choice']} ({r['why']})")


def run_command(
    scenario: Path,
    engine: str,
    out: str | None,
    set_: list[str] | None,
    engine_set: list[str] | None,
    profile: str | None,
    overwrite: bool,
    member: int | None,
    members: int | None,
) -> None:
    """``pbr-xval run``: simulate a scenario with one engine, write the trajectory and print a summary."""
    from pbr_xval.engine import EngineNotAvailable, EngineSettingsError, NotApplicable, get_engine
    from pbr_xval.runner import effective_settings, run_resolved
    from pbr_xval.scenario import ScenarioError
    from pbr_xval.scene import compile_scene

    scn = _load(scenario)
    try:
        eng = get_engine(engine)
    except EngineNotAvailable as exc:
        raise _fail(str(exc)) from None
    member_info = None
    if member is not None:
        scn, member_info = _ensemble_member(scn, scenario, member, members, engine)
    try:
        settings = _parse_sets(engine_set)
        scenario_sets = _parse_sets(set_)
    except typer.BadParameter as exc:
        raise _fail(str(exc)) from None
    engine_keys = set(eng.default_settings())
    for key, value in scenario_sets.items():
        try:
            scn = scn.with_value(key, value)
        except ScenarioError as exc:
            if key in engine_keys:  # the old meaning of --set: an engine setting
                err.print(
                    f"note: --set {escape(key)}: an engine setting of {engine!r}, not a scenario key; "
                    f"write --engine-set {escape(key)}=...",
                    soft_wrap=True,
                )
                settings[key] = value
                continue
            not_a_key = "unknown key" in str(exc) or "no table" in str(exc)
            hint = " (engine settings go to --engine-set)" if not_a_key else ""
            raise _fail(f"--set {key}: {exc}{hint}") from None
    if profile:
        settings["profile"] = profile
    from pbr_xval.atomic import check_output_file
    from pbr_xval.errors import OutputPathError

    try:
        out_path = check_output_file(
            out or Path("runs") / f"{scn.name}.{engine}.parquet",
            "--out",
            overwrite=overwrite,
            default_name=f"{scn.name}.{engine}.parquet",
        )
    except OutputPathError as exc:
        raise _fail(str(exc)) from None
    try:
        scene = compile_scene(scn)
        full = effective_settings(eng, scene, settings)
    except (EngineSettingsError, ScenarioError) as exc:
        raise _fail(f"{scenario}: {exc}") from None
    except (ValueError, OSError) as exc:
        raise _fail(f"{scenario}: {exc}") from None
    try:
        with console.status(f"simulating {scn.name} with {engine} ..."):
            traj = run_resolved(scene, eng, full)
    except (EngineNotAvailable, EngineSettingsError, NotApplicable) as exc:
        raise _fail(str(exc)) from None
    if member_info is not None:
        traj.scene_info["ensemble_member"] = member_info
    traj.save_parquet(out_path)
    table = Table(title=f"{scn.name} — {engine}")
    table.add_column("quantity")
    table.add_column("value")
    for k, v in traj.summary().items():
        table.add_row(k, f"{v:.6g}" if isinstance(v, float) else str(v))
    console.print(table)
    console.print(f"trajectory written to {out_path}")
    if not traj.ok:
        raise _fail(f"run failed: {traj.message}", 1)


def threshold_command(
    scenario: Path,
    engine: str,
    param: str,
    lo: float | None,
    hi: float | None,
    n_grid: int,
    rel_tol: float,
    set_: list[str] | None,
    profile: str | None,
    json_out: str | None,
    overwrite: bool,
) -> None:
    """``pbr-xval threshold``: toppling bands of a scenario parameter: physics lower bound, coarse scan refined near toppling, every"""
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from pbr_xval.atomic import check_output_file, write_text_atomic
    from pbr_xval.engine import EngineNotAvailable, EngineSettingsError, NotApplicable
    from pbr_xval.errors import OutputPathError
    from pbr_xval.study.threshold_search import find_threshold

    scn = _load(scenario)
    json_path = None
    if json_out is not None:  # checked before the search, not after it
        try:
            json_path = check_output_file(
                json_out,
                "--json",
                overwrite=overwrite,
                default_name=f"{scn.name}.{engine}.threshold.json",
            )
        except OutputPathError as exc:
            raise _fail(str(exc)) from None
    settings = _parse_sets(set_)
    if profile:
        settings["profile"] = profile
    with Progress(
        TextColumn("[bold]{task.description}"),
        BarColumn(),
        TextColumn("{task.fields[last]}"),
        TimeElapsedColumn(),
        console=err,
        transient=True,
    ) as prog:
        task = prog.add_task(f"{engine}: {param}", total=None, last="")

        def tick(n: int, value: float, topp: bool) -> None:
            prog.update(task, advance=1, last=f"#{n}: {value:.6g} → {'topples' if topp else 'stands'}")

        try:
            res = find_threshold(
                scn,
                engine,
                param,
                lo=lo,
                hi=hi,
                n_grid=n_grid,
                rel_tol=rel_tol,
                settings=settings,
                progress=tick,
            )
        except (EngineNotAvailable, EngineSettingsError, NotApplicable, ValueError) as exc:
            raise _fail(str(exc)) from None
        except RuntimeError as exc:
            raise _fail(str(exc), 1) from None
    unit = res.unit
    prof = res.settings.get("profile", "")
    variant = res.settings.get("variant")
    label = escape(f"{engine}" + (f" ({variant})" if variant else "") + (f" [{prof}]" if prof else ""))
    u = f" {unit}" if unit else ""
    crit = res.criterion.get("criterion", "")
    console.print(
        f"{label}: {escape(res.message())} "
        f"({res.n_simulations} simulations, {res.wall_time:.2f} s; toppling criterion: {crit})",
        soft_wrap=True,
    )
    if res.lower_bound is not None:
        console.print(
            f"  physics: below {res.lower_bound:.6g}{u} the peak acceleration stays under g·tan α "
            "(no rocking can start); those values stand without simulation",
            soft_wrap=True,
        )
    if res.status == "never_toppled" and res.max_tilt < 1e-3:
        console.print(f"  it never rocked (largest tilt {res.max_tilt:.1e} rad)")
    for b in res.bands():
        start_s = f"< {res.lo:.6g}" if b.start is None else f"{b.start:.6g} ± {b.start_tol:.2g}"
        end_s = f"≥ {res.hi:.6g} (end of scan)" if b.end is None else f"{b.end:.6g} ± {b.end_tol:.2g}"
        console.print(f"  toppling band: {start_s} … {end_s}{u}")
    for tr in res.transitions:
        below, above = tr.lo_run, tr.hi_run
        if below is None or above is None:
            continue

        def word(r: object) -> str:
            reg = getattr(r, "regime", "")
            if r.toppled:  # type: ignore[attr-defined]
                return f"topples ({reg})" if reg else "topples"
            return f"stands (max θ/α {r.peak_ratio:.3f}{'; ' + reg if reg else ''})"  # type: ignore[attr-defined]

        console.print(
            f"    confirmed by direct runs: {below.value:.6g}{u} {word(below)}, {above.value:.6g}{u} {word(above)}",
            soft_wrap=True,
        )
    console.print(
        f"  resolution: a band narrower than {100 * res.resolution:.3g} % of the value may be missed between "
        "scanned values where the response stayed far from toppling (refined where it came close)",
        soft_wrap=True,
    )
    if res.status == "topples_at_lo":
        err.print(f"warning: {escape(res.message())}", soft_wrap=True)
    if json_path is not None:
        write_text_atomic(json_path, json.dumps(res.to_dict(), indent=2, default=str))
        console.print(f"  result written to {escape(str(json_path))}", soft_wrap=True)
    if res.status != "bracketed":
        raise typer.Exit(EXIT_TOPPLES_AT_LO if res.status == "topples_at_lo" else EXIT_NEVER_TOPPLED)


def _ensemble_member(
    scn: Any, path: Path, index: int, members: int | None, engine: str
) -> tuple[Any, dict[str, Any]]:
    """(member ``index``'s scenario, what the trajectory records about it) for ``run --member``."""
    from pbr_xval.uncertainty import ensemble_spec, member_scenario

    spec = ensemble_spec(scn)
    if spec is None:
        raise _fail(f"--member: {path} has no [uncertainty] table; expected one (docs/scenarios.md)")
    n = int(members or spec.members)
    if not 0 <= index < n:
        raise _fail(f"--member {index}: expected 0 ≤ member < {n} (the ensemble's members)")
    m = spec.member(index, members=n, engines=list(spec.engines) or [engine])
    if m.engine != engine:
        err.print(
            f"note: member {index} was drawn for engine {m.engine!r}; running it on {engine!r} as asked",
            soft_wrap=True,
        )
    info = {**m.to_dict(), "run_engine": engine, "base_scenario_hash": scn.content_hash()}
    err.print(
        escape(f"member {index}: values {json.dumps(m.values)} (seed {m.seed}, {m.sampling})"), soft_wrap=True
    )
    return member_scenario(scn, m, engine=engine), info
