"""Write a list of :class:`~pbr_xval.study.base.StudyResult` as a report folder, atomically.

``write_report(results, Path("reports/housner"), provenance={...})`` produces::

    reports/housner/
        index.html          self-contained: plots inlined as PNG data URIs, tables as HTML,
                            a provenance section (scenario hashes, engine versions/settings,
                            machine, pbr-xval version, date, command line)
        summary.md          the verdict and summary lines (CI logs, pull requests)
        verdict.csv         the verdict, one row per engine × case
        provenance.json     the same provenance, machine-readable
        <figure>.csv        the data of every figure, linked under the plot
        <table>.csv         every table
        data/<table>.parquet  every table, provenance in the Parquet schema metadata
        <asset files>       generated inputs (e.g. a synthetic rock mesh and its scenario)

Every file is written atomically (temporary file in the same folder, then ``os.replace``) into
``<name>.tmp-<pid>/``; only when all are written does that folder replace the previous report
(which is kept if anything fails).
"""

from __future__ import annotations

import base64
import contextlib
import datetime as _dt
import io
import json
import math
import os
import re
import shutil
import sys
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pbr_xval.atomic import (
    clean_stale_temporaries,
    write_bytes_atomic,
    write_parquet_atomic,
    write_text_atomic,
)
from pbr_xval.jsonio import jsonable as _jsonable
from pbr_xval.study.base import StudyResult
from pbr_xval.study.verdicts import md_inline, settings_short

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["atomic_write_bytes", "atomic_write_text", "base_provenance", "write_report"]

#: figures wider than this (px) take the full width of the page; narrower ones sit two per row
WIDE_PX = 760
#: summary tables longer than this are folded (their data are linked as CSV and Parquet)
LONG_TABLE_ROWS = 12


# ------------------------------------------------------------------ atomic i/o
#: old names of :func:`pbr_xval.atomic.write_bytes_atomic` and :func:`~pbr_xval.atomic.write_text_atomic`
#: (kept so existing imports work; new code uses the :mod:`pbr_xval.atomic` names)
atomic_write_bytes = write_bytes_atomic
atomic_write_text = write_text_atomic


def _slug(s: str) -> str:
    s = re.sub(r"[^A-Za-z0-9_.-]+", "_", s.strip()).strip("_.")
    return s or "x"


def _dumps(v: Any) -> str:
    return json.dumps(_jsonable(v), indent=2, sort_keys=True, default=str, ensure_ascii=False)


def _fmt(v: Any) -> str:
    """A number for humans: 6 significant digits; everything else as text."""
    try:
        import numpy as np

        if isinstance(v, np.generic):
            v = v.item()
    except ImportError:  # pragma: no cover
        pass
    if isinstance(v, bool) or v is None:
        return "" if v is None else str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "—"
        if math.isinf(v):
            return "∞" if v > 0 else "−∞"
        if v == 0:
            return "0"
        if 1e-4 <= abs(v) < 1e7:
            return f"{v:.6g}"
        return f"{v:.4e}"
    if isinstance(v, dict | list | tuple):
        return json.dumps(_jsonable(v), default=str)
    return str(v)


def _summary_blocks(summary: Iterable[str]) -> tuple[list[Any], list[Any]]:
    """Summary lines as HTML list items; Markdown tables among them as HTML tables."""
    from markupsafe import Markup

    items: list[Any] = []
    tables: list[Any] = []
    rows: list[list[str]] = []

    def flush() -> None:
        if not rows:
            return
        body = [r for r in rows if not all(re.fullmatch(r":?-{2,}:?", c.strip()) for c in r if c.strip())]
        long = len(body) - 1 > LONG_TABLE_ROWS
        out = (
            [f"<details><summary>Table of {len(body) - 1} rows (the data links below)</summary>"]
            if long
            else []
        )
        out.append('<table class="data">')
        if body:
            out.append("<thead><tr>" + "".join(f"<th>{md_inline(c)}</th>" for c in body[0]) + "</tr></thead>")
        out.append("<tbody>")
        for r in body[1:]:
            out.append("<tr>" + "".join(f"<td>{md_inline(c)}</td>" for c in r) + "</tr>")
        out.append("</tbody></table>")
        if long:
            out.append("</details>")
        tables.append(Markup("".join(out)))
        rows.clear()

    for s in summary:
        for ln in str(s).split("\n"):
            t = ln.strip()
            if t.startswith("|"):
                rows.append([c.strip() for c in t.strip("|").split("|")])
                continue
            flush()
            if t:
                items.append(md_inline(t))
    flush()
    return items, tables


