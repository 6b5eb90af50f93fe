"""Issue 24: the verdict of every study type, the disagreement finder, the settings panel.

Unit tests on synthetic tables (no engine runs) and checks of the committed reports' HTML.
"""

from __future__ import annotations

import re
from pathlib import Path

import pandas as pd
import pytest

from pbr_xval.report.verdict import build_verdict
from pbr_xval.study.base import StudyResult
from pbr_xval.study.verdicts import TOL_MESH_SPREAD, agreement, azimuth_disagreements

ROOT = Path(__file__).resolve().parents[2]
REPORTS = ROOT / "reports"


def _azimuth_table(levels: dict[float, dict[str, float]], hw: float = 0.005) -> pd.DataFrame:
    rows = []
    for phi, by in levels.items():
        for e, v in by.items():
            rows.append(
                {
                    "engine": e,
                    "phi_deg": phi,
                    "status": "bracketed",
                    "pga_at_minimum_m_s2": v,
                    "pga_tolerance_m_s2": hw,
                    "bound_m_s2": 0.4 if phi in (0.0, 180.0) else 0.8,
                }
            )
    return pd.DataFrame(rows)


def test_agreement_finds_the_outlier_and_refuses_a_two_against_two_split() -> None:
    # three engines within 1 %, one 38 % below (SP1 at φ = 300°)
    ag, out = agreement(
        {"a": (1.595, 0.015), "b": (0.976, 0.006), "c": (1.569, 0.012), "d": (1.571, 0.01)}, 0.0036
    )
    assert sorted(ag) == ["a", "c", "d"] and out == ["b"]
    # two pairs far apart: no consensus, every engine named
    ag, out = agreement({"a": (1.0, 0.0), "b": (1.001, 0.0), "c": (2.0, 0.0), "d": (2.001, 0.0)}, 0.0036)
    assert ag == [] and sorted(out) == ["a", "b", "c", "d"]
    # the search brackets widen the tolerance: 1.5 % apart with ±1 % brackets agree
    assert agreement({"a": (1.0, 0.01), "b": (1.015, 0.01)}, TOL_MESH_SPREAD) == (["a", "b"], [])
    assert agreement({"a": (1.0, 0.001), "b": (1.015, 0.001)}, TOL_MESH_SPREAD)[0] == []


def test_azimuth_verdict_names_the_directions_and_engines_that_differ() -> None:
    df = _azimuth_table(
        {
            0.0: {"mujoco": 1.411, "pybullet": 1.263, "dart": 1.390},
            90.0: {"mujoco": 2.806, "pybullet": 2.810, "dart": 2.813},
            180.0: {"mujoco": 1.243, "pybullet": 1.240, "dart": 1.251},
            300.0: {"mujoco": 1.595, "pybullet": 0.976, "dart": 1.569},
        },
        hw=0.015,
    )
    dirs = {d.phi: d for d in azimuth_disagreements(df)}
    assert dirs[300.0].outliers == ["pybullet"] and dirs[0.0].outliers == ["pybullet"]
    assert dirs[90.0].outliers == [] and dirs[180.0].outliers == []
    assert dirs[300.0].spread == pytest.approx(1.595 / 0.976 - 1)
    r = StudyResult("azimuth", "Az", tables={"azimuth": df}, provenance={"scenario": "x", "config": {}})
    v = build_verdict([r])
    (sv,) = v.studies
    text = " ".join(sv.disagreements)
    assert "φ = 300°" in text and "φ = 0°" in text and "pybullet" in text
    assert "φ = 90°" not in text and "φ = 180°" not in text
    assert "Weakest direction φ = 180°" in sv.answer[0]
    assert "0.36" in sv.tolerance and "bracket" in sv.tolerance
    # the compact table marks the outliers
    pyb = next(row for row in sv.rows if row[0].text == "pybullet")
    assert [c.status for c in pyb[1:5]] == ["attention", "pass", "pass", "attention"]


def test_histories_extremes_tradeoff_verdicts_say_what_differs() -> None:
    m = pd.DataFrame(
        [
            {"engine": "housner", "status": "ok", "toppled": False, "toppled_at_s": float("nan"),
             "peak_theta_over_alpha": 0.3474, "impact1_t_s": 0.7983, "impact2_t_s": 1.2, "impact3_t_s": 1.5},
            {"engine": "mujoco", "status": "ok", "toppled": False, "toppled_at_s": float("nan"),
             "peak_theta_over_alpha": 0.3471, "impact1_t_s": 0.7976, "impact2_t_s": 1.2, "impact3_t_s": 1.5},
            {"engine": "pybullet", "status": "ok", "toppled": True, "toppled_at_s": 0.9,
             "peak_theta_over_alpha": 0.40, "impact1_t_s": 0.83, "impact2_t_s": float("nan"), "impact3_t_s": float("nan")},
        ]
    )  # fmt: skip
    h = StudyResult(
        "histories", "H", tables={"histories_metrics": m}, provenance={"reference_engine": "housner"}
    )
    ext = pd.DataFrame(
        [
            {"case": "mass_1e6kg", "engine": "mujoco", "class": "ok", "detail": "stands at −1%", "reference_m_s2": 5.638},
            {"case": "mass_1e6kg", "engine": "pybullet", "class": "biased", "detail": "stands at +1.00% of 5.638 (threshold too high)",
             "reference_m_s2": 5.638, "threshold_m_s2": 5.90, "threshold_rel_error": 5.90 / 5.638 - 1},
        ]
    )  # fmt: skip
    e = StudyResult("extremes", "E", tables={"extremes_matrix": ext})
    pts = pd.DataFrame(
        [
            {"engine": "mujoco", "setting": "timestep=0.001", "profile": "faithful", "status": "ok",
             "rel_error": 1e-4, "abs_rel_error": 1e-4, "wall_s_per_sim": 0.1, "note": ""},
            {"engine": "pybullet", "setting": "timestep=0.01", "profile": "faithful", "status": "ok",
             "rel_error": -0.006, "abs_rel_error": 0.006, "wall_s_per_sim": 0.05, "note": ""},
        ]
    )  # fmt: skip
    t = StudyResult("tradeoff", "T", tables={"tradeoff_points": pts}, provenance={"reference": 5.638})
    v = build_verdict([h, e, t])
    hv, ev, tv = v.studies
    assert [s.kind for s in v.studies] == ["histories", "extremes", "tradeoff"]
    (dh,) = hv.disagreements
    assert "pybullet" in dh and "toppled" in dh and "impact 1" in dh and "peak tilt +15" in dh
    (de,) = ev.disagreements
    assert "pybullet" in de and "mass_1e6kg" in de and "+4.65 %" in de and "right: mujoco" in de
    (dt,) = tv.disagreements
    assert "pybullet" in dt and "±0.2 %" in dt
    assert v.disagreements == [dh, de, dt]


