"""Report writer and study files: valid self-contained HTML, CSV/Parquet data, atomic folders,
study-file validation, failed sections."""

from __future__ import annotations

import io
import json
import shutil
import subprocess
import sys
import textwrap
import types
from html.parser import HTMLParser
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pandas as pd
import pytest
from pydantic import BaseModel, ConfigDict

from pbr_xval.report import write_report
from pbr_xval.study import study_file as spec_mod
from pbr_xval.study.base import Figure, StudyResult

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"

VOID = {"area", "base", "br", "col", "embed", "hr", "img", "input", "link", "meta", "source", "track", "wbr"}


class Checker(HTMLParser):
    """Balanced tags, images as data URIs, links collected."""

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.stack: list[str] = []
        self.errors: list[str] = []
        self.imgs: list[dict[str, str | None]] = []
        self.links: list[str] = []
        self.ids: list[str] = []
        self.text: list[str] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = dict(attrs)
        if "id" in a:
            self.ids.append(str(a["id"]))
        if tag == "img":
            self.imgs.append(a)
        if tag == "a" and a.get("href"):
            self.links.append(str(a["href"]))
        if tag not in VOID:
            self.stack.append(tag)

    def handle_startendtag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self.handle_starttag(tag, attrs)
        if tag not in VOID:
            self.stack.pop()

    def handle_endtag(self, tag: str) -> None:
        if tag in VOID:
            return
        if not self.stack or self.stack[-1] != tag:
            self.errors.append(f"unbalanced </{tag}> (open: {self.stack[-3:]}) at {self.getpos()}")
            if tag in self.stack:
                while self.stack and self.stack.pop() != tag:
                    pass
        else:
            self.stack.pop()

    def handle_data(self, data: str) -> None:
        self.text.append(data)


def check_html(folder: Path) -> Checker:
    text = (folder / "index.html").read_text()
    assert text.startswith("<!DOCTYPE html>")
    c = Checker()
    c.feed(text)
    c.close()
    assert not c.errors, c.errors
    assert c.stack == [], f"unclosed tags {c.stack}"
    assert len(c.ids) == len(set(c.ids)), "duplicate ids"
    for img in c.imgs:
        assert str(img.get("src", "")).startswith("data:image/png;base64,"), img.get("src", "")[:40]
        assert img.get("alt")
    for href in c.links:
        if href.startswith("#"):
            assert href[1:] in c.ids, href
        else:
            assert "://" not in href
            assert (folder / href).is_file(), f"link to missing file {href}"
    return c


def fake_result(kind: str = "thresholds", title: str = "Fake thresholds", n: int = 5) -> StudyResult:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    df = pd.DataFrame(
        {
            "engine": ["housner", "mujoco", "pybullet", "dart", "reference"][:n],
            "threshold_m_s2": np.linspace(5.63, 5.64, n),
            "wall_s": np.arange(n, dtype=float),
            "status": ["ok"] * n,
        }
    )
    long = pd.DataFrame({"t": np.linspace(0, 1, 500), "theta_rad": np.sin(np.linspace(0, 6, 500))})
    fig, ax = plt.subplots(figsize=(4, 3))
    ax.bar(df["engine"], df["threshold_m_s2"])
    fig2, ax2 = plt.subplots(figsize=(4, 3))
    ax2.plot(long["t"], long["theta_rad"])
    return StudyResult(
        kind=kind,
        title=title,
        tables={"thresholds": df, "theta <long>": long},
        figures=[
            Figure(
                "thresholds",
                fig,
                "thresholds",
                "Minimum toppling amplitude per engine; **5.638** is Housner's.",
            ),
            Figure("theta", fig2, "theta <long>", "θ(t) & friends <script>alert(1)</script>"),
        ],
        summary=[
            "all engines within **0.2 %** of `5.638` m/s²",
            "a <b>raw</b> tag is escaped",
            "| engine | value |\n|---|---|\n| housner | 5.638 |",
        ],
        headline={"threshold_m_s2": {"housner": 5.638, "mujoco": 5.6387}, "max_rel_err": 1.2e-3},
        provenance={
            "scenario_hash": "ab" * 32,
            "scenario_name": "housner_halfsine",
            "engines": {
                "mujoco": {"versions": {"mujoco": "3.2"}, "settings": {"timestep": 1e-3}},
                "housner": {"versions": {"pbr_xval": "0.1"}, "settings": {"variant": "exact"}},
            },
        },
        notes=["engine 'curved_base' skipped: NotApplicable"],
        wall_time=1.5,
    )


