"""``pbr-xval validate --ensemble``: P(topple) per test from the scenario's ``[uncertainty]``."""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
from typer.testing import CliRunner

from pbr_xval.cli import app

runner = CliRunner()
RAW = ["--highpass", "0", "--lowpass", "0", "--detrend", "none", "--resample", "0"]

UNCERTAINTY = """
[uncertainty]
members = 4
seed = 2
engines = ["housner"]
"contact.friction_static" = { dist = "uniform", low = 0.9, high = 1.1 }
"rock.density" = { dist = "lognormal", median = 2500.0, beta = 0.05 }
"""


def test_validate_ensemble_scores_and_resumes(
    box_campaign_files: tuple[Path, Path, list[int]], tmp_path: Path
) -> None:
    csv, scn, observed = box_campaign_files
    scn.write_text(scn.read_text() + UNCERTAINTY)
    out = tmp_path / "report"
    # no --engine: the mixture's engines run deterministically too
    args = ["validate", str(csv), "--specimen", "1", "--scenario", str(scn), "--ensemble", "--out", str(out),
            "--folds", "3", "--tail", "2", "--workers", "1", *RAW]  # fmt: skip
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    lines = res.output.splitlines()
    assert "F1 housner 1.0000" in lines
    # friction and density this close to nominal change no outcome: every member agrees with the lab
    assert "F1 ensemble 1.0000" in lines and "Brier ensemble 0.0000" in lines
    oc = pd.read_csv(out / "outcomes.csv", dtype={"test": str})
    assert oc["p_ensemble"].tolist() == [float(o) for o in observed]
    assert oc["members_ensemble"].tolist() == [4] * 6
    mem = pd.read_csv(out / "ensemble_members.csv", dtype={"test": str})
    assert len(mem) == 24 and set(mem["member"]) == {0, 1, 2, 3}
    assert mem["value:contact.friction_static"].between(0.9, 1.1).all()
    assert (mem["mu"] == mem["value:contact.friction_static"]).all()  # each member's own friction ran
    doc = json.loads((out / "validation.json").read_text())
    assert doc["ensemble_members"] == 4 and doc["ensemble_uncertainty"]["seed"] == 2
    # resumable: nothing is simulated again
    res2 = runner.invoke(app, args)
    assert res2.exit_code == 0 and "F1 ensemble 1.0000" in res2.output
    doc2 = json.loads((out / "validation.json").read_text())
    assert doc2["ensemble_chunks_run_skipped_failed"].startswith("0/")
    assert doc2["chunks_run_skipped_failed"].startswith("0/")


def test_validate_ensemble_needs_an_uncertainty_table(
    box_campaign_files: tuple[Path, Path, list[int]], tmp_path: Path
) -> None:
    csv, scn, _ = box_campaign_files
    args = [
        "validate",
        str(csv),
        "--scenario",
        str(scn),
        "--ensemble",
        "--engine",
        "housner",
        "--out",
        str(tmp_path / "r"),
        *RAW,
    ]
    res = runner.invoke(app, args)
    assert res.exit_code == 2 and "no [uncertainty] table" in res.output
