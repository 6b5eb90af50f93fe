"""CI guard of the lab-mode ensembles' Brier and F1 (issue 22, docs/validation.md "What CI guards").

The subset is fixed by a rule stated before any score on it was computed (chosen for its cost):
**every 27th test of the calibration list** (``experiments.csv`` order, from the first: every 9th
of the 66 screening tests the "Ensemble scores" table scores), on both specimens — 8 tests each.
The ensemble is the committed lab-mode one (``examples/validation/sp<N>.toml``: the MuJoCo +
PyBullet mixture with its stacked ``engine_weights`` and its ``[uncertainty]`` table), adaptive as documented (batches of 4 until the
Jeffreys 95 % half-width is ≤ 0.1 or the interval excludes 0.5) but **at most 8 members**: the first
8 members of the documented 16-member design, to fit CI's time budget.

``examples/validation/robustness/ensemble_sp<N>_guard.json`` (written by
``python -m pbr_xval.validation.robustness --ensemble``, see docs/validation.md) holds, for that
configuration, each test's P(topple) as run here and under perturbations of every member far below
physical uncertainty or of the machine (1e-9 rad of seating tilt, OpenBLAS's Haswell kernels,
dt × 1.01). Checked against the lab's observed outcomes, on whatever machine runs this:

1. every test's P lies in the Jeffreys 95 % interval of the recorded base run (the claim "an
   ensemble's P(topple) is the same on any machine within its stated interval");
2. the Brier score and F1 at P ≥ 0.5 lie in the interval spanned when each test's P takes any value
   it took under a perturbation (:func:`~pbr_xval.validation.robustness.ensemble_score_range`), and
   so do the figures docs/validation.md quotes;
3. the claim's direction: the ensemble's Brier is below the best out-of-fold logistic baseline's
   (fitted on all 196 calibration tests, scored on the same tests) — asserted only where the
   worst case of 2. keeps it below (``margin_worst_case`` > 0). On this subset it does not, on
   either specimen (measured 2026-11-26: docs/validation.md says so, and the first test below
   checks that the docs and the JSON agree): 8 tests, 2 of them toppled, cannot carry it.

The interval of 2. (``brier_range``, ``f1_range``): a test is *fragile* if a member's outcome flipped
under a perturbation, *undecided* if its members disagree (0 < P < 1: they sit near their
threshold); those tests may take any P in the recorded run's Jeffreys 95 % interval, every other
test the P it had under every perturbation. A decided test that flips a member on another machine
moves Brier by at most (1/4)²/8 ≈ 0.008, inside the slack the undecided tests give.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from .conftest import REPO, SCANS, SHAKE_TABLE, SP1_SCENARIO

ROBUSTNESS = SP1_SCENARIO.parent / "robustness"
#: the subset rule: every STRIDE-th test of the calibration list, from the first
STRIDE = 27
MAX_MEMBERS = 8
HALF_WIDTH = 0.1
BATCH = 4


def _guard(specimen: int) -> dict:
    return json.loads((ROBUSTNESS / f"ensemble_sp{specimen}_guard.json").read_text())


def _documented(specimen: int) -> tuple[float, float, bool]:
    """(Brier, F1, whether the direction is said to be guarded) of the ensemble on the CI subset, as
    docs/validation.md "What CI guards" quotes them."""
    doc = (REPO / "docs" / "validation.md").read_text()
    sec = doc[doc.index("### What CI guards") :]
    row = next(ln for ln in sec.splitlines() if ln.startswith(f"| SP{specimen} |"))
    m = re.search(r"Brier \*\*([0-9.]+)\*\*.*F1 \*\*([0-9.]+)\*\*", row)
    assert m, row
    return float(m.group(1)), float(m.group(2)), "not guarded" not in row


@pytest.mark.parametrize("specimen", [1, 2])
def test_guard_file_matches_the_rule(specimen: int) -> None:
    """The committed intervals were measured on the subset the rule gives, with this configuration,
    and the documented figures are the recorded base run's (to the 3 decimals quoted)."""
    g = _guard(specimen)
    assert g["specimen"] == specimen
    assert g["ensemble"] == {"members": MAX_MEMBERS, "half_width": HALF_WIDTH, "batch": BATCH}
    assert {"base", "tilt", "haswell"} <= set(g["variants_run"])
    brier, f1, direction_guarded = _documented(specimen)
    assert abs(brier - g["scores"]["base"]["brier"]) <= 5e-4 and abs(f1 - g["scores"]["base"]["f1"]) <= 5e-4
    # the docs say the direction is guarded exactly when the worst case keeps it (check 3 below)
    assert direction_guarded == (g["margin_worst_case"] > 0)
    lo, hi = g["brier_range"]
    assert lo - 5e-4 <= brier <= hi + 5e-4
    lo, hi = g["f1_range"]
    assert lo - 5e-4 <= f1 <= hi + 5e-4
    if SHAKE_TABLE.is_dir():
        import pandas as pd

        ex = pd.read_csv(SHAKE_TABLE / "experiments.csv", dtype={"test": str})
        assert g["tests"] == ex["test"].tolist()[::STRIDE]
        obs = dict(zip(ex["test"], ex[f"toppled_specimen{specimen}"].astype(int), strict=True))
        assert all(g["per_test"][t]["observed"] == obs[t] for t in g["tests"])