def _png_data_uri(fig: Any, dpi: int = 100) -> tuple[str, int, int]:
    import matplotlib

    matplotlib.use("Agg")
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, bbox_inches="tight")
    data = buf.getvalue()
    # PNG IHDR: width and height are big-endian uint32 at bytes 16..24
    w = int.from_bytes(data[16:20], "big")
    h = int.from_bytes(data[20:24], "big")
    with contextlib.suppress(Exception):
        import matplotlib.pyplot as plt

        plt.close(fig)
    return "data:image/png;base64," + base64.b64encode(data).decode("ascii"), w, h


def _csv_bytes(df: pd.DataFrame) -> bytes:
    return df.to_csv(index=False, lineterminator="\n").encode("utf-8")


def _arrow_table(df: pd.DataFrame, meta: Mapping[str, Any]) -> Any:
    import pyarrow as pa

    try:
        table = pa.Table.from_pandas(df, preserve_index=False)
    except (pa.ArrowInvalid, pa.ArrowTypeError, TypeError, ValueError):
        d2 = df.copy()
        for c in d2.columns:
            if d2[c].dtype == object:
                d2[c] = d2[c].map(
                    lambda x: x if x is None or isinstance(x, str) else json.dumps(_jsonable(x), default=str)
                )
        d2.columns = [str(c) for c in d2.columns]
        table = pa.Table.from_pandas(d2, preserve_index=False)
    md = dict(table.schema.metadata or {})
    md[b"pbr_xval"] = json.dumps(_jsonable(meta), sort_keys=True, default=str).encode()
    return table.replace_schema_metadata(md)


