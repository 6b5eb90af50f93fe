"""``pbr-xval engines | check | run | threshold``: one scenario, one engine."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from pbr_xval.cli._app import ProfileOpt, SetOpt, app
from pbr_xval.cli.simulate_impl import EXIT_NEVER_TOPPLED, EXIT_TOPPLES_AT_LO  # noqa: F401  (threshold's exit statuses)


@app.command()
def engines() -> None:
    """List the registered engines, whether they import, and their versions."""
    from pbr_xval.cli.simulate_impl import engines_command

    engines_command()


@app.command()
def check(scenario: Path) -> None:
    """Validate a scenario file and print the resolved model (defaults filled in)."""
    from pbr_xval.cli.simulate_impl import check_command

    check_command(scenario)


ScenarioSetOpt = Annotated[
    list[str] | None,
    typer.Option(
        "--set",
        help="scenario value KEY=VALUE, dotted keys as in `threshold --param` (repeatable), e.g. "
        "--set excitation.amplitude=24 --set contact.restitution=0.2. An engine setting here (no such "
        "scenario key) is still accepted, with a note: use --engine-set for those.",
    ),
]
EngineSetOpt = Annotated[
    list[str] | None,
    typer.Option(
        "--engine-set", help="engine setting KEY=VALUE (repeatable), e.g. --engine-set timestep=5e-4"
    ),
]


@app.command()
def run(
    scenario: Path,
    engine: Annotated[str, typer.Option("--engine", "-e", help="engine name (see `pbr-xval engines`)")],
    out: Annotated[
        str | None,
        typer.Option(
            help="trajectory Parquet file, or a folder (an existing one, or any path ending in /) to write "
            "<name>.<engine>.parquet into (default runs/<name>.<engine>.parquet)"
        ),
    ] = None,
    set_: ScenarioSetOpt = None,
    engine_set: EngineSetOpt = None,
    profile: ProfileOpt = None,
    overwrite: Annotated[
        bool, typer.Option("--overwrite", help="replace an existing trajectory file (default: refuse)")
    ] = False,
    member: Annotated[
        int | None,
        typer.Option(
            help="run member I (0-based) of the scenario's [uncertainty] ensemble: its sampled values applied "
            "(bit for bit the ensemble's run when --engine is the member's engine, see members.csv)"
        ),
    ] = None,
    members: Annotated[
        int | None, typer.Option(help="--member: the ensemble's size (a Latin hypercube depends on it)")
    ] = None,
) -> None:
    """Simulate a scenario with one engine, write the trajectory and print a summary.

    Everything is checked before the simulation starts: the scenario with its --set values, the
    engine and its settings, and the output path (an existing file is never replaced silently).
    """
    from pbr_xval.cli.simulate_impl import run_command

    run_command(scenario, engine, out, set_, engine_set, profile, overwrite, member, members)


@app.command()
def threshold(
    scenario: Path,
    engine: Annotated[str, typer.Option("--engine", "-e")],
    param: Annotated[str, typer.Option(help="dotted scenario key to search")] = "excitation.amplitude",
    lo: Annotated[
        float | None,
        typer.Option(
            help="lower end of the scan (default: the uplift bound g·tan α where it applies, else 0.5× the scenario value)"
        ),
    ] = None,
    hi: Annotated[
        float | None, typer.Option(help="upper end of the scan (default 2× the scenario value)")
    ] = None,
    n_grid: Annotated[
        int, typer.Option(help="coarse scan points (≥ 2); refined where the response nears toppling")
    ] = 8,
    rel_tol: Annotated[
        float, typer.Option(help="relative bracket width at which each transition is narrowed")
    ] = 1e-3,
    set_: SetOpt = None,
    profile: ProfileOpt = None,
    json_out: Annotated[
        str | None,
        typer.Option(
            "--json",
            help="also write the result as JSON to this file, or into this folder (an existing one, or a "
            "path ending in /) as <name>.<engine>.threshold.json; an existing file is replaced only with "
            "--overwrite",
        ),
    ] = None,
    overwrite: Annotated[
        bool, typer.Option("--overwrite", help="replace an existing --json file (default: refuse)")
    ] = False,
) -> None:
    """Toppling bands of a scenario parameter: physics lower bound, coarse scan refined near toppling, every
    transition narrowed and confirmed by direct runs.

    Exit status: 0 a minimum was bracketed; 3 the lowest scanned value already topples (no minimum: lower
    --lo); 4 nothing toppled in the range (raise --hi); 2 bad input; 1 an engine failure.
    """
    from pbr_xval.cli.simulate_impl import threshold_command

    threshold_command(scenario, engine, param, lo, hi, n_grid, rel_tol, set_, profile, json_out, overwrite)