def _first_screen_list(page: str) -> str:
    """The verdict section of a report page, up to its first table (the words before any table)."""
    m = re.search(r'<section id="verdict">(.*?)</section>', page, re.S)
    assert m, "no verdict section"
    sec = m.group(1)
    return re.sub(r"<[^>]+>", "", sec.split("<table", 1)[0])


def test_committed_sp1_report_names_the_directions_beyond_tolerance() -> None:
    """reports/azimuth_sp1: φ = 300° and every direction the finder flags, with the engines, before any table."""
    folder = REPORTS / "azimuth_sp1"
    page = (folder / "index.html").read_text()
    words = _first_screen_list(page).split("Disagreement beyond tolerance:", 1)[1]  # the list, in words
    df = pd.read_csv(next(folder.glob("s01_azimuth_azimuth.csv")))
    flagged = [d for d in azimuth_disagreements(df) if d.outliers]
    assert any(d.phi == 300.0 for d in flagged)
    for d in flagged:
        line = next((ln for ln in words.split("φ = ")[1:] if ln.startswith(f"{d.phi:g}°:")), None)
        assert line is not None, f"φ = {d.phi:g}° is beyond tolerance but not named before the tables"
        for e in d.outliers:
            assert e in line, (d.phi, e, line[:200])
    p300 = next(d for d in flagged if d.phi == 300.0)
    assert "pybullet" in p300.outliers and p300.spread > 0.3  # 0.976 vs 1.57–1.60 m/s²


def _panel_items(page: str) -> list[str]:
    m = re.search(r"<h3>Engines and settings</h3>\s*<ul>(.*?)</ul>", page, re.S)
    assert m, "no 'Engines and settings' panel"
    return [re.sub(r"<[^>]+>", "", li).strip() for li in re.findall(r"<li[^>]*>(.*?)</li>", m.group(1), re.S)]


@pytest.mark.parametrize("name", sorted(p.parent.name for p in REPORTS.glob("*/index.html")))
def test_committed_reports_have_a_settings_panel(name: str) -> None:
    """No committed report has an empty 'Engines and settings' panel; every engine has versions."""
    page = (REPORTS / name / "index.html").read_text()
    if "<h3>Engines and settings</h3>" not in page:  # validate/constrain pages: the verdict block's panel
        assert 'id="verdict"' in page, name
        return
    items = _panel_items(page)
    assert items, f"{name}: empty settings panel"
    for it in items:
        assert "settings not recorded" not in it and "versions not recorded" not in it, it


def test_settings_panel_check_catches_an_empty_panel() -> None:
    page = (REPORTS / "azimuth_sp1" / "index.html").read_text()
    doctored = re.sub(r"(<h3>Engines and settings</h3>\s*<ul>).*?(</ul>)", r"\1\2", page, count=1, flags=re.S)
    assert _panel_items(page) and not _panel_items(doctored)


def test_validation_verdict_shows_every_score_column_and_tests_the_f1_difference() -> None:
    import numpy as np

    from pbr_xval.study.verdicts import hazard_paragraph, validation_verdict

    rng = np.random.default_rng(0)
    n = 60
    obs = rng.random(n) < 0.5
    good = np.where(rng.random(n) < 0.95, obs, ~obs)
    bad = np.where(rng.random(n) < 0.55, obs, ~obs)
    out = pd.DataFrame({"test": [f"T{i}" for i in range(n)], "motion": [f"r{i % 6}" for i in range(n)],
                        "observed": obs.astype(int), "pred_a": good.astype(int), "pred_b": bad.astype(int),
                        "pred_c": good.astype(int)})  # fmt: skip
    scores = pd.DataFrame(
        {"model": ["a", "b", "c"], "f1": [0.95, 0.55, 0.95], "brier": [0.05, 0.3, float("nan")]}
    )
    sv = validation_verdict(scores, out, ["a", "b", "c"])
    assert sv.header == ["model", "f1", "brier"] and sv.rows[2][2].text == "—"
    ab = next(d for d in sv.disagreements if "**a** and **b**" in d)
    assert "beyond tolerance" in ab
    assert not any("**a** and **c**" in d for d in sv.disagreements)  # identical predictions
    text = hazard_paragraph(
        {"mean_im_before": 3.0, "mean_im_after": 2.0, "im05_before": 2.5, "im95_before": 3.2,
         "mean_im_change": -1 / 3, "prior_joint_survival": 0.1, "range_ratio": 0.5},
        "PGA", "m/s²", 1e-4, 25, 3, "independent",
    )  # fmt: skip
    assert "beyond that spread" in text and "−33.3 %" in text.replace("-", "−")
