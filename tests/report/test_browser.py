"""The quick demo report as a reader sees it: rendered by headless Chromium at 1400 px.

Checks (issue 14): no horizontal overflow at 1400 px, every image decoded (naturalWidth > 0),
the verdict table on the first screen (1400 × 900) with every engine's Housner threshold, its
unit and its deviation, the thresholds within tolerance of the exact nonlinear 5.638 m/s²
(independent reference: the Housner ODE, seed paper 5.62–5.64), and the page under 6,000 px.
A screenshot of the first screen is kept in the test's tmp folder (path printed).

Chromium is the Debian package ``chromium``; `.ci/run` installs it. In CI (``CI`` set) a
missing browser fails the test; elsewhere it is skipped with the reason.
"""

from __future__ import annotations

import html
import json
import os
import re
import shutil
import subprocess
from pathlib import Path
from typing import Any

import pandas as pd
import pytest

HOUSNER = 5.638  # m/s², exact nonlinear threshold (conformance.HOUSNER_THRESHOLD)
#: engines vs 5.638: measured worst on the quick demo −0.11 % (PyBullet, dt = 1 ms, bisection
#: rel. tol 1e-3 ⇒ bracket ±0.1 %); tolerance 3e-3 as in test_demo, margin ≈ 2.7×
REL_TOL = 3e-3
WIDTH, HEIGHT = 1400, 900
MAX_PAGE_HEIGHT = 6000  # px at 1400 px wide (issue 14 budget; was 16,600)

PROBE = """<script>
window.addEventListener('load', function () {
  var d = document.documentElement;
  var wide = [];
  document.querySelectorAll('body *').forEach(function (e) {
    var r = e.getBoundingClientRect();
    if (r.right > d.clientWidth + 1 && wide.length < 10)
      wide.push(e.tagName + '.' + e.className + ': ' + (e.textContent || '').trim().slice(0, 60));
  });
  var imgs = Array.from(document.images).map(function (i) {
    return {alt: i.alt.slice(0, 60), w: i.naturalWidth, h: i.naturalHeight, complete: i.complete};
  });
  var vt = document.querySelector('table.verdict');
  var cases = Array.from(document.querySelectorAll('table.verdict thead th[data-case]')).map(function (th) {
    return {key: th.dataset.case, text: th.textContent};
  });
  var cells = Array.from(document.querySelectorAll('table.verdict td[data-engine]')).map(function (td) {
    var r = td.getBoundingClientRect();
    return {engine: td.dataset.engine, case: td.dataset.case, status: td.dataset.status,
            value: td.dataset.value === undefined ? null : parseFloat(td.dataset.value),
            text: td.textContent, bottom: r.bottom};
  });
  var out = {scrollWidth: d.scrollWidth, clientWidth: d.clientWidth, scrollHeight: d.scrollHeight,
             wide: wide, imgs: imgs, cases: cases, cells: cells,
             verdictBottom: vt ? vt.getBoundingClientRect().bottom : null};
  var p = document.createElement('pre');
  p.id = 'pbr-probe';
  p.textContent = JSON.stringify(out);
  document.body.appendChild(p);
});
</script>"""


def chromium() -> str:
    """Path of the Chromium binary; fail in CI, skip elsewhere when it is missing."""
    path = shutil.which("chromium") or ("/usr/bin/chromium" if Path("/usr/bin/chromium").exists() else None)
    if path:
        return path
    if os.environ.get("CI"):
        pytest.fail("chromium is not installed: CI must install it (.ci/run: apt-get install chromium)")
    pytest.skip("chromium not installed (Debian: apt-get install chromium); CI runs this test")
    raise AssertionError  # unreachable


def _base(profile: Path) -> list[str]:
    return [
        chromium(),
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--hide-scrollbars",
        f"--user-data-dir={profile}",
        f"--window-size={WIDTH},{HEIGHT}",
    ]


def measure(folder: Path, work: Path, *, screenshot: Path | None = None) -> dict[str, Any]:
    """Render ``folder/index.html`` with the probe script; the probe's JSON (see PROBE)."""
    probe = folder / "_browser_probe.html"  # beside index.html, so relative links resolve
    probe.write_text((folder / "index.html").read_text().replace("</body>", PROBE + "</body>"))
    try:
        r = subprocess.run(
            [*_base(work / "profile"), "--virtual-time-budget=10000", "--dump-dom", probe.resolve().as_uri()],
            capture_output=True,
            text=True,
            timeout=180,
        )
        if screenshot is not None:
            subprocess.run(
                [
                    *_base(work / "profile"),
                    f"--screenshot={screenshot}",
                    (folder / "index.html").resolve().as_uri(),
                ],
                capture_output=True,
                timeout=180,
            )
    finally:
        probe.unlink(missing_ok=True)
    m = re.search(r'<pre id="pbr-probe">(.*?)</pre>', r.stdout, re.S)
    assert m, f"the probe did not run in chromium (exit {r.returncode}): {r.stderr[-1500:]}"
    return json.loads(html.unescape(m.group(1)))