def test_write_report_is_valid_and_self_contained(tmp_path: Path) -> None:
    import pyarrow.parquet as pq

    results = [fake_result(), spec_mod.failed_result("histories", "Broken study", RuntimeError("boom <x>"))]
    out = write_report(
        results, tmp_path / "reports" / "demo", provenance={"command_line": "pbr-xval report x.toml"}
    )
    assert out == tmp_path / "reports" / "demo"
    c = check_html(out)
    assert len(c.imgs) == 2
    text = " ".join(c.text)
    assert "Broken study" in text and "boom <x>" in text  # escaped, shown as text
    html = (out / "index.html").read_text()
    assert "<script>" not in html and "&lt;script&gt;" in html
    assert "<strong>0.2 %</strong>" in html and "<code>5.638</code>" in html
    assert "<details>" in html and "ab" * 32 in html
    # the figure's data sits beside it, linked under the plot
    figcsv = [h for h in c.links if h.endswith(".csv")]
    assert any("thresholds" in h for h in figcsv)
    df = pd.read_csv(out / next(h for h in figcsv if "theta" in h))
    assert list(df.columns) == ["t", "theta_rad"] and len(df) == 500
    # Parquet, one file per table, provenance in the metadata
    pqs = sorted((out / "data").glob("*.parquet"))
    assert len(pqs) == 2
    t = pq.read_table(pqs[0])
    meta = json.loads(t.schema.metadata[b"pbr_xval"])
    assert meta["report"]["command_line"] == "pbr-xval report x.toml"
    assert meta["study"]["kind"] == "thresholds"
    assert "machine" in meta["report"] and meta["report"]["pbr_xval_version"]
    # raw tables are not inlined: each is linked (CSV and Parquet) with its row count
    assert "theta &lt;long&gt;</a> (500 rows" in html and "0.841471" not in html
    md = (out / "summary.md").read_text()
    assert "\n| housner | 5.638 |" in md and "<td>housner</td>" in html
    assert "# demo" in md and "**FAILED**" in md and "0.2 %" in md
    # no second "headline" table repeating the numbers with dotted keys
    assert "| headline |" not in md and "threshold_m_s2.mujoco" not in html
    prov = json.loads((out / "provenance.json").read_text())
    assert prov["engines"]["mujoco"]["versions"]["mujoco"] == "3.2"
    assert not list(out.parent.glob("*.tmp-*")) and not list(out.parent.glob("*.old-*"))


