"""The report's HTML template (jinja2, autoescaped; kept as a string so no package data is needed)."""

from __future__ import annotations

INDEX_HTML = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<meta name="generator" content="pbr-xval {{ prov.pbr_xval_version }}">
<title>{{ title }}</title>
<style>
* { box-sizing: border-box; }
body { font-family: system-ui, -apple-system, "Segoe UI", Roboto, sans-serif; max-width: 1320px;
       margin: 1.2em auto; padding: 0 1em; color: #1b1b1b; line-height: 1.4; overflow-wrap: anywhere; }
h1 { font-size: 1.6em; border-bottom: 2px solid #444; padding-bottom: .15em; margin: 0 0 .2em; }
h2 { font-size: 1.3em; border-bottom: 1px solid #bbb; margin: 1.6em 0 .4em; }
h3 { font-size: 1.05em; margin: 1em 0 .3em; }
table { border-collapse: collapse; margin: .4em 0 .8em; font-size: .86em; max-width: 100%; }
th, td { border: 1px solid #ccc; padding: .2em .5em; text-align: right; vertical-align: top; }
th { background: #f1f1f1; }
td.text, th.text { text-align: left; }
.run { display: grid; grid-template-columns: minmax(0, 3fr) minmax(0, 2fr); gap: 0 2em; font-size: .86em; }
.run > div { min-width: 0; }
.run h3 { margin: .3em 0 .1em; font-size: 1em; }
.run ul { margin: 0; padding-left: 1.1em; }
.run li.one { white-space: nowrap; overflow: hidden; text-overflow: ellipsis; }
table.verdict { font-size: .9em; width: 100%; table-layout: fixed; }
table.verdict th { text-align: left; font-weight: 600; }
table.verdict th small { display: block; font-weight: normal; color: #444; }
table.verdict th.eng { width: 9em; }
table.verdict td { text-align: left; line-height: 1.3; }
table.verdict .v { font-weight: 600; font-variant-numeric: tabular-nums; }
table.verdict .c { color: #555; font-size: .88em; }
td.pass { background: #eef8ee; } td.attention { background: #fff3dd; } td.failed { background: #fde8e8; }
td.reference { background: #f3f3f8; } td.none, td.skipped { background: #fafafa; color: #666; }
.mark { font-weight: bold; } td.pass .mark { color: #2e7d32; } td.attention .mark { color: #b26a00; }
td.failed .mark { color: #c62828; }
ul.findings { margin: .2em 0; padding-left: 1.2em; }
ul.findings li { margin: .1em 0; }
ul.headlines { margin: .2em 0; padding-left: 1.2em; font-size: .95em; }
p.news { margin: .3em 0 0; font-weight: 600; font-size: .92em; }
.study-verdict h3 { margin: .6em 0 .1em; }
.study-verdict p.ran { margin: .1em 0; }
table.sv { font-size: .82em; }
table.sv td { font-variant-numeric: tabular-nums; }
.figs { display: grid; grid-template-columns: repeat(2, minmax(0, 1fr)); gap: .6em 1em; }
figure { margin: .4em 0; }
figure.wide { grid-column: 1 / -1; }
figure img { max-width: 100%; height: auto; border: 1px solid #ddd; display: block; }
figcaption { font-size: .85em; color: #333; }
.failed-sec { border-left: 5px solid #c62828; padding-left: .8em; background: #fff4f4; }
.interrupted-sec { border-left: 5px solid #ef6c00; padding-left: .8em; background: #fff8ef; }
.status-failed { color: #c62828; font-weight: bold; }
.notes { font-size: .85em; color: #444; }
pre { background: #f6f6f6; padding: .6em; overflow-x: auto; font-size: .8em; white-space: pre-wrap; }
details { margin: .3em 0; }
summary { cursor: pointer; }
code { background: #f3f3f3; padding: 0 .2em; }
.small { font-size: .85em; color: #555; }
nav { font-size: .9em; }
.more { display: flex; flex-wrap: wrap; gap: 0 2em; font-size: .85em; }
.more details[open] { flex-basis: 100%; }
nav a { margin-right: 1em; }
</style>
</head>
<body>
<h1>{{ title }}</h1>
<p class="small">{% if description %}{{ description }} {% endif %}Generated {{ prov.date }} by pbr-xval {{ prov.pbr_xval_version }}{% if prov.wall_time_s %} in {{ "%.0f"|format(prov.wall_time_s) }} s{% endif %}{% if prov.quick %} (quick){% endif %}.
{% if n_failed %}<span class="status-failed">{{ n_failed }} section(s) failed or did not run.</span>{% endif %}</p>

<section id="run" class="run">
<div><h3>Scenarios</h3>
<ul>
{% for sc in run_scenarios %}<li>{% if sc.label %}<strong>{{ sc.label }}</strong>: {% endif %}{{ sc.summary or sc.name }}</li>
{% endfor %}</ul></div>
<div id="engines-panel"><h3>Engines and settings</h3>
<ul>
{% for e in engines %}<li class="one" title="{{ e.settings_full }}"><strong>{{ e.name }}</strong> {{ e.versions_short }} — {{ e.settings_short }}</li>
{% endfor %}{% if not engines %}<li class="none">No engine ran: nothing was simulated in this report.</li>
{% endif %}</ul></div>
</section>

<section id="verdict">
<h2>Verdict</h2>
{% if verdict.cases %}
<div class="case-verdict">
<ul class="headlines">
{% for h in verdict_headlines %}<li>{{ h }}</li>
{% endfor %}</ul>
{% if verdict_findings %}<p class="news">Disagreement beyond tolerance:</p>
<ul class="findings disagreements">
{% for f in verdict_findings %}<li>{{ f }}</li>
{% endfor %}</ul>{% else %}<p class="small disagreements"><strong>Disagreement beyond tolerance:</strong> none.</p>{% endif %}
<table class="verdict">
<thead><tr><th class="eng">engine</th>{% for c in verdict.cases %}<th data-case="{{ c.key }}"><a href="#{{ c.anchor }}">{{ c.title }}</a><small>vs {{ c.reference_text }}; tolerance {{ c.tolerance_text }}</small></th>{% endfor %}</tr></thead>
<tbody>
{% for e in verdict.engines %}<tr><th class="text eng">{{ e }}</th>{% for c in verdict.cases %}{% set cell = verdict.cells.get((e, c.key)) %}{% if cell %}<td class="{{ cell.status }}" data-engine="{{ e }}" data-case="{{ c.key }}" data-status="{{ cell.status }}"{% if cell.value is not none %} data-value="{{ cell.value }}"{% endif %}{% if cell.deviation is not none %} data-deviation="{{ cell.deviation }}"{% endif %}{% if cell.message %} title="{{ cell.message }}"{% endif %}><span class="v">{{ cell.value_text }}</span>{% if cell.deviation_text %} <span class="d">{{ cell.deviation_text }}</span>{% endif %} <span class="mark">{{ cell.mark }}</span>{% if cell.tolerance is not none %} <span class="c">(±{{ "%.2f"|format(100 * cell.tolerance) }} %)</span>{% endif %}<br><span class="c">{{ cell.cost_text }}</span></td>{% else %}<td class="none"></td>{% endif %}{% endfor %}</tr>
{% endfor %}</tbody>
</table>
</div>
{% elif verdict_findings %}<ul class="findings disagreements">
{% for f in verdict_findings %}<li>{{ f }}</li>
{% endfor %}</ul>
{% endif %}
{% for st in studies %}{% set sv = st.sv %}
<div class="study-verdict" data-kind="{{ sv.kind }}" id="verdict-{{ sv.anchor }}">
<h3><a href="#{{ sv.anchor }}">{{ sv.title }}</a></h3>
<p class="small ran">Ran: {{ sv.ran }}</p>
<ul class="headlines">
{% for a in st.answer %}<li>{{ a }}</li>
{% endfor %}</ul>
{% if st.disagreements %}<p class="news">Disagreement beyond tolerance:</p>
<ul class="findings disagreements">
{% for d in st.disagreements %}<li>{{ d }}</li>
{% endfor %}</ul>{% else %}<p class="small disagreements"><strong>Disagreement beyond tolerance:</strong> none between the engines.</p>{% endif %}
{% if sv.rows %}<table class="sv">
<thead><tr>{% for h in sv.header %}<th>{{ h }}</th>{% endfor %}</tr></thead>
<tbody>
{% for row in sv.rows %}<tr>{% for c in row %}{% if loop.first %}<th class="text"{% if c.title %} title="{{ c.title }}"{% endif %}>{{ c.text }}</th>{% else %}<td{% if c.status %} class="{{ c.status }}"{% endif %}{% if c.title %} title="{{ c.title }}"{% endif %}>{{ c.text }}</td>{% endif %}{% endfor %}</tr>
{% endfor %}</tbody>
</table>{% endif %}
<p class="small tolerance">Tolerance: {{ sv.tolerance }}</p>
</div>
{% endfor %}
{% if verdict.empty %}<p class="small">No study in this report compares engines: no verdict.</p>{% endif %}
{% if global_notes %}<ul class="notes">
{% for n in global_notes %}<li>{{ n }}</li>
{% endfor %}</ul>{% endif %}
<nav>Sections: {% for s in sections %}<a href="#{{ s.anchor }}">{{ s.title }}</a>{% if s.status != "ok" %} <span class="status-failed">({{ s.status }})</span>{% endif %} {% endfor %}<a href="#provenance">Provenance</a></nav>
</section>

{% for s in sections %}
<section id="{{ s.anchor }}"{% if s.status != "ok" %} class="{{ s.status }}-sec"{% endif %}>
<h2>{{ s.title }}</h2>
<p class="small">study <code>{{ s.kind }}</code>{% if s.scenario %} on scenario <code>{{ s.scenario }}</code>{% endif %}; wall time {{ s.wall }}</p>
{% if s.summary_html %}
<ul>
{% for line in s.summary_html %}<li>{{ line }}</li>
{% endfor %}
</ul>
{% endif %}
{% for t in s.summary_tables %}{{ t }}
{% endfor %}
{% if s.figures %}<div class="figs">
{% for f in s.figures %}
<figure id="{{ f.anchor }}"{% if f.wide %} class="wide"{% endif %}>
<img src="{{ f.data_uri }}" alt="{{ f.alt }}" width="{{ f.width }}" height="{{ f.height }}">
<figcaption>{{ f.caption }}{% if f.csv %} Data: <a href="{{ f.csv }}">{{ f.csv }}</a>{% endif %}</figcaption>
</figure>
{% endfor %}
</div>{% endif %}
{% if s.tables %}<p class="small">Data: {% for t in s.tables %}<a href="{{ t.csv }}">{{ t.name }}</a> ({{ t.rows }} rows{% if t.parquet %}, <a href="{{ t.parquet }}">Parquet</a>{% endif %}){% if not loop.last %} · {% endif %}{% endfor %}</p>{% endif %}
<div class="more">
{% if s.notes %}
<details class="notes"><summary>Notes ({{ s.notes|length }})</summary>
<ul>
{% for n in s.notes %}<li>{{ n }}</li>
{% endfor %}
</ul>
</details>
{% endif %}
{% if s.error %}
<details><summary>Error details</summary>
<pre>{{ s.error }}</pre>
</details>
{% endif %}
<details><summary>Study provenance</summary>
<pre>{{ s.provenance_json }}</pre>
</details>
</div>
</section>
{% endfor %}

<section id="provenance">
<h2>Provenance</h2>
<p class="small">pbr-xval {{ prov.pbr_xval_version }} · {{ prov.date }} · <code>{{ prov.command_line }}</code>{% if prov.study_file %} · study file <code>{{ prov.study_file }}</code>{% endif %}</p>
<details><summary>Scenarios (content hashes)</summary>
<table>
<thead><tr><th class="text">scenario</th><th class="text">SHA-256 (content + referenced files)</th><th class="text">file</th></tr></thead>
<tbody>
{% for sc in scenarios %}<tr><td class="text">{{ sc.name }}</td><td class="text"><code>{{ sc.hash }}</code></td><td class="text">{{ sc.file }}</td></tr>
{% endfor %}
</tbody>
</table>
{% if prov.study_file_sha256 %}<p class="small">study file SHA-256 <code>{{ prov.study_file_sha256 }}</code></p>{% endif %}
</details>
<details><summary>Engines (versions and complete settings)</summary>
{% for e in engines %}
<details><summary><strong>{{ e.name }}</strong> — {{ e.versions_short }}</summary>
<pre>{{ e.json }}</pre>
</details>
{% endfor %}
{% if not engines %}<p class="small">No engine versions were recorded.</p>{% endif %}
</details>
<details><summary>Machine</summary>
<table>
<tbody>
{% for k, v in machine %}<tr><th class="text">{{ k }}</th><td class="text">{{ v }}</td></tr>
{% endfor %}
</tbody>
</table>
</details>
{% if assets %}
<p class="small">Generated inputs: {% for a in assets %}<a href="{{ a }}">{{ a }}</a>{% if not loop.last %}, {% endif %}{% endfor %}</p>
{% endif %}
<details><summary>Full provenance (JSON)</summary>
<pre>{{ prov_json }}</pre>
</details>
<p class="small">Machine-readable files: <a href="provenance.json">provenance.json</a>, <a href="summary.md">summary.md</a>{% if verdict.cases %}, <a href="verdict.csv">verdict.csv</a>{% endif %}; every table as CSV and Parquet (<code>data/</code>, provenance in the schema metadata), linked in its section.</p>
</section>
</body>
</html>
"""