def problems(m: dict[str, Any]) -> list[str]:
    """What a reader would see wrong on the page (empty: nothing)."""
    out = []
    if m["scrollWidth"] > m["clientWidth"]:
        out.append(
            f"horizontal overflow: page {m['scrollWidth']} px wide at {m['clientWidth']} px: {m['wide']}"
        )
    bad = [i["alt"] for i in m["imgs"] if not (i["complete"] and i["w"] > 0)]
    if bad or not m["imgs"]:
        out.append(f"images not loaded: {bad or 'no images'}")
    if m["scrollHeight"] >= MAX_PAGE_HEIGHT:
        out.append(f"page {m['scrollHeight']} px tall (budget {MAX_PAGE_HEIGHT} px)")
    if m["verdictBottom"] is None:
        out.append("no verdict table")
    elif m["verdictBottom"] > HEIGHT:
        out.append(f"verdict table ends at {m['verdictBottom']:.0f} px, below the first screen ({HEIGHT} px)")
    return out


def housner_cells(m: dict[str, Any]) -> list[dict[str, Any]]:
    key = next((c["key"] for c in m["cases"] if "5.638 m/s²" in c["text"]), None)
    assert key is not None, f"no verdict column against 5.638 m/s²: {[c['text'] for c in m['cases']]}"
    return [c for c in m["cells"] if c["case"] == key]


def test_quick_demo_in_chromium(quick_demo: tuple[Path, Any], tmp_path: Path) -> None:
    folder, res = quick_demo
    assert res.exit_code in (0, 1), res.output  # 1: a section failed; the page must still read well
    shot = tmp_path / "demo_first_screen.png"
    m = measure(folder, tmp_path, screenshot=shot)
    print(f"\nscreenshot of the first screen: {shot}")
    print(f"page {m['scrollWidth']} × {m['scrollHeight']} px, {len(m['imgs'])} images")
    assert not problems(m), problems(m)
    assert shot.is_file() and shot.stat().st_size > 20_000
    # every engine's Housner threshold, with unit and deviation, on the first screen
    cells = housner_cells(m)
    engines = {c["engine"] for c in cells if c["value"] is not None}
    assert {"housner", "mujoco", "pybullet", "dart"} <= engines, engines
    for c in cells:
        if c["value"] is None:
            continue
        assert abs(c["value"] / HOUSNER - 1) < REL_TOL, (c["engine"], c["value"])
        assert "m/s²" in c["text"] and "%" in c["text"], c["text"]
        assert c["bottom"] <= HEIGHT, f"{c['engine']} below the first screen"
    # the rendered numbers are the measured ones (the study's CSV)
    thr = pd.read_csv(next(folder.glob("s01_thresholds_thresholds.csv")))
    measured = dict(zip(thr["engine"], thr["minimum_m_s2"], strict=True))
    for c in cells:
        if c["value"] is not None:
            assert c["value"] == pytest.approx(measured[c["engine"]], rel=1e-9)


def test_probe_catches_a_broken_page(quick_demo: tuple[Path, Any], tmp_path: Path) -> None:
    """The checks fail on overflow, a missing image and a wrong headline number."""
    folder, _ = quick_demo
    bad = tmp_path / "bad"
    shutil.copytree(folder, bad)
    page = (bad / "index.html").read_text()
    value = re.search(
        r'data-engine="mujoco" data-case="(c\d+)" data-status="\w+" data-value="([0-9.e+-]+)"', page
    )
    assert value
    page = page.replace(f'data-value="{value.group(2)}"', 'data-value="5.9"', 1)
    page = page.replace(
        "</h1>",
        '</h1><div style="width:2600px">wide</div><img alt="broken" src="data:image/png;base64,AAAA">',
        1,
    )
    (bad / "index.html").write_text(page)
    m = measure(bad, tmp_path)
    found = " | ".join(problems(m))
    assert "horizontal overflow" in found and "broken" in found, found
    wrong = [
        c for c in housner_cells(m) if c["value"] is not None and abs(c["value"] / HOUSNER - 1) >= REL_TOL
    ]
    assert [c["engine"] for c in wrong] == ["mujoco"]
