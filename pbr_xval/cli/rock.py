"""``pbr-xval rock``: a scan (mesh or point cloud) → rock model."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from pbr_xval.cli._app import app, console


@app.command()
def rock(
    scan: Annotated[
        Path,
        typer.Argument(help="rock scan: mesh (OBJ/PLY/STL/OFF) or point cloud (PLY/XYZ/CSV/TXT/LAS/E57)"),
    ],
    pedestal: Annotated[
        Path | None, typer.Option(help="pedestal scan (default: a flat pedestal under the rock)")
    ] = None,
    density: Annotated[float, typer.Option(help="kg/m³")] = 2700.0,
    mass: Annotated[float | None, typer.Option(help="kg; overrides --density")] = None,
    units: Annotated[str, typer.Option(help="length unit of the scan: m, cm, mm, ft, in")] = "m",
    out: Annotated[Path | None, typer.Option(help="report folder (default reports/rock_<name>/)")] = None,
    pose: Annotated[
        str,
        typer.Option(
            "--pose",
            "--orientation",
            help="resting pose: scan (as scanned; refused when not at rest) | settle (onto the hull face "
            "below the COM) | stable (lowest COM); the scenario key rock.pose takes the same values",
        ),
    ] = "settle",
    scenario: Annotated[
        Path | None,
        typer.Option(
            help="also write a ready scenario TOML for this rock (check/run/threshold accept it); an existing "
            "file is replaced only with --overwrite"
        ),
    ] = None,
    cut_z: Annotated[
        float | None, typer.Option(help="split one scan at z = cut (m): rock above, pedestal below")
    ] = None,
    alpha_multiple: Annotated[
        float | None, typer.Option(help="point cloud: alpha as a multiple of the spacing (> 0)")
    ] = None,
    grid_spacing: Annotated[
        float | None, typer.Option(help="node grid spacing, m (> 0; default 1/40 of the rock's size)")
    ] = None,
    overwrite: Annotated[
        bool,
        typer.Option(
            "--overwrite",
            help="replace an existing --scenario file (and a point cloud's <stem>.rock.obj beside it; default: refuse)",
        ),
    ] = False,
) -> None:
    """Rock model of a scan: mass, COM, inertia, contact patch, critical tilt per direction; writes a small report."""
    from pbr_xval.cli.rock_impl import rock_command

    code = rock_command(
        scan,
        pedestal,
        density,
        units,
        out,
        mass=mass,
        pose=pose,
        scenario=scenario,
        cut_z=cut_z,
        alpha_multiple=alpha_multiple,
        grid_spacing=grid_spacing,
        console=console,
        overwrite=overwrite,
    )
    if code:
        raise typer.Exit(code)
