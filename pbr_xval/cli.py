"""The ``pbr-xval`` command line."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table

app = typer.Typer(
    help="Cross-validate physics engines on precariously balanced rocks.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
console = Console()
err = Console(stderr=True)


def _parse_sets(items: list[str] | None) -> dict[str, Any]:
    """``key=value`` pairs; values parsed as JSON where possible (numbers, booleans, lists)."""
    out: dict[str, Any] = {}
    for it in items or []:
        if "=" not in it:
            raise typer.BadParameter(f"--set expects key=value, got {it!r}")
        k, v = it.split("=", 1)
        try:
            out[k.strip()] = json.loads(v)
        except json.JSONDecodeError:
            out[k.strip()] = v
    return out


def _load(path: Path):
    from pbr_xval.scenario import ScenarioError, load_scenario

    try:
        return load_scenario(path)
    except ScenarioError as exc:
        err.print(f"[red]error:[/] {exc}")
        raise typer.Exit(2) from None


def _fail(msg: str, code: int = 2) -> typer.Exit:
    err.print(f"[red]error:[/] {msg}")
    return typer.Exit(code)


SetOpt = Annotated[
    list[str] | None,
    typer.Option("--set", help="engine setting override key=value (repeatable), e.g. --set variant=linearized"),
]
ProfileOpt = Annotated[str | None, typer.Option(help="engine settings profile, e.g. faithful or engine-default")]


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
    out: Annotated[Path | None, typer.Option(help="trajectory Parquet file (default runs/<name>.<engine>.parquet)")] = None,
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
    lo: Annotated[float | None, typer.Option(help="lower end of the scan (default 0.5× the scenario value)")] = None,
    hi: Annotated[float | None, typer.Option(help="upper end of the scan (default 2× the scenario value)")] = None,
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
        TextColumn("[bold]{task.description}"), BarColumn(), TextColumn("{task.fields[last]}"), TimeElapsedColumn(),
        console=err, transient=True,
    ) as prog:
        task = prog.add_task(f"{engine}: {param}", total=None, last="")

        def tick(n: int, value: float, topp: bool) -> None:
            prog.update(task, advance=1, last=f"#{n}: {value:.6g} → {'topples' if topp else 'stands'}")

        try:
            res = find_threshold(
                scn, engine, param, lo=lo, hi=hi, n_grid=n_grid, rel_tol=rel_tol, settings=settings, progress=tick
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
        console.print(f"{label}: never toppled for {param} in [{res.grid[0]:.6g}, {res.grid[-1]:.6g}] {unit}: "
                      f"{how} ({res.n_simulations} simulations)")
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


@app.command()
def rock(
    scan: Annotated[Path, typer.Argument(help="rock scan: mesh (OBJ/PLY/STL/OFF) or point cloud (PLY/XYZ/CSV/TXT/LAS/E57)")],
    pedestal: Annotated[Path | None, typer.Option(help="pedestal scan (default: a flat pedestal under the rock)")] = None,
    density: Annotated[float, typer.Option(help="kg/m³")] = 2700.0,
    mass: Annotated[float | None, typer.Option(help="kg; overrides --density")] = None,
    units: Annotated[str, typer.Option(help="length unit of the scan: m, cm, mm, ft, in")] = "m",
    out: Annotated[Path | None, typer.Option(help="report folder (default reports/rock_<name>/)")] = None,
    orientation: Annotated[str, typer.Option(help="scan | settle | stable")] = "settle",
    cut_z: Annotated[float | None, typer.Option(help="split one scan at z = cut (m): rock above, pedestal below")] = None,
    alpha_multiple: Annotated[float | None, typer.Option(help="point cloud: alpha as a multiple of the spacing")] = None,
    grid_spacing: Annotated[float | None, typer.Option(help="node grid spacing, m")] = None,
) -> None:
    """Rock model of a scan: mass, COM, inertia, contact patch, critical tilt per direction; writes a small report."""
    from pbr_xval.rock_cli import rock_command

    code = rock_command(
        scan, pedestal, density, units, out, mass=mass, orientation=orientation, cut_z=cut_z,
        alpha_multiple=alpha_multiple, grid_spacing=grid_spacing, console=console,
    )
    if code:
        raise typer.Exit(code)


@app.command()
def report(
    study: Annotated[Path, typer.Argument(help="study file (TOML), e.g. examples/studies/housner.toml")],
    out: Annotated[Path, typer.Option(help="reports folder; the report goes to <out>/<name>/")] = Path("reports"),
    quick: Annotated[bool, typer.Option(help="apply each study's [quick] options (smaller grids)")] = False,
) -> None:
    """Run a study file across engines and write reports/<name>/ (index.html, summary.md, CSV, Parquet)."""
    from pbr_xval.report_cli import report_command

    code = report_command(study, out, console, quick=quick)
    if code:
        raise typer.Exit(code)


@app.command()
def regress(
    golden: Annotated[Path, typer.Argument(help="golden threshold table (CSV), e.g. examples/golden/thresholds.csv")],
    update: Annotated[bool, typer.Option(help="re-measure and rewrite the thresholds on purpose")] = False,
    engine: Annotated[list[str] | None, typer.Option("--engine", "-e", help="only these engines")] = None,
    fast: Annotated[bool, typer.Option(help="two simulations per row: stands at value−tol, topples at value+tol")] = False,
    strict: Annotated[bool, typer.Option(help="a missing engine is a failure")] = False,
    markdown: Annotated[Path | None, typer.Option(help="append the diff as Markdown (e.g. $GITHUB_STEP_SUMMARY)")] = None,
) -> None:
    """Re-measure every golden toppling threshold; exit 1 with a readable diff if one leaves its tolerance."""
    from pbr_xval.report_cli import regress_command

    code = regress_command(golden, update, engine, fast, console, strict=strict, markdown=markdown)
    if code:
        raise typer.Exit(code)


@app.command()
def demo(
    out: Annotated[Path, typer.Option(help="reports folder; the demo report goes to <out>/demo/")] = Path("reports"),
    quick: Annotated[bool, typer.Option(help="a smaller, faster demo")] = False,
) -> None:
    """The main job on the built-in examples: Housner, curved-base and synthetic-rock scenarios across all engines."""
    from pbr_xval.report_cli import demo_command

    code = demo_command(out, quick, console)
    if code:
        raise typer.Exit(code)


def _fraction(text: str) -> float:
    """'5%' → 0.05; '0.05' → 0.05."""
    t = text.strip()
    try:
        return float(t[:-1]) / 100 if t.endswith("%") else float(t)
    except ValueError:
        raise typer.BadParameter(f"expected a fraction like 0.05 or a percentage like 5%, got {text!r}") from None


@app.command()
def sweep(
    catalog: Annotated[Path, typer.Argument(help="catalog file (TOML)")],
    out: Annotated[Path, typer.Argument(help="results store (partitioned Parquet dataset)")],
    engine: Annotated[list[str] | None, typer.Option("--engine", "-e", help="engines (default: the catalog's)")] = None,
    profile: ProfileOpt = None,
    executor: Annotated[str, typer.Option(help="local | dask | inline")] = "local",
    workers: Annotated[int | None, typer.Option(help="worker processes (default: CPU count)")] = None,
    scheduler: Annotated[str | None, typer.Option(help="Dask scheduler address tcp://host:port")] = None,
    shard: Annotated[str | None, typer.Option(help="run only shard i/N of the chunks (job arrays)")] = None,
    chunk_size: Annotated[int, typer.Option(help="motions per chunk (0: the catalog's)")] = 0,
) -> None:
    """Run a rock catalog × motion set × engines, chunk by chunk, resumable (reruns skip finished chunks)."""
    from pbr_xval.catalog_cli import sweep_command

    code = sweep_command(catalog, out, engine, profile, executor, workers, scheduler, shard, chunk_size, console)
    if code:
        raise typer.Exit(code)


@app.command()
def choose(
    catalog: Annotated[Path, typer.Argument(help="catalog file (TOML) with a [choose] table")],
    budget: Annotated[str, typer.Option(help="accuracy budget, e.g. 5% (fragility median vs the reference)")] = "5%",
    out: Annotated[Path, typer.Option(help="where choose.md / choose.json are written")] = Path("reports/choose"),
) -> None:
    """Recommend the cheapest engine and settings within an accuracy budget; project the catalog's cost."""
    from pbr_xval.catalog_cli import choose_command

    code = choose_command(catalog, _fraction(budget), out, console)
    if code:
        raise typer.Exit(code)


def main() -> None:  # pragma: no cover
    app(prog_name="pbr-xval")


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
