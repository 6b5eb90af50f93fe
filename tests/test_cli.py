"""The pbr-xval command line on the built-in examples."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from pbr_xval.cli import app
from pbr_xval.engine import Trajectory

ROOT = Path(__file__).resolve().parents[1]
HOUSNER = str(ROOT / "examples" / "housner_halfsine.toml")
runner = CliRunner()


def test_check_prints_resolved_model() -> None:
    res = runner.invoke(app, ["check", HOUSNER])
    assert res.exit_code == 0, res.output
    assert "Content hash" in res.output and "460.8 kg" in res.output and "3.27" in res.output


def test_check_reports_bad_file(tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text(Path(HOUSNER).read_text().replace("density = 2400.0", "density = -1.0"))
    res = runner.invoke(app, ["check", str(bad)])
    assert res.exit_code == 2
    assert "bad.toml" in res.output and "rock.density" in res.output


@pytest.mark.parametrize(
    ("variant", "expected", "tol"),
    [("exact", 5.638, 5e-4), ("linearized", 5.44, 2e-3), ("housner1963", 6.616, 1e-3)],
)
def test_threshold_variants(tmp_path: Path, variant: str, expected: float, tol: float) -> None:
    out = tmp_path / "t.json"
    args = [
        "threshold",
        HOUSNER,
        "--engine",
        "housner",
        "--set",
        f"variant={variant}",
        "--hi",
        "12",
        "--json",
        str(out),
    ]
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    data = json.loads(out.read_text())
    assert abs(data["minimum"] / expected - 1) < tol, data
    # the bracket is narrowed to rel_tol (default 1e-3): half-width ≤ rel_tol/2 of its upper end
    assert data["tolerance"] <= 0.5 * data["rel_tol"] * 1.001 * (data["minimum"] + data["tolerance"])
    assert data["status"] == "bracketed" and data["settings"]["variant"] == variant
    assert "minimum toppling" in res.output


def test_run_writes_trajectory(tmp_path: Path) -> None:
    out = tmp_path / "traj.parquet"
    res = runner.invoke(app, ["run", HOUSNER, "--engine", "housner", "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert out.exists() and "peak_abs_theta_rad" in res.output


def test_engines_lists_registry() -> None:
    res = runner.invoke(app, ["engines"])
    assert res.exit_code == 0
    assert "housner" in res.output and "curved_base" in res.output


def test_unknown_setting_is_a_clear_error() -> None:
    res = runner.invoke(app, ["run", HOUSNER, "--engine", "housner", "--engine-set", "rtoll=1"])
    assert res.exit_code == 2 and "unknown setting 'rtoll'" in res.output
    res = runner.invoke(app, ["run", HOUSNER, "--engine", "housner", "--set", "rtoll=1"])
    assert res.exit_code == 2 and "key 'rtoll': unknown key" in res.output and "--engine-set" in res.output


def test_run_set_takes_scenario_keys(tmp_path: Path) -> None:
    """--set changes the scenario (as threshold --param does): 24 m/s² topples the block, 5 does not."""
    outs = {}
    for amp in (5.0, 24.0):
        out = tmp_path / f"a{amp:g}.parquet"
        args = ["run", HOUSNER, "-e", "housner", "--set", f"excitation.amplitude={amp}", "--out", str(out)]
        res = runner.invoke(app, args)
        assert res.exit_code == 0, res.output
        outs[amp] = Trajectory.load_parquet(out)
    # the exact two-pivot threshold of this block is 5.638 m/s² (Makris & Roussos 2000; seed §4.1)
    assert not outs[5.0].toppled and outs[24.0].toppled
    # a table the scenario leaves at its defaults can be set too
    out = tmp_path / "e.parquet"
    res = runner.invoke(app, ["run", HOUSNER, "-e", "housner", "--set", "seed=3", "--out", str(out)])
    assert res.exit_code == 0, res.output


def test_run_engine_settings_old_and_new_option(tmp_path: Path) -> None:
    out = tmp_path / "t.parquet"
    res = runner.invoke(
        app, ["run", HOUSNER, "-e", "housner", "--engine-set", "rtol=1e-8", "--out", str(out)]
    )
    assert res.exit_code == 0, res.output
    assert Trajectory.load_parquet(out).settings["rtol"] == 1e-8
    # backward compatibility: an engine setting given to --set is used, with a note
    out2 = tmp_path / "t2.parquet"
    res = runner.invoke(app, ["run", HOUSNER, "-e", "housner", "--set", "rtol=1e-9", "--out", str(out2)])
    assert res.exit_code == 0, res.output
    assert "--engine-set rtol" in res.output and Trajectory.load_parquet(out2).settings["rtol"] == 1e-9


def test_run_never_overwrites_silently(tmp_path: Path) -> None:
    folder = tmp_path / "runs"
    folder.mkdir()
    res = runner.invoke(app, ["run", HOUSNER, "-e", "housner", "--out", str(folder)])
    assert res.exit_code == 0, res.output
    written = folder / "housner_halfsine.housner.parquet"
    assert written.is_file()
    before = written.stat().st_mtime_ns
    res = runner.invoke(app, ["run", HOUSNER, "-e", "housner", "--out", str(folder)])
    assert res.exit_code == 2 and "file exists" in res.output and "--overwrite" in res.output
    assert written.stat().st_mtime_ns == before
    res = runner.invoke(app, ["run", HOUSNER, "-e", "housner", "--out", str(written), "--overwrite"])
    assert res.exit_code == 0, res.output


def test_rock_command_on_a_synthetic_rock(tmp_path: Path) -> None:
    from pbr_xval.geometry.synthetic import synthetic_rock

    mesh, _ = synthetic_rock(seed=3)
    path = tmp_path / "rock.obj"
    mesh.export(path)
    out = tmp_path / "rep"
    res = runner.invoke(app, ["rock", str(path), "--out", str(out), "--density", "2600"])
    assert res.exit_code == 0, res.output
    data = json.loads((out / "rock.json").read_text())
    assert data["mass_kg"] == pytest.approx(2600 * mesh.volume, rel=1e-6)
    assert (out / "polar.png").stat().st_size > 1000 and (out / "rock.png").exists()


def test_rock_command_refuses_a_flat_scan(tmp_path: Path) -> None:
    path = tmp_path / "flat.xyz"
    path.write_text("0 0 0\n1 0 0\n0 1 0\n1 1 0\n")
    res = runner.invoke(app, ["rock", str(path), "--out", str(tmp_path / "r")])
    assert res.exit_code == 2
    assert "flat.xyz" in res.output


def _documented_commands() -> list[tuple[str, str]]:
    """(where, command line) for every `pbr-xval ...` in README.md and docs/*.md (code spans and blocks)."""
    import re

    out = []
    for doc in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        lines: list[tuple[int, str]] = []  # shell line continuations (a trailing backslash) joined
        for n, line in enumerate(doc.read_text().splitlines(), start=1):
            if lines and lines[-1][1].rstrip().endswith("\\"):
                lines[-1] = (lines[-1][0], lines[-1][1].rstrip()[:-1] + " " + line.strip())
            else:
                lines.append((n, line))
        for n, line in lines:
            spans = re.findall(r"`(pbr-xval [^`]+)`", line)
            stripped = line.strip().lstrip("$ ")
            if (
                stripped.startswith("pbr-xval ")
                or stripped.startswith("run: pbr-xval ")
                or stripped.startswith("- pbr-xval ")
            ):
                spans.append(stripped[stripped.index("pbr-xval") :].split("  #")[0])
            out += [(f"{doc.name}:{n}", s) for s in spans]
    return out


@pytest.mark.parametrize(("where", "line"), _documented_commands(), ids=lambda x: str(x)[:60])
def test_documented_commands_match_the_cli(where: str, line: str) -> None:
    """Every option a document shows exists on that command; the positional arguments fit."""
    import shlex

    import typer

    group = typer.main.get_command(app)
    tokens = shlex.split(line.replace("[", " ").replace("]", " ").replace("\\|", "|").replace("...", " "))
    assert tokens[0] == "pbr-xval"
    if len(tokens) == 1 or tokens[1].startswith("-"):
        return
    name = tokens[1]
    assert name in group.commands, f"{where}: no command {name!r} ({line})"
    cmd = group.commands[name]
    if len(tokens) == 2:  # the command named in prose
        return
    # typer vendors its own click: tell options from arguments by their type name
    opts = {o: p for p in cmd.params if p.param_type_name == "option" for o in (*p.opts, *p.secondary_opts)}
    args = [p for p in cmd.params if p.param_type_name == "argument"]
    positional = []
    it = iter(tokens[2:])
    for tok in it:
        if tok.startswith("-") and len(tok) > 1 and not tok[1].isdigit():
            opt = tok.split("=", 1)[0]
            assert opt in opts, f"{where}: {name} has no option {opt} ({line}); it has {sorted(opts)}"
            if not opts[opt].is_flag and "=" not in tok:
                next(it, None)
        else:
            positional.append(tok)
    required = sum(1 for a in args if a.required)
    assert required <= len(positional) <= len(args), (
        f"{where}: {name} takes {len(args)} positional argument(s) ({[a.name for a in args]}), "
        f"the document gives {positional} ({line})"
    )