@pytest.mark.slow
@pytest.mark.parametrize("specimen", [1, 2])
def test_ensemble_scores_against_the_experiments(specimen: int, tmp_path: Path) -> None:
    pytest.importorskip("mujoco")
    pytest.importorskip("pybullet")
    scn = SP1_SCENARIO.with_name(f"sp{specimen}.toml")
    mesh = SCANS / "SP1_mesh.obj" if specimen == 1 else scn.with_name("sp2.rock.obj")
    if not (SHAKE_TABLE.is_dir() and mesh.is_file()):
        pytest.skip("shared data (or examples/validation/sp2.rock.obj: run make_sp2_mesh.py) not present")
    from pbr_xval.uncertainty import jeffreys_interval
    from pbr_xval.validation.robustness import logistic_out_of_fold
    from pbr_xval.validation.scores import probabilistic_scores

    g = _guard(specimen)
    from pbr_xval.validation.robustness import run_ensemble_variant

    rows, _members = run_ensemble_variant(
        SHAKE_TABLE, specimen, scn, tmp_path, tests=g["tests"], members=MAX_MEMBERS, half_width=HALF_WIDTH,
        batch=BATCH, workers=2,
    )  # fmt: skip
    assert rows["test"].tolist() == g["tests"]
    assert (rows["failed"] == 0).all() and (rows["n"] >= BATCH).all()
    # 1. every P inside the recorded run's Jeffreys 95 % interval
    outside = {}
    for r in rows.itertuples():
        base = g["per_test"][r.test]["base"]
        lo, hi = jeffreys_interval(base["k"], base["n"])
        if not lo <= r.p <= hi:
            outside[r.test] = (base["p"], r.p, (lo, hi))
    assert not outside, (
        f"P outside the recorded run's Jeffreys 95 % interval (test: recorded, now, interval): {outside}"
    )
    # 2. Brier and F1 against the observed outcomes, inside the perturbations' interval
    obs = rows["observed"].to_numpy(int)
    assert obs.tolist() == [g["per_test"][t]["observed"] for t in g["tests"]]
    s = probabilistic_scores(obs, rows["p"].to_numpy(float))
    lo, hi = g["brier_range"]
    assert lo - 1e-12 <= s["brier"] <= hi + 1e-12, (s["brier"], g["brier_range"])
    lo, hi = g["f1_range"]
    assert lo - 1e-12 <= s["f1"] <= hi + 1e-12, (s["f1"], g["f1_range"])
    # 3. the claim's direction against the best out-of-fold logistic baseline on the same tests
    lb = logistic_out_of_fold(SHAKE_TABLE, specimen, g["tests"])
    best = min(float(np.mean((p - obs) ** 2)) for p in lb.values())
    assert abs(best - g["baselines_brier"][g["best_baseline"]]) <= 1e-6
    if g["margin_worst_case"] > 0:
        assert s["brier"] < best
