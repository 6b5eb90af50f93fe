"""docs/validation.md, "Is the experiment itself repeatable?": the counts of near-twin tests (same record,
sheet PGA within 5 % / 10 %) and of those with opposite outcomes, recounted here from the lab sheet
(``experiments.csv``, the independent reference) — not with ``tools/ensemble_scores.py repeats``, which
printed them for the page."""

from __future__ import annotations

import itertools
import math
import re

import pandas as pd
import pytest

from .conftest import REPO, SHAKE_TABLE

pytestmark = pytest.mark.skipif(
    not (SHAKE_TABLE / "experiments.csv").is_file(), reason="shared shake-table data not present"
)


def _section() -> str:
    doc = " ".join((REPO / "docs" / "validation.md").read_text().split())
    start = doc.index("**Is the experiment itself repeatable?")
    return doc[start : doc.index("**Re-seating between sessions", start)]


def _twins(specimen: int, tol: float) -> tuple[int, list[tuple[int, int]]]:
    """Same-record pairs with |ln(PGA_a / PGA_b)| ≤ tol; the discordant ones as (test, test)."""
    ex = pd.read_csv(SHAKE_TABLE / "experiments.csv")
    n, discordant = 0, []
    for _, rec in ex.groupby("motion"):
        for (_, a), (_, b) in itertools.combinations(rec.iterrows(), 2):
            if abs(math.log(a.pga_g / b.pga_g)) <= tol:
                n += 1
                if a[f"toppled_specimen{specimen}"] != b[f"toppled_specimen{specimen}"]:
                    discordant.append(tuple(sorted((int(a.test), int(b.test)))))
    return n, sorted(discordant)  # type: ignore[arg-type]


def test_twin_counts_on_the_page_match_the_lab_sheet() -> None:
    text = _section()
    m = re.search(r"within 5 %: (\d+) pairs .*?(\d+) of those (\d+) pairs gave opposite outcomes", text)
    assert m, "docs/validation.md: the 5 % twin sentence is missing"
    n5, d5, n5b = map(int, m.groups())
    m10 = re.search(r"within 10 %: (\d+) of (\d+)\)", text)
    assert m10
    d10, n10 = map(int, m10.groups())
    for spec in (1, 2):
        n, dis = _twins(spec, 0.05)
        assert (n, len(dis)) == (n5, d5) and n5 == n5b, (spec, n, dis)
        n, dis = _twins(spec, 0.10)
        assert (n, len(dis)) == (n10, d10), (spec, n, dis)
    # the SP2 pairs the page names, and which of each toppled
    _, dis = _twins(2, 0.10)
    assert dis == [(59, 90), (269, 361), (374, 396)]
    ex = pd.read_csv(SHAKE_TABLE / "experiments.csv").set_index("test")
    assert [int(ex.loc[t, "toppled_specimen2"]) for t in (374, 396, 269, 361, 59, 90)] == [1, 0, 1, 0, 0, 1]
    assert [int(ex.loc[t, "toppled_specimen1"]) for t in (269, 361)] == [0, 1]
    # the floor the page quotes: six tests, at least 0.25 each, over the specimen's 196 tests
    floor = re.search(r"at least 6 × 0\.25 / 196 = ([0-9.]+)", text)
    assert floor and float(floor.group(1)) == pytest.approx(6 * 0.25 / len(ex), abs=5e-5)


def _bullet(title: str) -> str:
    """The docs/validation.md bullet that starts with ``title`` (whitespace collapsed), up to the next bullet."""
    doc = " ".join((REPO / "docs" / "validation.md").read_text().split())
    start = doc.index(title)
    return doc[start : doc.index("* **", start + 1)]


def _bands_section() -> str:
    return _bullet("**Where SP2's shortfall sits")


