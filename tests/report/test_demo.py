"""The main job: `pbr-xval demo --quick` writes a valid report with the Housner thresholds and curved-base maps."""

from __future__ import annotations

import re
from html.parser import HTMLParser
from pathlib import Path
from typing import Any, ClassVar

import pandas as pd


class _Checker(HTMLParser):
    VOID: ClassVar[set[str]] = {"img", "br", "meta", "link", "hr", "input", "col", "source", "wbr"}

    def __init__(self) -> None:
        super().__init__()
        self.stack: list[str] = []
        self.imgs: list[str] = []
        self.errors: list[str] = []

    def handle_starttag(self, tag, attrs):
        if tag == "img":
            self.imgs.append(dict(attrs).get("src", ""))
        if tag not in self.VOID:
            self.stack.append(tag)

    def handle_endtag(self, tag):
        if not self.stack or self.stack[-1] != tag:
            self.errors.append(f"unbalanced </{tag}> (open: {self.stack[-3:]})")
        else:
            self.stack.pop()


def test_quick_demo_report(quick_demo: tuple[Path, Any]) -> None:
    rep, res = quick_demo
    assert res.exit_code == 0, res.output
    html = (rep / "index.html").read_text()
    chk = _Checker()
    chk.feed(html)
    assert not chk.errors and not chk.stack
    assert chk.imgs and all(src.startswith("data:image/png;base64,") for src in chk.imgs)
    # the Housner threshold per engine against 5.638 (independent reference: the exact ODE value)
    thr = pd.read_csv(rep / "s01_thresholds_thresholds.csv")
    ok = thr[thr["status"] == "ok"].set_index("engine")
    assert {"housner", "reference", "mujoco", "pybullet", "dart"} <= set(ok.index)
    for engine, value in ok["minimum_m_s2"].items():
        assert abs(value / 5.638 - 1) < 3e-3, (engine, value)
    assert "5.638" in html
    # curved-base maps against the analytical ones
    agree = pd.read_csv(rep / "s03_fragility_fragility_agreement.csv")
    assert "curved_base" in set(agree["engine"])
    assert (agree.loc[agree["engine"] != "curved_base", "agreement"] >= 0.75).all()
    assert (rep / "summary.md").read_text().count("## ") >= 4
    # terminal: plain progress lines when not a terminal, a closing verdict table with the numbers
    out = res.output
    assert re.search(r"^\[\s*\d+ s\]\s+\d+ %", out, re.M), out[:2000]
    assert "Verdict" in out and "m/s²" in out
    for engine, value in ok["minimum_m_s2"].items():
        assert f"{value:.5g} m/s²" in out, (engine, value)
    assert "| headline |" not in (rep / "summary.md").read_text()
    # our LCP reference solver has its rows in the verdict (Housner block, synthetic rock)
    verdict = pd.read_csv(rep / "verdict.csv")
    ref = verdict[verdict["engine"] == "reference"]
    assert len(ref) == 2 and (ref["status"] == "pass").all(), ref
