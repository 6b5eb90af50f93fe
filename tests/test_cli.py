"""The pbr-xval command line on the built-in examples."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from pbr_xval.cli import app

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
    assert data["tolerance"] < 1e-3 and data["settings"]["variant"] == variant
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
    res = runner.invoke(app, ["run", HOUSNER, "--engine", "housner", "--set", "rtoll=1"])
    assert res.exit_code == 2 and "unknown setting 'rtoll'" in res.output


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
