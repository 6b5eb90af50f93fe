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
body { font-family: system-ui, -apple-system, "Segoe UI", Roboto, sans-serif; max-width: 1100px;
       margin: 2em auto; padding: 0 1em; color: #1b1b1b; line-height: 1.45; }
h1 { border-bottom: 2px solid #444; padding-bottom: .2em; }
h2 { border-bottom: 1px solid #bbb; margin-top: 2.2em; }
nav ol { columns: 2; }
table { border-collapse: collapse; margin: .6em 0 1.2em; font-size: .88em; }
th, td { border: 1px solid #ccc; padding: .25em .55em; text-align: right; }
th { background: #f1f1f1; }
td.text, th.text { text-align: left; }
figure { margin: 1.2em 0; }
figure img { max-width: 100%; height: auto; border: 1px solid #ddd; }
figcaption { font-size: .9em; color: #333; }
.failed { border-left: 5px solid #c62828; padding-left: .8em; background: #fff4f4; }
.interrupted { border-left: 5px solid #ef6c00; padding-left: .8em; background: #fff8ef; }
.status-failed { color: #c62828; font-weight: bold; }
.notes { font-size: .9em; color: #444; }
.headline td:first-child { text-align: left; }
pre { background: #f6f6f6; padding: .6em; overflow-x: auto; font-size: .82em; }
details { margin: .4em 0; }
summary { cursor: pointer; }
code { background: #f3f3f3; padding: 0 .2em; }
.small { font-size: .85em; color: #555; }
</style>
</head>
<body>
<h1>{{ title }}</h1>
{% if description %}<p>{{ description }}</p>{% endif %}
<p class="small">Generated {{ prov.date }} by pbr-xval {{ prov.pbr_xval_version }}{% if prov.command_line %} — <code>{{ prov.command_line }}</code>{% endif %}.
{% if n_failed %}<span class="status-failed">{{ n_failed }} section(s) failed or did not run.</span>{% endif %}</p>
{% if global_notes %}
<ul class="notes">
{% for n in global_notes %}<li>{{ n }}</li>
{% endfor %}
</ul>
{% endif %}
<nav>
<h2 id="contents">Contents</h2>
<ol>
{% for s in sections %}<li><a href="#{{ s.anchor }}">{{ s.title }}</a>{% if s.status != "ok" %} <span class="status-failed">({{ s.status }})</span>{% endif %}</li>
{% endfor %}<li><a href="#provenance">Provenance</a></li>
</ol>
</nav>

{% for s in sections %}
<section id="{{ s.anchor }}"{% if s.status != "ok" %} class="{{ s.status }}"{% endif %}>
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
{% if s.headline %}
<table class="headline">
<thead><tr><th class="text">headline</th><th>value</th></tr></thead>
<tbody>
{% for k, v in s.headline %}<tr><td class="text">{{ k }}</td><td>{{ v }}</td></tr>
{% endfor %}
</tbody>
</table>
{% endif %}
{% for f in s.figures %}
<figure id="{{ f.anchor }}">
<img src="{{ f.data_uri }}" alt="{{ f.alt }}" width="{{ f.width }}" height="{{ f.height }}">
<figcaption>{{ f.caption }}{% if f.csv %} <a href="{{ f.csv }}">Data: {{ f.csv }}</a>{% endif %}</figcaption>
</figure>
{% endfor %}
{% for t in s.tables %}
<h3>{{ t.name }}</h3>
{{ t.html }}
<p class="small">{% if t.truncated %}First {{ t.shown }} of {{ t.rows }} rows. {% endif %}Full table: <a href="{{ t.csv }}">{{ t.csv }}</a>{% if t.parquet %}, <a href="{{ t.parquet }}">{{ t.parquet }}</a>{% endif %}</p>
{% endfor %}
{% if s.notes %}
<div class="notes"><strong>Notes</strong>
<ul>
{% for n in s.notes %}<li>{{ n }}</li>
{% endfor %}
</ul>
</div>
{% endif %}
{% if s.error %}
<details><summary>Error details</summary>
<pre>{{ s.error }}</pre>
</details>
{% endif %}
<details><summary>Study provenance</summary>
<pre>{{ s.provenance_json }}</pre>
</details>
</section>
{% endfor %}

<section id="provenance">
<h2>Provenance</h2>
<table>
<tbody>
<tr><th class="text">pbr-xval version</th><td class="text">{{ prov.pbr_xval_version }}</td></tr>
<tr><th class="text">date</th><td class="text">{{ prov.date }}</td></tr>
<tr><th class="text">command line</th><td class="text"><code>{{ prov.command_line }}</code></td></tr>
{% if prov.study_file %}<tr><th class="text">study file</th><td class="text"><code>{{ prov.study_file }}</code></td></tr>{% endif %}
{% if prov.study_file_sha256 %}<tr><th class="text">study file SHA-256</th><td class="text"><code>{{ prov.study_file_sha256 }}</code></td></tr>{% endif %}
</tbody>
</table>
<h3>Scenarios</h3>
<table>
<thead><tr><th class="text">scenario</th><th class="text">SHA-256 (content + referenced files)</th><th class="text">file</th></tr></thead>
<tbody>
{% for sc in scenarios %}<tr><td class="text">{{ sc.name }}</td><td class="text"><code>{{ sc.hash }}</code></td><td class="text">{{ sc.file }}</td></tr>
{% endfor %}
</tbody>
</table>
<h3>Engines</h3>
{% for e in engines %}
<details><summary><strong>{{ e.name }}</strong> — {{ e.versions_short }}</summary>
<pre>{{ e.json }}</pre>
</details>
{% endfor %}
{% if not engines %}<p class="small">No engine versions were recorded.</p>{% endif %}
<h3>Machine</h3>
<table>
<tbody>
{% for k, v in machine %}<tr><th class="text">{{ k }}</th><td class="text">{{ v }}</td></tr>
{% endfor %}
</tbody>
</table>
{% if assets %}
<h3>Generated inputs</h3>
<ul>
{% for a in assets %}<li><a href="{{ a }}">{{ a }}</a></li>
{% endfor %}
</ul>
{% endif %}
<details><summary>Full provenance (JSON)</summary>
<pre>{{ prov_json }}</pre>
</details>
<p class="small">Machine-readable files: <a href="provenance.json">provenance.json</a>, <a href="summary.md">summary.md</a>{% for p in parquet_files %}, <a href="{{ p }}">{{ p }}</a>{% endfor %}.</p>
</section>
</body>
</html>
"""