def test_report_folder_replaced_only_when_complete(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from pbr_xval.report import writer

    out = write_report([fake_result(n=2)], tmp_path / "r", provenance={})
    before = (out / "index.html").read_text()
    (out / "marker.txt").write_text("previous report")

    def boom(*a: Any, **k: Any) -> str:
        raise OSError("disk full")

    monkeypatch.setattr(writer, "summary_markdown", boom)
    with pytest.raises(OSError, match="disk full"):
        write_report([fake_result(n=4)], tmp_path / "r", provenance={})
    assert (out / "index.html").read_text() == before
    assert (out / "marker.txt").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r"]
    monkeypatch.undo()
    write_report([fake_result(n=4)], tmp_path / "r", provenance={})
    assert not (out / "marker.txt").exists()  # replaced as a whole


@pytest.mark.skipif(not Path("/usr/bin/chromium").exists(), reason="chromium not installed")
def test_report_renders_in_headless_chromium(tmp_path: Path) -> None:
    out = write_report([fake_result()], tmp_path / "r", provenance={})
    png = tmp_path / "shot.png"
    cmd = [
        "/usr/bin/chromium",
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--no-first-run",
        f"--user-data-dir={tmp_path / 'prof'}",
        f"--screenshot={png}",
        "--window-size=1200,2000",
        (out / "index.html").resolve().as_uri(),
    ]
    subprocess.run(cmd, check=True, timeout=60, capture_output=True)
    assert png.is_file() and png.stat().st_size > 10_000


# ------------------------------------------------------------------ study files
class FakeConfig(BaseModel):
    model_config = ConfigDict(extra="forbid")
    type: Literal["fake"] = "fake"
    n: int = 3
    fail: bool = False


def _fake_run(config: FakeConfig, scenario: Any, engines: list[str], *, progress: Any = None) -> StudyResult:
    if config.fail:
        raise RuntimeError("this study always fails")
    for i in range(config.n):
        if progress:
            progress(f"step {i}", (i + 1) / config.n)
    r = fake_result(kind="fake", title=f"Fake on {scenario.name}", n=min(config.n, 5))
    r.provenance["engines_given"] = list(engines)
    del r.provenance["scenario_hash"], r.provenance["scenario_name"]
    return r


@pytest.fixture
def fake_study(monkeypatch: pytest.MonkeyPatch) -> None:
    mod = types.ModuleType("pbr_xval_fake_study")
    mod.FakeConfig = FakeConfig  # type: ignore[attr-defined]
    mod.run = _fake_run  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "pbr_xval_fake_study", mod)
    monkeypatch.setitem(spec_mod.STUDY_MODULES, "fake", "pbr_xval_fake_study")


def _write(tmp_path: Path, body: str) -> Path:
    shutil.copy(EXAMPLES / "housner_halfsine.toml", tmp_path / "housner.toml")
    p = tmp_path / "study.toml"
    p.write_text(textwrap.dedent(body))
    return p


def test_study_file_runs_and_failed_section_does_not_stop_the_others(
    tmp_path: Path, fake_study: None
) -> None:
    p = _write(
        tmp_path,
        """
        name = "fake"
        title = "A fake study"
        scenario = "housner.toml"
        engines = ["housner", "curved_base"]

        [[study]]
        type = "fake"
        n = 2
        quick = { n = 1 }

        [[study]]
        type = "fake"
        fail = true

        [[study]]
        type = "fake"
        title = "Third"
        """,
    )
    spec = spec_mod.load_study_spec(p)
    assert [s.config.n for s in spec.studies] == [2, 3, 3]
    assert spec_mod.load_study_spec(p, quick=True).studies[0].config.n == 1
    seen: list[tuple[str, float]] = []
    results = spec_mod.run_study(spec, lambda m, f: seen.append((m, f)))
    assert len(results) == 3
    assert [spec_mod.is_failed(r) for r in results] == [False, True, False]
    assert "this study always fails" in results[1].summary[0]
    # curved_base cannot model a box: skipped before the study, with a note
    assert results[0].provenance["engines_given"] == ["housner"]
    assert any("curved_base" in n for n in results[0].notes)
    assert results[0].provenance["scenario_hash"] == spec.scenarios[0].scenario.content_hash()
    fr = [f for _, f in seen]
    assert fr == sorted(fr) and fr[-1] == pytest.approx(1.0)
    out = write_report(results, tmp_path / "reports" / spec.name, provenance={"title": spec.title})
    check_html(out)
    assert "Third" in (out / "summary.md").read_text()


def test_study_file_with_scenarios_and_synthetic_rock(tmp_path: Path, fake_study: None) -> None:
    p = _write(
        tmp_path,
        """
        name = "multi"
        title = "Two scenarios"
        engines = ["housner"]

        [[scenarios]]
        label = "box"
        path = "housner.toml"

        [[scenarios]]
        label = "synthetic"
        base = "housner.toml"
        synthetic = { seed = 3, subdivisions = 2, density = 2500.0 }

        [[study]]
        type = "fake"
        scenario = "synthetic"

        [[study]]
        type = "fake"
        """,
    )
    spec = spec_mod.load_study_spec(p)
    results = spec_mod.run_study(spec, False, work_dir=tmp_path / "work")
    assert len(results) == 3
    assert sorted(spec.assets) == ["synthetic.obj", "synthetic.toml"]
    assert results[0].provenance["scenario_label"] == "synthetic"
    assert "synthetic" in results[0].title
    h1 = results[0].provenance["scenario_hash"]
    # deterministic: a second materialisation gives the same content hash
    spec2 = spec_mod.load_study_spec(p)
    spec2.materialise(tmp_path / "work2")
    assert spec2.scenario("synthetic").content_hash() == h1
    out = write_report(results, tmp_path / "rep", provenance={}, assets=spec.assets)
    check_html(out)
    assert (out / "synthetic.obj").is_file() and (out / "synthetic.toml").is_file()