def base_provenance(extra: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """pbr-xval version, date (UTC), command line and machine, updated by ``extra``."""
    from pbr_xval.machine import machine_info
    from pbr_xval.version import __version__

    prov: dict[str, Any] = {
        "pbr_xval_version": __version__,
        "date": _dt.datetime.now(_dt.UTC).replace(microsecond=0).isoformat(),
        "command_line": " ".join([Path(sys.argv[0]).name if sys.argv else "python", *sys.argv[1:]]),
        "machine": dict(machine_info()),
    }
    prov.update(dict(extra or {}))
    return prov


def _status(r: StudyResult) -> str:
    s = r.provenance.get("status") if isinstance(r.provenance, Mapping) else None
    if s in ("failed", "interrupted"):
        return str(s)
    if isinstance(r.headline, Mapping) and r.headline.get("status") in ("failed", "interrupted"):
        return str(r.headline["status"])
    return "ok"


def _scenarios(results: Iterable[StudyResult], prov: Mapping[str, Any]) -> list[dict[str, str]]:
    seen: dict[str, dict[str, str]] = {}

    def add(name: Any, h: Any, file: Any = "", label: Any = "", summary: Any = "") -> None:
        if not h or not isinstance(h, str):
            return
        if h not in seen:
            seen[h] = {
                "name": str(name or "?"),
                "hash": h,
                "file": str(file or ""),
                "label": str(label or ""),
                "summary": str(summary or ""),
            }
        elif file and not seen[h]["file"]:
            seen[h]["file"] = str(file)

    for s in prov.get("scenarios", []) or []:
        if isinstance(s, Mapping):
            add(s.get("name"), s.get("hash"), s.get("file", ""), s.get("label", ""), s.get("summary", ""))
    for r in results:
        p = r.provenance if isinstance(r.provenance, Mapping) else {}
        sc = p.get("scenario")
        name = sc if isinstance(sc, str) else p.get("scenario_name")
        add(name, p.get("scenario_hash"), p.get("scenario_file", ""))
        add(p.get("scenario_name"), p.get("base_scenario_hash"), p.get("scenario_file", ""))
        if isinstance(sc, Mapping):
            add(sc.get("name"), sc.get("hash") or sc.get("scenario_hash"), sc.get("file", ""))
        for key in ("scenario_hashes", "scenarios"):
            v = p.get(key)
            if isinstance(v, Mapping):
                for n, h in v.items():
                    add(n, h if isinstance(h, str) else (h.get("hash") if isinstance(h, Mapping) else None))
    return list(seen.values())


def _engines(results: Iterable[StudyResult]) -> dict[str, dict[str, Any]]:
    """Engine name -> {versions, settings (by study)} gathered from the results' provenance."""
    out: dict[str, dict[str, Any]] = {}

    def slot(name: str) -> dict[str, Any]:
        return out.setdefault(str(name), {"versions": {}, "settings": {}})

    for r in results:
        p = r.provenance if isinstance(r.provenance, Mapping) else {}
        eng = p.get("engines")
        if isinstance(eng, Mapping):
            for n, info in eng.items():
                if isinstance(info, Mapping):
                    s = slot(n)
                    if isinstance(info.get("versions"), Mapping):
                        s["versions"].update(info["versions"])
                    st = info.get("settings")
                    if isinstance(st, Mapping) and st and all(isinstance(x, Mapping) for x in st.values()):
                        # settings by case or by settings point (extremes, speed–accuracy trade)
                        for k, x in st.items():
                            s["settings"][f"{r.title}: {k}"] = x
                    elif "settings" in info:
                        s["settings"][r.title] = st
                    for k, v in info.items():
                        if k not in ("versions", "settings"):
                            s.setdefault("other", {})[k] = v
        for key in ("versions", "engine_versions"):
            v = p.get(key)
            if isinstance(v, Mapping):
                for n, ver in v.items():
                    if isinstance(ver, Mapping):
                        slot(n)["versions"].update(ver)
        for key in ("settings", "engine_settings"):
            v = p.get(key)
            if isinstance(v, Mapping):
                for n, st in v.items():
                    if isinstance(st, Mapping):
                        slot(n)["settings"][r.title] = st
        _engines_from_tables(r, slot)
    return out


def _engines_from_tables(r: StudyResult, slot: Any) -> None:
    """Versions and settings from a table's ``engine``/``settings``/``versions`` columns (JSON text)
    for engines the study's provenance does not describe."""
    for df in (r.tables or {}).values():
        cols = set(getattr(df, "columns", []))
        if "engine" not in cols or not ({"settings", "versions"} & cols):
            continue
        for _, row in df.iterrows():
            name = str(row["engine"])
            s = slot(name)
            for key in ("versions", "settings"):
                raw = row.get(key)
                try:
                    val = json.loads(raw) if isinstance(raw, str) else raw
                except ValueError:
                    continue
                if not isinstance(val, Mapping) or not val:
                    continue
                if key == "versions":
                    for k, v in val.items():
                        s["versions"].setdefault(k, v)
                elif r.title not in s["settings"]:
                    s["settings"][r.title] = dict(val)


def _engines_fallback(engines: dict[str, dict[str, Any]], prov: Mapping[str, Any]) -> None:
    """Engines the run used that no study described: their registry versions and profile defaults."""
    used = prov.get("engines_used")
    if not isinstance(used, list | tuple):
        return
    for name in used:
        if str(name) in engines:
            continue
        info: dict[str, Any] = {"versions": {}, "settings": {}}
        try:
            from pbr_xval.engine import get_engine

            eng = get_engine(str(name))
            info["versions"] = dict(eng.versions())
            info["settings"]["faithful profile (defaults; no study recorded its settings)"] = dict(
                eng.default_settings()
            )
        except Exception as exc:  # not installed: say so rather than leave the panel empty
            info["note"] = f"not available: {exc}"
        engines[str(name)] = info


def _settings_short(by_study: Mapping[str, Any]) -> str:
    return settings_short(by_study)


def _unique(name: str, used: set[str]) -> str:
    base, i = name, 2
    while name in used:
        name = f"{base}_{i}"
        i += 1
    used.add(name)
    return name


# ------------------------------------------------------------------ writer
def _write_section(
    i: int, r: StudyResult, tmp: Path, prov: dict[str, Any], used: set[str], parquet_files: list[str]
) -> dict[str, Any]:
    """Write one study's tables (CSV, Parquet) into ``tmp``; its section of the page, figures inlined.

    ``used`` (file stems already taken) and ``parquet_files`` are updated in place.
    """
    prefix = f"s{i:02d}_{_slug(r.kind)}"
    status = _status(r)
    rprov = r.provenance if isinstance(r.provenance, Mapping) else {}
    sec: dict[str, Any] = {
        "anchor": prefix,
        "title": r.title,
        "kind": r.kind,
        "status": status,
        "scenario": rprov.get("scenario_label") or rprov.get("scenario_name") or "",
        "wall": f"{r.wall_time:.1f} s" if r.wall_time >= 1 else f"{r.wall_time * 1000:.0f} ms",
        "summary_html": [],
        "summary_tables": [],
        "notes": [md_inline(n) for n in r.notes],
        "error": rprov.get("traceback") or rprov.get("error") or "",
        "provenance_json": _dumps({k: v for k, v in rprov.items() if k != "traceback"}),
        "figures": [],
        "tables": [],
    }
    items, mtables = _summary_blocks(r.summary)
    sec["summary_html"], sec["summary_tables"] = items, mtables
    table_files: dict[str, dict[str, str]] = {}
    for tname, df in (r.tables or {}).items():
        stem = _unique(f"{prefix}_{_slug(tname)}", used)
        csv = f"{stem}.csv"
        write_bytes_atomic(tmp / csv, _csv_bytes(df))
        pq_name = f"data/{stem}.parquet"
        meta = {
            "report": prov,
            "study": {"kind": r.kind, "title": r.title, "table": tname, "headline": r.headline},
            "study_provenance": {k: v for k, v in rprov.items() if k != "traceback"},
        }
        try:
            write_parquet_atomic(tmp / pq_name, _arrow_table(df, meta))
            parquet_files.append(pq_name)
        except Exception as exc:  # a table pyarrow cannot store must not sink the report
            sec["notes"].append(md_inline(f"table {tname!r} could not be written as Parquet: {exc}"))
            pq_name = ""
        table_files[tname] = {"csv": csv, "parquet": pq_name}
        sec["tables"].append(
            {
                "name": tname,
                "rows": len(df),
                "csv": csv,
                "parquet": pq_name,
            }
        )
    for fig in r.figures or []:
        same = _slug(fig.name) == _slug(fig.table) and fig.table in table_files
        stem = f"{prefix}_{_slug(fig.name)}" if same else _unique(f"{prefix}_{_slug(fig.name)}", used)
        try:
            uri, w, h = _png_data_uri(fig.figure)
        except Exception as exc:
            sec["notes"].append(md_inline(f"figure {fig.name!r} could not be rendered: {exc}"))
            continue
        df = (r.tables or {}).get(fig.table)
        if same:
            csv = table_files[fig.table]["csv"]
        elif df is not None:
            csv = f"{stem}.csv"
            write_bytes_atomic(tmp / csv, _csv_bytes(df))
        else:
            # no data table: link the caption to nothing rather than to a missing file
            csv = ""
            sec["notes"].append(md_inline(f"figure {fig.name!r}: its data table {fig.table!r} is missing"))
        sec["figures"].append(
            {
                "anchor": stem,
                "data_uri": uri,
                "width": w,
                "height": h,
                "wide": w > WIDE_PX,
                "alt": fig.caption or fig.name,
                "caption": md_inline(fig.caption),
                "csv": csv,
            }
        )
    return sec


def write_report(
    results: list[StudyResult],
    out_dir: Path,
    *,
    provenance: dict[str, Any],
    title: str | None = None,
    description: str = "",
    assets: Mapping[str, Path] | None = None,
    notes: Iterable[str] = (),
) -> Path:
    """Write the report folder ``out_dir`` (e.g. ``reports/<name>``) and return it.

    Parameters
    ----------
    results : the studies' results (failed sections included; see ``spec.failed_result``).
    out_dir : the report folder; replaced as a whole once every file is written.
    provenance : run-level provenance (``command_line``, ``study_file``, ...); filled in with
        the pbr-xval version, the date and the machine where missing.
    title, description : page title (default: ``provenance['title']`` or the folder name).
    assets : extra files copied into the folder (generated inputs), name -> source path.
    notes : run-level notes (e.g. engines that were skipped).
    """
    from jinja2 import Environment

    from pbr_xval.report.template import INDEX_HTML

    out_dir = Path(out_dir)
    prov = base_provenance()
    prov.update(provenance or {})
    title = title or prov.get("title") or out_dir.name
    prov.setdefault("title", title)

    parent = out_dir.parent
    parent.mkdir(parents=True, exist_ok=True)
    clean_stale_temporaries(parent)  # staging folders of killed report writers
    tmp = parent / f"{out_dir.name}.tmp-{os.getpid()}"
    if tmp.exists():
        shutil.rmtree(tmp)
    tmp.mkdir()
    try:
        from pbr_xval.report.verdict import build_verdict

        used: set[str] = {"index", "summary", "provenance", "verdict"}
        sections: list[dict[str, Any]] = []
        parquet_files: list[str] = []
        anchors = [f"s{i:02d}_{_slug(r.kind)}" for i, r in enumerate(results, start=1)]
        verdict = build_verdict(results, anchors)
        for i, r in enumerate(results, start=1):
            sections.append(_write_section(i, r, tmp, prov, used, parquet_files))

        # generated inputs
        asset_names: list[str] = []
        for name, src in (assets or {}).items():
            safe = _unique(_slug(name), used)
            write_bytes_atomic(tmp / safe, Path(src).read_bytes())
            asset_names.append(safe)

        scen = _scenarios(results, prov)
        engines = _engines(results)
        _engines_fallback(engines, prov)
        prov["scenarios"] = scen
        prov["engines"] = engines
        prov_json = _dumps(prov)
        write_text_atomic(tmp / "provenance.json", prov_json + "\n")

        env = Environment(autoescape=True, trim_blocks=False, lstrip_blocks=False, keep_trailing_newline=True)
        tpl = env.from_string(INDEX_HTML)
        engine_rows = [
            {
                "name": n,
                "versions_short": ", ".join(
                    f"{k} {v}" for k, v in sorted(info["versions"].items()) if k != "numpy"
                )
                or "versions not recorded",
                "settings_short": _settings_short(info.get("settings", {})),
                "settings_full": _dumps(info.get("settings", {}))[:4000],
                "json": _dumps(info),
            }
            for n, info in sorted(engines.items())
        ]
        if verdict.cases:
            import pandas as pd

            write_bytes_atomic(tmp / "verdict.csv", _csv_bytes(pd.DataFrame(verdict.rows())))
        studies = [
            {
                "sv": sv,
                "answer": [md_inline(a) for a in sv.answer],
                "disagreements": [md_inline(d) for d in sv.disagreements],
            }
            for sv in verdict.studies
        ]
        html_text = tpl.render(
            title=title,
            description=description or prov.get("description", ""),
            prov=prov,
            prov_json=prov_json,
            sections=sections,
            n_failed=sum(s["status"] != "ok" for s in sections),
            global_notes=[md_inline(n) for n in notes],
            verdict=verdict,
            verdict_headlines=[md_inline(h) for h in verdict.headlines],
            verdict_findings=[md_inline(f) for f in verdict.findings],
            studies=studies,
            scenarios=scen,
            run_scenarios=[sc for sc in scen if sc.get("label")] or scen,
            engines=engine_rows,
            machine=sorted((prov.get("machine") or {}).items()),
            assets=asset_names,
            parquet_files=parquet_files,
        )
        write_text_atomic(tmp / "index.html", html_text)
        write_text_atomic(
            tmp / "summary.md", summary_markdown(results, prov, title=title, notes=notes, verdict=verdict)
        )

        _swap_in(tmp, out_dir)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return out_dir


def _swap_in(tmp: Path, final: Path) -> None:
    """Replace ``final`` by ``tmp`` (two renames; the previous folder is restored on failure)."""
    old = final.parent / f"{final.name}.old-{os.getpid()}"
    if old.exists():
        shutil.rmtree(old)
    had = final.exists()
    if had:
        os.rename(final, old)
    try:
        os.rename(tmp, final)
    except BaseException:
        if had and not final.exists():
            os.rename(old, final)
        raise
    if had:
        shutil.rmtree(old, ignore_errors=True)


def summary_markdown(
    results: list[StudyResult],
    prov: Mapping[str, Any],
    *,
    title: str,
    notes: Iterable[str] = (),
    verdict: Any = None,
) -> str:
    """The report as Markdown: the verdict, a status table, then each study's summary lines."""
    if verdict is None:
        from pbr_xval.report.verdict import build_verdict

        verdict = build_verdict(results)
    m = prov.get("machine") or {}
    lines = [
        f"# {title}",
        "",
        f"pbr-xval {prov.get('pbr_xval_version', '?')} · {prov.get('date', '')} · "
        f"{m.get('platform', '')} ({m.get('cpu_count', '?')} CPUs) · Python {m.get('python', '')}",
        "",
    ]
    if prov.get("command_line"):
        lines += [f"Command: `{prov['command_line']}`", ""]
    if not verdict.empty:
        lines += ["## Verdict", "", *verdict.markdown(), ""]
    n_bad = sum(_status(r) != "ok" for r in results)
    lines += [
        f"**{len(results) - n_bad} of {len(results)} sections OK**"
        + (f", **{n_bad} failed or not run**" if n_bad else ""),
        "",
        "| section | study | status | wall time |",
        "|---|---|---|---|",
    ]
    for r in results:
        st = _status(r)
        mark = "ok" if st == "ok" else f"**{st.upper()}**"
        lines.append(f"| {r.title} | {r.kind} | {mark} | {r.wall_time:.1f} s |")
    lines.append("")
    for n in notes:
        lines.append(f"- {n}")
    if notes:
        lines.append("")
    for r in results:
        lines += [f"## {r.title}", ""]
        prev_table = False
        for s in r.summary:
            for ln in str(s).split("\n"):
                is_table = ln.lstrip().startswith("|")
                if is_table and not prev_table and lines and lines[-1] != "":
                    lines.append("")
                if not ln.strip():
                    if not prev_table:
                        continue
                    lines.append("")
                elif is_table or ln.lstrip().startswith("#"):
                    lines.append(ln)
                else:
                    if prev_table:
                        lines.append("")
                    lines.append(f"- {ln}")
                prev_table = is_table
        if r.notes:
            lines += ["", "Notes:"]
            lines += [f"- {n}" for n in r.notes]
        lines.append("")
    return "\n".join(lines)
