"""Issue 24: every study type's report shows its verdict on the first screen, in headless Chromium.

Small studies (the housner engine and MuJoCo, a few simulations each) of every type — azimuth,
histories, extremes, speed–accuracy trade — plus a validate page (synthetic scores) and a
constrain page (the synthetic example), rendered at 1400 px wide. Checks, for each page:

* the verdict's answer ends within the first 1,000 px;
* the disagreements are listed in words before any table of the verdict;
* the "Engines and settings" panel lists every engine with its versions and settings (the
  constrain page runs no engine: it has none);
* no horizontal overflow.

Doctored copies of the pages prove that each check fails when its condition is broken. The
committed SP1 azimuth report's first screen must name φ = 300° and the engines that differ.
"""

from __future__ import annotations

import html
import json
import re
import subprocess
import textwrap
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest


def _demo_browser() -> Any:
    """tests/report/test_browser.py (the demo's browser test: its Chromium command line)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(
        "_demo_browser", Path(__file__).with_name("test_browser.py")
    )
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


_BROWSER = _demo_browser()
_base, chromium = _BROWSER._base, _BROWSER.chromium

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
FIRST_SCREEN = 1000  # px

pytestmark = pytest.mark.slow

PROBE = """<script>
window.addEventListener('load', function () {
  var d = document.documentElement;
  function top(e) { return e ? e.getBoundingClientRect().top + window.scrollY : null; }
  function bottom(e) { return e ? e.getBoundingClientRect().bottom + window.scrollY : null; }
  var v = document.querySelector('#verdict');
  var answers = document.querySelectorAll('#verdict ul.headlines li, p#verdict');
  var dis = document.querySelector('#verdict .disagreements, p#verdict');
  var table = document.querySelector('#verdict table');
  var panel = Array.from(document.querySelectorAll('#engines-panel li')).map(function (li) {
    return li.textContent.trim();
  });
  var words = [];
  document.querySelectorAll('#verdict li, p#verdict').forEach(function (e) {
    if (bottom(e) <= SCREEN) words.push(e.textContent);
  });
  var out = {scrollWidth: d.scrollWidth, clientWidth: d.clientWidth,
             verdictTop: top(v), answerBottom: answers.length ? bottom(answers[answers.length - 1]) : null,
             disagreementsTop: top(dis), tableTop: top(table), hasPanel: !!document.querySelector('#engines-panel'),
             panel: panel, firstScreen: words.join(' | ')};
  var p = document.createElement('pre');
  p.id = 'pbr-probe';
  p.textContent = JSON.stringify(out);
  document.body.appendChild(p);
});
</script>""".replace("SCREEN", str(FIRST_SCREEN))


def measure(page: Path, work: Path) -> dict[str, Any]:
    """Render ``page`` (an index.html) with the probe; the probe's JSON."""
    probe = page.parent / "_verdict_probe.html"
    probe.write_text(page.read_text().replace("</body>", PROBE + "</body>"))
    try:
        r = subprocess.run(
            [*_base(work / "profile"), "--virtual-time-budget=10000", "--dump-dom", probe.resolve().as_uri()],
            capture_output=True,
            text=True,
            timeout=180,
        )
    finally:
        probe.unlink(missing_ok=True)
    m = re.search(r'<pre id="pbr-probe">(.*?)</pre>', r.stdout, re.S)
    assert m, f"the probe did not run in chromium (exit {r.returncode}): {r.stderr[-1500:]}"
    return json.loads(html.unescape(m.group(1)))


def problems(m: dict[str, Any], *, engines: bool = True) -> list[str]:
    out = []
    if m["scrollWidth"] > m["clientWidth"]:
        out.append(f"horizontal overflow: {m['scrollWidth']} px at {m['clientWidth']} px")
    if m["verdictTop"] is None or m["answerBottom"] is None:
        out.append("no verdict")
    elif m["answerBottom"] > FIRST_SCREEN:
        out.append(f"verdict ends at {m['answerBottom']:.0f} px, below the first {FIRST_SCREEN} px")
    if m["disagreementsTop"] is None:
        out.append("no disagreement list")
    elif m["tableTop"] is not None and m["tableTop"] < m["disagreementsTop"]:
        out.append("a table comes before the disagreements")
    if engines:
        if not m["hasPanel"] or not m["panel"]:
            out.append("empty settings panel")
        for li in m["panel"]:
            if "not recorded" in li or " — " not in li:
                out.append(f"engine without versions or settings: {li[:80]}")
    return out