@pytest.mark.parametrize(
    ("body", "match"),
    [
        ('name = "x"\nscenario = "housner.toml"\n', r"study.toml: key 'study'"),
        (
            'name = "x"\nscenario = "nope.toml"\n[[study]]\ntype = "fake"\n',
            r"(?s)key 'scenario'.*cannot read",
        ),
        (
            'name = "x"\nscenario = "housner.toml"\n[[study]]\ntype = "nope"\n',
            r"key 'study\[0\].type': expected one of",
        ),
        ('name = "x"\nscenario = "housner.toml"\n[[study]]\ntype = "fake"\nn = "a"\n', r"key 'study\[0\].n'"),
        (
            'name = "x"\nscenario = "housner.toml"\n[[study]]\ntype = "fake"\nbogus = 1\n',
            r"key 'study\[0\].bogus': unknown key",
        ),
        (
            'name = "x"\nscenario = "housner.toml"\nengines = ["warp"]\n[[study]]\ntype = "fake"\n',
            r"key 'engines': unknown engine 'warp'",
        ),
        (
            'name = "x"\nscenario = "housner.toml"\ncolour = 1\n[[study]]\ntype = "fake"\n',
            r"key 'colour': unknown key",
        ),
        ('name = "x y"\nscenario = "housner.toml"\n[[study]]\ntype = "fake"\n', r"key 'name'"),
        (
            'name = "x"\nscenario = "housner.toml"\n[[study]]\ntype = "fake"\nscenario = "other"\n',
            r"unknown scenario label 'other'",
        ),
        (
            'name = "x"\nscenario = "housner.toml"\n[[study]]\ntype = "fake"\nquick = { n = "z" }\n',
            r"key 'study\[0\].n'",
        ),
        ("name = \n", r"not valid TOML"),
    ],
)
def test_study_file_errors_name_file_and_key(tmp_path: Path, fake_study: None, body: str, match: str) -> None:
    p = _write(tmp_path, body)
    with pytest.raises(spec_mod.StudyFileError, match=match) as ei:
        spec_mod.load_study_spec(p)
    assert str(p) in str(ei.value)


def test_report_command_end_to_end(tmp_path: Path, fake_study: None) -> None:
    from rich.console import Console

    from pbr_xval.cli.report_impl import report_command

    p = _write(
        tmp_path,
        """
        name = "e2e"
        scenario = "housner.toml"
        engines = ["housner"]
        [[study]]
        type = "fake"
        [[study]]
        type = "fake"
        fail = true
        """,
    )
    con = Console(file=io.StringIO(), width=120)
    code = report_command(p, tmp_path / "reports", console=con)
    assert code == 1  # a failed section is reported in the exit code
    out = tmp_path / "reports" / "e2e"
    check_html(out)
    prov = json.loads((out / "provenance.json").read_text())
    assert prov["study_file"].endswith("study.toml") and len(prov["study_file_sha256"]) == 64
    assert report_command(tmp_path / "missing.toml", tmp_path / "reports", console=con) == 2


@pytest.mark.parametrize("name", ["housner.toml", "curved_base.toml", "demo.toml", "synthetic_rock.toml"])
def test_example_study_files_validate(name: str) -> None:
    # a study module that cannot be imported is a broken install: it fails here, never skips
    spec_mod.load_study_spec(EXAMPLES / "studies" / name, quick=True)


