"""docs/validation.md: the corrected table records' PGV against the lab sheet's, overall ("Table records:
baseline correction": the median ratio at the 0.1, 0.3 and 0.5 Hz corners that chose the committed
0.3 Hz) and by the sheet's PGV/PGA ("A softer contact, or less high-frequency shaking": the ratio by
band, flat at no corner). Recomputed here from the shared records with the campaign reader's
correction (:func:`pbr_xval.validation.campaign.baseline_correct`, the one ``validate`` applies) and
the same trapezoidal velocity as :func:`pbr_xval.validation.execution.prepare_motions`, against the
sheet (``experiments.csv``: PGA × PGV/PGA), the independent measurement. No simulation."""

from __future__ import annotations

import re

import numpy as np
import pandas as pd
import pytest

from pbr_xval.validation.campaign import G_STANDARD, Baseline, baseline_correct, load_campaign

from .conftest import REPO, SHAKE_TABLE

pytestmark = pytest.mark.skipif(
    not (SHAKE_TABLE / "experiments.csv").is_file(), reason="shared shake-table data not present"
)

#: the sheet's PGV/PGA bands the page reports, s
BANDS = [0.0, 0.06, 0.08, 0.10, 0.15, np.inf]


def _doc() -> str:
    return " ".join((REPO / "docs" / "validation.md").read_text().split())


@pytest.fixture(scope="module")
def ratios() -> pd.DataFrame:
    """Per test: the sheet's PGV/PGA (s) and the corrected record's PGV / the sheet's at each corner."""
    camp = load_campaign(SHAKE_TABLE, specimen=2)  # the table motion is the same for both specimens
    corners: dict[str, float | None] = {"0.1": 0.1, "0.3": 0.3, "0.5": 0.5, "1": 1.0, "none": None}
    rows = []
    for t in camp.tests:
        raw, dt = t.raw_acceleration()
        sheet_pga = t.sheet["pga_g"] * G_STANDARD
        r: dict[str, float] = {"pvp": t.sheet["pgv_over_pga_s"], "pga_0.3": np.nan}
        sheet_pgv = sheet_pga * r["pvp"]
        for name, hp in corners.items():
            acc, d = baseline_correct(raw, dt, Baseline(highpass_hz=hp))
            v = np.concatenate([[0.0], np.cumsum(d * (acc[:-1] + acc[1:]) / 2)])
            r[name] = float(np.max(np.abs(v))) / sheet_pgv
            if name == "0.3":
                r["pga_0.3"] = float(np.max(np.abs(acc))) / sheet_pga
        rows.append(r)
    out = pd.DataFrame(rows)
    out["band"] = pd.cut(out["pvp"], BANDS)
    return out


def _by_band(df: pd.DataFrame, col: str) -> list[float]:
    return [round(float(x), 2) for x in df.groupby("band", observed=True)[col].median()]


def test_the_chosen_corner_against_the_sheet(ratios: pd.DataFrame) -> None:
    m = re.search(
        r"median ratio of the corrected records' PGV to the sheet's PGV is ([\d.]+) at 0\.3 Hz "
        r"\(([\d.]+) at 0\.1 Hz, ([\d.]+) at 0\.5 Hz\)",
        _doc(),
    )
    assert m, "docs/validation.md: the sentence on the 0.3 Hz corner is missing"
    doc = [float(x) for x in m.groups()]
    got = [round(float(ratios[c].median()), 2) for c in ("0.3", "0.1", "0.5")]
    assert got == doc


def test_the_pgv_ratio_by_band(ratios: pd.DataFrame) -> None:
    text = _doc()
    m = re.search(
        r"median ([\d.]+) with quartiles ([\d.]+)–([\d.]+) at the committed 0\.3 Hz corner, but by the "
        r"sheet's PGV/PGA ([\d.]+) below 0\.06 s \((\d+) tests\), ([\d.]+) at 0\.06–0\.08 s, ([\d.]+) at "
        r"0\.08–0\.10 s, ([\d.]+) at 0\.10–0\.15 s and ([\d.]+) above \((\d+) tests\); no single corner "
        r"makes it flat \(no high-pass: ([\d., ]+); 1 Hz: ([\d., ]+)\)",
        text,
    )
    assert m, "docs/validation.md: the PGV-by-band sentence is missing"
    g = m.groups()
    r03 = ratios["0.3"]
    assert [
        round(float(r03.median()), 2),
        round(float(r03.quantile(0.25)), 2),
        round(float(r03.quantile(0.75)), 2),
    ] == [float(x) for x in g[0:3]]
    assert _by_band(ratios, "0.3") == [float(g[3]), float(g[5]), float(g[6]), float(g[7]), float(g[8])]
    counts = ratios.groupby("band", observed=True).size().tolist()
    assert (counts[0], counts[-1]) == (int(g[4]), int(g[9]))
    assert _by_band(ratios, "none") == [float(x) for x in g[10].split(",")]
    assert _by_band(ratios, "1") == [float(x) for x in g[11].split(",")]
    # "the corrected PGA is within 1 % of the sheet's in every band"
    assert "the corrected PGA is within 1 % of the sheet's in every band" in text
    assert all(abs(x - 1.0) <= 0.01 for x in ratios.groupby("band", observed=True)["pga_0.3"].median())
    # the claim itself: no corner gives a ratio within 10 % of 1 in every band
    for c in ("0.1", "0.3", "0.5", "1", "none"):
        assert any(abs(x - 1.0) > 0.1 for x in _by_band(ratios, c)), c
