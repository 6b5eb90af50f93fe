"""``pbr-xval engines | check | run | threshold``: one scenario, one engine."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer
from rich.markup import escape
from rich.table import Table

from pbr_xval.cli._app import ProfileOpt, SetOpt, _fail, _load, _parse_sets, app, console, err


@app.command()
def engines() -> None:
    """List the registered engines, whether they import, and their versions."""
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


@app.command()
def check(scenario: Path) -> None:
    """Validate a scenario file and print the resolved model (defaults filled in)."""
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


@app.command()
def run(
    scenario: Path,
    engine: Annotated[str, typer.Option("--engine", "-e", help="engine name (see `pbr-xval engines`)")],
    out: Annotated[
        Path | None, typer.Option(help="trajectory Parquet file (default runs/<name>.<engine>.parquet)")
    ] = None,
    set_: SetOpt = None,
    profile: ProfileOpt = None,
) -> None:
    """Simulate a scenario with one engine, write the trajectory and print a summary."""
    from pbr_xval.engine import EngineNotAvailable, EngineSettingsError, NotApplicable
    from pbr_xval.runner import run_scenario

    scn = _load(scenario)
    settings = _parse_sets(set_)
    if profile:
        settings["profile"] = profile
    try:
        with console.status(f"simulating {scn.name} with {engine} ..."):
            traj = run_scenario(scn, engine, settings)
    except (EngineNotAvailable, EngineSettingsError, NotApplicable) as exc:
        raise _fail(str(exc)) from None
    out = out or Path("runs") / f"{scn.name}.{engine}.parquet"
    traj.save_parquet(out)
    table = Table(title=f"{scn.name} — {engine}")
    table.add_column("quantity")
    table.add_column("value")
    for k, v in traj.summary().items():
        table.add_row(k, f"{v:.6g}" if isinstance(v, float) else str(v))
    console.print(table)
    console.print(f"trajectory written to {out}")
    if not traj.ok:
        raise _fail(f"run failed: {traj.message}", 1)


@app.command()
def threshold(
    scenario: Path,
    engine: Annotated[str, typer.Option("--engine", "-e")],
    param: Annotated[str, typer.Option(help="dotted scenario key to search")] = "excitation.amplitude",
    lo: Annotated[
        float | None, typer.Option(help="lower end of the scan (default 0.5× the scenario value)")
    ] = None,
    hi: Annotated[
        float | None, typer.Option(help="upper end of the scan (default 2× the scenario value)")
    ] = None,
    n_grid: Annotated[int, typer.Option(help="coarse scan points")] = 16,
    rel_tol: Annotated[float, typer.Option(help="relative bracket width at which bisection stops")] = 1e-4,
    set_: SetOpt = None,
    profile: ProfileOpt = None,
    json_out: Annotated[Path | None, typer.Option("--json", help="also write the result as JSON")] = None,
) -> None:
    """Minimum toppling value of a scenario parameter: coarse scan, then bisection (with its tolerance)."""
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from pbr_xval.engine import EngineNotAvailable, EngineSettingsError, NotApplicable
    from pbr_xval.study.threshold import find_threshold

    scn = _load(scenario)
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
    unit = {"amplitude": "m/s²", "pgv": "m/s", "pga": "m/s²"}.get(param.rsplit(".", 1)[-1], "")
    prof = res.settings.get("profile", "")
    variant = res.settings.get("variant")
    label = escape(f"{engine}" + (f" ({variant})" if variant else "") + (f" [{prof}]" if prof else ""))
    if res.minimum is None:
        how = (
            f"it never rocked (largest tilt {res.max_tilt:.1e} rad)"
            if res.max_tilt < 1e-3
            else f"it rocked (largest tilt {res.max_tilt:.3g} rad) but never toppled"
        )
        console.print(
            f"{label}: never toppled for {param} in [{res.grid[0]:.6g}, {res.grid[-1]:.6g}] {unit}: "
            f"{how} ({res.n_simulations} simulations)"
        )
    else:
        tol = res.tolerance or 0.0
        console.print(
            f"{label}: minimum toppling {param} = [bold]{res.minimum:.4f} {unit}[/] ± {tol:.1e} "
            f"(bracket rel. width ≤ {res.rel_tol:g}; {res.n_simulations} simulations, {res.wall_time:.2f} s)"
        )
        bands = res.bands()
        if len(bands) > 1 or (bands and bands[0].end is not None):
            for b in bands:
                end = "end of scan" if b.end is None else f"{b.end:.4f}"
                console.print(f"  toppling band: {b.start:.4f} … {end} {unit}")
    if json_out:
        json_out.write_text(json.dumps(res.to_dict(), indent=2, default=str))