def test_native_banners_kept_off_the_console(tmp_path: Path) -> None:
    """A banner written natively to fd 2 (as pybullet's import does) is dropped; other lines pass."""
    code = textwrap.dedent(
        """
        import os, sys
        from rich.console import Console
        from pbr_xval.cli.report_impl import quiet_native_stdout
        con = Console()
        with quiet_native_stdout(con):
            os.write(2, b"pybullet build time: Jan 29 2025 23:17:20\\n")
            os.write(1, b"native line\\n")
            print("python line", file=sys.stderr)
            con.print("console line")
        con.print("after")
        """
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert "build time" not in r.stdout + r.stderr
    assert "native line" in r.stdout and "console line" in r.stdout and "after" in r.stdout
    assert "python line" in r.stderr


def test_plain_progress_lines_are_periodic() -> None:
    from rich.console import Console

    from pbr_xval.cli.report_impl import log_progress

    now = [0.0]
    con = Console(file=io.StringIO(), width=200)
    cb = log_progress(con, interval=10.0, clock=lambda: now[0])
    for k in range(100):  # 100 updates over 50 s in one section: a line every 10 s
        now[0] = k * 0.5
        cb(f"section A: sim {k}", k / 200)
    now[0] = 51.0
    cb("section B: start", 0.5)  # a new section always gets a line
    lines = con.file.getvalue().splitlines()
    assert len(lines) == 5 + 1, lines  # t = 0, 10, 20, 30, 40 s, then section B
    assert lines[-1].endswith("section B: start") and " 50 %" in lines[-1]


def _thresholds_result(
    minima: dict[str, float], reference: float | None, ref_engine: str | None
) -> StudyResult:
    rows = [
        {
            "engine": e,
            "status": "ok",
            "message": "",
            "param": "excitation.amplitude",
            "minimum_m_s2": v,
            "tolerance_m_s2": 1e-4 * v,
            "n_bands": 1,
            "n_simulations": 12,
            "wall_s": 2.0,
            "rel_error_vs_reference": (v / reference - 1) if reference else float("nan"),
        }
        for e, v in minima.items()
    ]
    return StudyResult(
        kind="thresholds",
        title="t",
        tables={"thresholds": pd.DataFrame(rows)},
        provenance={
            "scenario_label": "box",
            "reference_engine": ref_engine,
            "config": {"param": "excitation.amplitude", "reference": reference},
        },
    )


def test_verdict_marks_and_names_disagreements() -> None:
    from pbr_xval.report.verdict import TOL_NUMERICAL, build_verdict

    # mujoco 0.1 % off (within ±0.2 %), pybullet 1 % off (beyond), against Housner's 5.638
    r = _thresholds_result(
        {"housner": 5.638, "mujoco": 5.638 * 1.001, "pybullet": 5.638 * 0.99}, 5.638, "housner"
    )
    v = build_verdict([r])
    (case,) = v.cases
    assert case.unit == "m/s²" and "5.638 m/s²" in case.reference_text
    assert v.cell("mujoco", case.key).status == "pass"
    assert v.cell("mujoco", case.key).tolerance == pytest.approx(TOL_NUMERICAL + 1.001e-4)  # + its bracket
    assert v.cell("pybullet", case.key).status == "attention"
    assert v.cell("pybullet", case.key).deviation == pytest.approx(-0.01)
    (finding,) = v.findings
    assert "pybullet" in finding and "-1.00 %" in finding
    # no analytical reference: deviation from the engines' median, ±1 %
    m = build_verdict([_thresholds_result({"mujoco": 2.48, "pybullet": 2.53, "dart": 2.63}, None, None)])
    (c2,) = m.cases
    assert "median" in c2.reference_text and m.cell("pybullet", c2.key).deviation == pytest.approx(0.0)
    assert m.cell("dart", c2.key).status == "attention" and m.cell("mujoco", c2.key).status == "attention"
    assert "spread 6.0%" in m.headlines[0]
    # the writer puts the verdict first, with the numbers in data attributes and in verdict.csv
    md = "\n".join(v.markdown())
    assert "| box: pulse amplitude threshold | pybullet | 5.5816 m/s² | -1.00 % |" in md
