"""The typer application and what every command group shares: consoles, option types, input helpers."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.markup import escape

from pbr_xval.console import make_console

app = typer.Typer(
    help="Cross-validate physics engines on precariously balanced rocks.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
console = make_console()
err = make_console(stderr=True)


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
        err.print(f"[red]error:[/] {escape(str(exc))}", soft_wrap=True)
        raise typer.Exit(2) from None


def _fail(msg: str, code: int = 2) -> typer.Exit:
    err.print(f"[red]error:[/] {escape(msg)}", soft_wrap=True)  # one line, brackets kept
    return typer.Exit(code)


SetOpt = Annotated[
    list[str] | None,
    typer.Option(
        "--set", help="engine setting override key=value (repeatable), e.g. --set variant=linearized"
    ),
]
ProfileOpt = Annotated[
    str | None, typer.Option(help="engine settings profile, e.g. faithful or engine-default")
]


def _fraction(text: str) -> float:
    """'5%' → 0.05; '0.05' → 0.05."""
    t = text.strip()
    try:
        return float(t[:-1]) / 100 if t.endswith("%") else float(t)
    except ValueError:
        raise typer.BadParameter(
            f"expected a fraction like 0.05 or a percentage like 5%, got {text!r}"
        ) from None
