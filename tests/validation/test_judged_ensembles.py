"""docs/validation.md, "The judged command": the table's figures are the committed 16-member reports'.

The four ensemble reports under ``reports/`` were written by the command issue 22's goals are judged by
(``pbr-xval validate … --ensemble``, no ``--half-width``: every member on every test). Their Brier, log
loss, AUC and F1 were scored by ``validate`` against the lab's observed outcomes (scikit-learn's metrics);
this test keeps the page and the reports in step: every number of the table's row and the percentages
against the out-of-fold logistic law and the transferred law are recomputed from ``scores.csv``, and
``validation.json`` must say 16 members on every test of the 196, not adaptive.
"""

from __future__ import annotations

import csv
import json
import re
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]

ROWS = [  # (the table's first cell, report folder, scenario, the baseline its percentage is against)
    ("SP1, lab", "validate_sp1_ensemble", "examples/validation/sp1.toml", "logistic(lnPGA,lnPGV)"),
    ("SP2, lab", "validate_sp2_ensemble", "examples/validation/sp2.toml", "logistic(lnPGA,lnPGV)"),
    ("SP1, field", "validate_sp1_field_ensemble", "examples/validation/sp1_field.toml", "transferred"),
    ("SP2, field", "validate_sp2_field_ensemble", "examples/validation/sp2_field.toml", "transferred"),
]


def _section() -> str:
    doc = (REPO / "docs" / "validation.md").read_text()
    start = doc.index("**The judged command: every member on every test.**")
    return doc[start : doc.index("**A rehearsal of the held-out judgement**", start)]


def _num(s: str) -> float:
    return float(s.replace("*", "").replace("−", "-").strip())


@pytest.mark.parametrize(("label", "folder", "scenario", "baseline"), ROWS)
def test_judged_command_table_is_the_committed_reports(
    label: str, folder: str, scenario: str, baseline: str
) -> None:
    rows = [ln for ln in _section().splitlines() if ln.startswith(f"| {label} |")]
    assert len(rows) == 1, f"docs/validation.md, 'The judged command': {len(rows)} rows {label!r}"
    cells = [c.strip() for c in rows[0].strip("|").split("|")]
    rep = REPO / "reports" / folder
    with (rep / "scores.csv").open() as fh:
        scores = {r["model"]: r for r in csv.DictReader(fh)}
    meta = json.loads((rep / "validation.json").read_text())
    # the judged command: the committed scenario, all 16 members on every one of the 196 tests
    assert meta["scenario"] == scenario and meta["tests"] == 196
    assert meta["ensemble_members"] == 16 and meta["ensemble_adaptive"] is None
    assert meta["ensemble_member_runs"] == 16 * 196 and meta["ensemble_failed_runs"] == 0
    ens = scores["ensemble"]
    brier, logloss, auc, f1 = (_num(x) for x in cells[1].split("(")[0].split("/"))
    for doc, key in ((brier, "brier"), (logloss, "log_loss"), (auc, "auc"), (f1, "f1")):
        assert doc == pytest.approx(float(ens[key]), abs=5e-4), (label, key)
    confusion = re.search(r"TP (\d+) FP (\d+) FN (\d+) TN (\d+)", cells[1])
    if confusion:
        assert [int(x) for x in confusion.groups()] == [int(ens[k]) for k in ("tp", "fp", "fn", "tn")]
    best_logistic = _num(cells[3].split("(")[0])
    assert best_logistic == pytest.approx(float(scores["logistic(lnPGA,lnPGV)"]["brier"]), abs=5e-4)
    # the best logistic is the best of the three logistic laws on this specimen
    assert float(scores["logistic(lnPGA,lnPGV)"]["brier"]) <= min(
        float(scores[m]["brier"]) for m in ("logistic(lnPGA)", "logistic(lnPGV)")
    )
    assert _num(cells[5].split(":")[0]) == pytest.approx(float(scores["transferred"]["brier"]), abs=5e-4)
    pct_cell = cells[4] if baseline != "transferred" else cells[5].split(":", 1)[1]
    pct = _num(re.search(r"([−\-+]?[\d.]+) %", pct_cell).group(1))  # type: ignore[union-attr]
    want = 100 * (float(ens["brier"]) / float(scores[baseline]["brier"]) - 1)
    assert pct == pytest.approx(want, abs=0.5 if abs(want) >= 10 else 0.05), (label, pct, want)
