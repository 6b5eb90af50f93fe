"""``pbr-xval validate --ensemble``: P(topple) per test from the scenario's ``[uncertainty]``."""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pytest
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
    # friction and density this close to nominal change no outcome: every member agrees with the lab;
    # 4 of 4 (0 of 4) members give the Jeffreys posterior mean 4.5 / 5 = 0.9 (0.1), Brier 0.1² = 0.01
    assert "F1 ensemble 1.0000" in lines and "Brier ensemble 0.0100" in lines
    oc = pd.read_csv(out / "outcomes.csv", dtype={"test": str})
    assert oc["p_ensemble"].tolist() == pytest.approx([0.9 if o else 0.1 for o in observed], abs=1e-12)
    assert oc["members_ensemble"].tolist() == [4] * 6
    mem = pd.read_csv(out / "ensemble_members.csv", dtype={"test": str})
    assert len(mem) == 24 and set(mem["member"]) == {0, 1, 2, 3}
    assert mem["value:contact.friction_static"].between(0.9, 1.1).all()
    assert (mem["mu"] == mem["value:contact.friction_static"]).all()  # each member's own friction ran
    doc = json.loads((out / "validation.json").read_text())
    assert doc["ensemble_members"] == 4 and doc["ensemble_uncertainty"]["seed"] == 2
    # the closing line times both phases (it used to give the deterministic phase's time alone)
    wrote = next(ln for ln in lines if ln.startswith("wrote "))
    assert f"(deterministic runs {doc['wall_s']:.1f} s, ensemble {doc['ensemble_wall_s']:.1f} s)" in wrote
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


def test_per_test_draws_fresh_members_for_every_test(
    box_campaign_files: tuple[Path, Path, list[int]], tmp_path: Path
) -> None:
    """Lab mode (default): member i has the same values in every test; field mode (per_test): fresh draws."""
    from pbr_xval.scenario import load_scenario
    from pbr_xval.uncertainty import ensemble_spec
    from pbr_xval.validation.campaign import Baseline, load_campaign
    from pbr_xval.validation.ensemble import build_ensemble_chunks
    from pbr_xval.validation.execution import prepare_motions

    csv, scn_path, _ = box_campaign_files
    camp = load_campaign(csv, 1)
    motions = prepare_motions(
        camp, Baseline(detrend="none", highpass_hz=None, lowpass_hz=None, resample_hz=None), tmp_path / "m"
    )
    values = {}
    for per_test in (False, True):
        scn_path.write_text(
            scn_path.read_text().split("[uncertainty]")[0]
            + UNCERTAINTY
            + f"per_test = {str(per_test).lower()}\n"
        )
        scn = load_scenario(scn_path)
        spec = ensemble_spec(scn)
        assert spec is not None and spec.per_test is per_test
        members = {t.test: spec.for_test(t.test).sample() for t in camp.tests}
        chunks = build_ensemble_chunks(camp, motions, scn, members)
        by_test: dict[str, list] = {}
        for c in chunks:
            for m in c.motions:
                by_test.setdefault(m["params"]["test"], []).append(
                    (m["member"], m["values"]["contact.friction_static"])
                )
        values[per_test] = {t: sorted(v) for t, v in by_test.items()}
    shared, fresh = values[False], values[True]
    assert len({tuple(v) for v in shared.values()}) == 1  # the same 4 members in every test
    assert len({tuple(v) for v in fresh.values()}) == 6  # every test its own draws
    t0 = camp.tests[0].test
    assert spec.for_test(t0).sample() == spec.for_test(t0).sample()  # still deterministic


def test_adaptive_ensemble_stops_each_test_once_decided(
    box_campaign_files: tuple[Path, Path, list[int]], tmp_path: Path
) -> None:
    """--half-width: batches of 2; every member of every test agrees, so the Jeffreys interval
    excludes 0.5 after 4 members (k = 0: [0, 0.445]; k = 4: [0.555, 1]) and no test gets more of
    the 8 allowed; after 2 members it does not yet (k = 0: [0, 0.66])."""
    csv, scn, observed = box_campaign_files
    scn.write_text(scn.read_text() + UNCERTAINTY.replace("members = 4", "members = 8"))
    out = tmp_path / "adaptive"
    args = ["validate", str(csv), "--specimen", "1", "--scenario", str(scn), "--ensemble", "--out", str(out),
            "--folds", "3", "--tail", "2", "--workers", "1", "--half-width", "0.05", "--batch", "2", *RAW]  # fmt: skip
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    oc = pd.read_csv(out / "outcomes.csv", dtype={"test": str})
    assert oc["p_ensemble"].tolist() == pytest.approx([0.9 if o else 0.1 for o in observed], abs=1e-12)
    assert oc["members_ensemble"].tolist() == [4] * 6
    doc = json.loads((out / "validation.json").read_text())
    assert doc["ensemble_adaptive"] == {"half_width": 0.05, "batch": 2} and doc["ensemble_member_runs"] == 24
    bad = runner.invoke(app, [*args[:-10], "--half-width", "0.7"])
    assert bad.exit_code == 2 and "--half-width 0.7" in bad.output