def test_sp2_shortfall_counts_on_the_page_match_the_lab_sheet() -> None:
    """The tests and topples per PGV/PGA band and on 2021-08-19 in the "Where SP2's shortfall sits"
    table and text, recounted from the lab sheet (the expected counts and shares are one-off)."""
    text = _bands_section()
    ex = pd.read_csv(SHAKE_TABLE / "experiments.csv")
    v = ex.pgv_over_pga_s
    bands = {
        "sheet PGV/PGA ≤ 0.06 s": v <= 0.06,
        "0.06–0.08 s": (v > 0.06) & (v <= 0.08),
        "0.08–0.10 s": (v > 0.08) & (v <= 0.10),
        "0.10–0.15 s": (v > 0.10) & (v <= 0.15),
        "> 0.15 s": v > 0.15,
        "day 2021-08-19": ex.date == 20210819,
    }
    for label, m in bands.items():
        row = re.search(re.escape(f"| {label} | ") + r"(\d+) \| (\d+) \|", text)
        assert row, f"docs/validation.md: no row {label!r}"
        assert (int(row.group(1)), int(row.group(2))) == (int(m.sum()), int(ex.toppled_specimen2[m].sum())), (
            label
        )
    day = ex[ex.date == 20210819]
    short = day[(day.pgv_over_pga_s >= 0.04) & (day.pgv_over_pga_s <= 0.08)]
    only = [r for r in day.motion.unique() if set(ex.date[ex.motion == r]) == {20210819}]
    assert "24 tests, 23 of them the lab's `.AT2` records" in text
    assert (len(day), int(day.motion.str.endswith(".AT2").sum())) == (24, 23)
    assert (
        f"eight records ({int(ex.motion.isin(only).sum())} tests) tested that day only" in text
        and len(only) == 8
    )
    assert f"{len(short)} tests at sheet PGV/PGA 0.04–0.08 s, which hold all its topples" in text
    assert int(short.toppled_specimen2.sum()) == int(day.toppled_specimen2.sum()) == 14
    assert int(day.toppled_specimen1.sum()) == 15 and "SP1 on the same day: 15 topples" in text
    assert "12 % of SP2's tests" in text and round(100 * len(day) / len(ex)) == 12
    assert "other 172 tests" in text and len(ex) - len(day) == 172


def test_support_geometry_observed_counts_match_the_lab_sheet() -> None:
    """The observed topples per PGV/PGA band quoted beside the support-geometry runs (the predicted
    counts are one-off), recounted from the lab sheet."""
    text = _bullet("**The support geometry (where the rock pivots)")
    ex = pd.read_csv(SHAKE_TABLE / "experiments.csv")
    v = ex.pgv_over_pga_s
    short, mid, long_ = v < 0.06, (v >= 0.06) & (v < 0.10), v >= 0.10
    for spec, first_row in ((1, "| SP1 | 0.8 |"), (2, "| SP2 | 0.8 |")):
        o = ex[f"toppled_specimen{spec}"]
        row = text[text.index(first_row) :].split("|")[:12]
        assert f"({int(o.sum())})" in row[9], (spec, row)
        assert (
            row[10].strip().endswith(f"({int(o[short].sum())} / {int(o[mid].sum())} / {int(o[long_].sum())})")
        ), (spec, row)
    o2 = ex.toppled_specimen2
    assert f"12–18 of the {int(o2[mid].sum())} topples observed at 0.06–0.10 s" in text
    assert f"22–32 of the {int(o2[short].sum())} below 0.06 s" in text
    rest = mid & (ex.date != 20210819)
    assert f"(MuJoCo 12 of {int(o2[rest].sum())})" in text


def test_band_edges_and_observed_counts_in_the_command_section_match_the_lab_sheet() -> None:
    """ "Errors by band of PGV/PGA" quotes SP2's quartile edges and observed topples: recounted from the
    lab sheet with numpy's quantiles (MuJoCo's predicted counts there are one-off)."""
    import numpy as np

    text = _bullet("* **Errors by band of PGV/PGA**")
    ex = pd.read_csv(SHAKE_TABLE / "experiments.csv")
    r, o = ex.pgv_over_pga_s.to_numpy(), ex.toppled_specimen2.to_numpy()
    q50, q75 = np.quantile(r, [0.5, 0.75])
    assert f"where {int(o[r <= q50].sum())} were observed below {q50:.3f} s" in text
    assert f"where {int(o[(r > q50) & (r <= q75)].sum())} were observed at {q50:.3f}–{q75:.3f} s" in text