# ------------------------------------------------------------------ the small reports
STUDIES = {
    "azimuth": """
        [[study]]
        type = "azimuth"
        azimuths_deg = [0.0, 90.0]
        n_grid = 3
        rel_tol = 0.05
        max_simulations = 8
    """,
    "histories": """
        [[study]]
        type = "histories"
        values = { "excitation.amplitude" = 5.0 }
        toppling_run = false
    """,
    "extremes": """
        [[study]]
        type = "extremes"
        cases = ["mass_1e6kg"]
        timeout = 300.0
    """,
    "tradeoff": """
        [[study]]
        type = "tradeoff"
        engines = ["mujoco"]
        reference = 5.638
        timesteps = [1e-2, 2e-3]
        profiles = ["faithful"]
        iterations = {}
        lo = 5.2
        hi = 6.2
        n_grid = 3
        rel_tol = 2e-3
    """,
}


@pytest.fixture(scope="module")
def reports(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """index.html of every small report, by study type (plus validate and constrain)."""
    import io

    from rich.console import Console

    from pbr_xval.cli.report_impl import report_command

    base = tmp_path_factory.mktemp("verdict_reports")
    scen = (EXAMPLES / "housner_halfsine.toml").resolve()
    out: dict[str, Path] = {}
    for kind, body in STUDIES.items():
        study = base / f"{kind}.toml"
        study.write_text(
            f'name = "{kind}"\nscenario = "{scen}"\nengines = ["housner", "mujoco"]\n' + textwrap.dedent(body)
        )
        code = report_command(study, base / "reports", console=Console(file=io.StringIO(), width=120))
        assert code == 0, kind
        out[kind] = base / "reports" / kind / "index.html"
    out["validate"] = _validate_page(base / "validate")
    out["constrain"] = _constrain_page(base / "constrain")
    return out


def _validate_page(folder: Path) -> Path:
    from pbr_xval.validation.campaign_report import ValidationResult, write_report
    from pbr_xval.validation.metrics import score

    rng = np.random.default_rng(3)
    n = 30
    obs = rng.random(n) < 0.5
    out = pd.DataFrame(
        {
            "test": [f"T{i:02d}" for i in range(n)],
            "motion": [f"rec{i % 5}" for i in range(n)],
            "observed": obs.astype(int),
            "pga_m_s2": 0.5 + 5 * rng.random(n),
            "pgv_over_pga_s": 0.05 + 0.2 * rng.random(n),
        }
    )
    preds = {
        "mujoco": np.where(rng.random(n) < 0.9, obs, ~obs),
        "dart": np.where(rng.random(n) < 0.6, obs, ~obs),
        "PGA rule": np.where(rng.random(n) < 0.7, obs, ~obs),
    }
    rows = []
    for m, p in preds.items():
        out[f"pred_{m}"] = p.astype(int)
        prob = np.clip(np.where(p, 0.8, 0.2) + 0.1 * rng.standard_normal(n), 0.01, 0.99)
        out[f"p_{m}"] = prob
        kind = "empirical" if "rule" in m else "physics"
        probabilistic = {  # the columns scores.csv carries (whatever they are, the verdict shows them)
            "brier": float(np.mean((prob - obs) ** 2)),
            "log_loss": float(-np.mean(np.where(obs, np.log(prob), np.log(1 - prob)))),
            "auc": 0.8,
        }
        rows.append(
            {
                "model": m,
                "kind": kind,
                "evaluated_on": "all tests",
                **score(obs, p).to_dict(),
                **probabilistic,
            }
        )
    res = ValidationResult(
        outcomes=out, scores=pd.DataFrame(rows), engines=["mujoco", "dart"], baseline_source="record", folds=4
    )
    meta = {
        "scenario": str(EXAMPLES / "housner_halfsine.toml"),
        "engines": "mujoco, dart",
        "engine_settings": {},
    }
    return write_report(res, folder, meta)["html"]


def _constrain_page(folder: Path) -> Path:
    from typer.testing import CliRunner

    from pbr_xval.cli import app

    res = CliRunner().invoke(app, ["constrain", "--example", "--out", str(folder)])
    assert res.exit_code == 0, res.output
    return folder / "index.html"


KINDS = [*STUDIES, "validate", "constrain"]


@pytest.mark.parametrize("kind", KINDS)
def test_every_study_type_shows_its_verdict_on_the_first_screen(
    reports: dict[str, Path], kind: str, tmp_path: Path
) -> None:
    chromium()
    m = measure(reports[kind], tmp_path)
    assert not problems(m, engines=kind != "constrain"), problems(m, engines=kind != "constrain")
    assert "Verdict" in reports[kind].read_text()
    if kind in STUDIES:  # the verdict names every engine the study ran
        engines = ["mujoco"] if kind == "tradeoff" else ["housner", "mujoco"]
        page = reports[kind].read_text()
        sec = page[
            page.index('<section id="verdict">') : page.index("</section>", page.index('id="verdict"'))
        ]
        for e in engines:
            assert e in sec, (kind, e)
        assert {li.split(" ")[0] for li in m["panel"]} >= set(engines), m["panel"]


def _push_down(page: str) -> str:
    anchor = '<section id="verdict"' if '<section id="verdict"' in page else '<p id="verdict"'
    return page.replace(anchor, '<div style="height:1200px">spacer</div>' + anchor, 1)


def _empty_panel(page: str) -> str:
    return re.sub(r'(<div id="engines-panel"[^>]*>.*?<ul>).*?(</ul>)', r"\1\2", page, count=1, flags=re.S)


def _table_first(page: str) -> str:
    i = page.index("<table", page.index('id="verdict"'))
    j = page.index("</table>", i) + len("</table>")
    table = page[i:j]
    page = page[:i] + page[j:]
    k = page.index("<ul", page.index('id="verdict"'))
    return page[:k] + table + page[k:]


def _wide(page: str) -> str:
    return page.replace("</h1>", '</h1><div style="width:2600px">wide</div>', 1)


DOCTORS: dict[str, tuple[Callable[[str], str], str]] = {
    "pushed_down": (_push_down, "below the first"),
    "empty_panel": (_empty_panel, "empty settings panel"),
    "table_first": (_table_first, "a table comes before the disagreements"),
    "overflow": (_wide, "horizontal overflow"),
}


@pytest.mark.parametrize(
    ("kind", "doctor"),
    [(k, d) for k in ("azimuth", "validate") for d in DOCTORS] + [("constrain", "pushed_down")],
)
def test_each_check_fails_on_a_doctored_page(
    reports: dict[str, Path], kind: str, doctor: str, tmp_path: Path
) -> None:
    chromium()
    fn, expect = DOCTORS[doctor]
    bad = tmp_path / "index.html"
    bad.write_text(fn(reports[kind].read_text()))
    found = " | ".join(problems(measure(bad, tmp_path), engines=kind != "constrain"))
    assert expect in found, (doctor, found)


def test_sp1_azimuth_first_screen_names_the_directions_that_differ(tmp_path: Path) -> None:
    """The committed reports/azimuth_sp1: φ = 300° and the engines that differ within 1,000 px."""
    from pbr_xval.study.verdicts import azimuth_disagreements

    chromium()
    folder = ROOT / "reports" / "azimuth_sp1"
    m = measure(folder / "index.html", tmp_path)
    assert not problems(m), problems(m)
    df = pd.read_csv(folder / "s01_azimuth_azimuth.csv")
    flagged = [d for d in azimuth_disagreements(df) if d.outliers]
    assert any(d.phi == 300.0 for d in flagged)
    for d in flagged:
        assert named(m, d.phi), f"φ = {d.phi:g}° is beyond tolerance but not named on the first screen"
    line = next(x for x in m["firstScreen"].split(" | ") if x.strip().startswith("φ = 300°:"))
    for e in ("pybullet", "mujoco", "dart"):
        assert e in line, line
    # doctored: without the φ = 300° line the check fails
    page = (folder / "index.html").read_text()
    doctored = re.sub(r"<li><strong>φ = 300°</strong>:(?:(?!</li>).)*</li>", "", page, count=1, flags=re.S)
    assert doctored != page
    copy = tmp_path / "sp1"
    copy.mkdir()
    (copy / "index.html").write_text(doctored)
    assert not named(measure(copy / "index.html", tmp_path), 300.0)


def named(m: dict[str, Any], phi: float) -> bool:
    """A first-screen line that starts with the direction: a disagreement named in words."""
    return any(x.strip().startswith(f"φ = {phi:g}°:") for x in m["firstScreen"].split(" | "))
