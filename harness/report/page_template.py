# ruff: noqa: E501  (HTML template lines are not wrapped)
"""The Jinja2 template of ``report.html`` (autoescaped; ``harness.report.page`` fills it).

Kept as a module constant, not a package data file, so an installed wheel always has it.
Only the plotly fragments, the sorter / filter scripts and the style are inserted unescaped
(``|safe``); every text from the run (task names, messages, ids) is escaped by Jinja2.
"""

TEMPLATE = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<title>pick-harness {{ 'tune' if tune_path else 'report' }}: {{ title_name }}</title>
<style>{{ style|safe }}</style>
{% if plotly_js %}<script type="text/javascript">{{ plotly_js|safe }}</script>{% endif %}
</head><body>
<h1>pick-harness {{ 'tune' if tune_path else 'report' }}: {{ title_name }}</h1>
<p class="lede">Objective: <b>{{ objective }} rate</b> ({{ objective_meaning }}), 95% Wilson intervals; the {{ other_objective }} rate beside it.{% if objective_note %} <b>{{ objective_note }}</b>.{% endif %}{% if tune_path %} This run is part of the tune <code>{{ tune_path }}</code>: its decisions (tested on fresh seeds) come first.{% endif %}{% if tune_links %} Tune results:{% for text, href in tune_links %} <a href="{{ href }}">{{ text }}</a>{% if not loop.last %},{% endif %}{% endfor %}.{% endif %}</p>

<section id="answer">
{% for t in answers %}<h2{% if loop.first %} id="answer-title"{% endif %}>{{ t.title }}</h2>
<table class="answer"><thead><tr>{% for h in t.header %}<th>{{ h }}</th>{% endfor %}</tr></thead><tbody>
{% for row in t.rows %}<tr>{% for cell in row.cells %}<td{% if loop.index0 == 1 %} class="decision {{ row.kind }}"{% elif cell.cls %} class="{{ cell.cls }}"{% endif %}>{% for piece in cell.pieces %}{{ piece.text }}{% endfor %}</td>{% endfor %}</tr>
{% endfor %}</tbody></table>
{% if t.note %}<p class="note">{{ t.note }}</p>{% endif %}
{% endfor %}
{% if not tune_path %}<p class="note">{% if tune_links %}The tune results linked above were tested on fresh seeds; the candidates here were not.{% else %}A "best swept setting" has the highest Wilson lower bound over the swept settings on the seeds that chose it, not a tested win: <code>harness tune</code> confirms on fresh seeds.{% endif %}</p>{% endif %}
</section>

<details class="section"><summary><h2 id="summary">Summary: what to change ({{ findings|length }} point{{ '' if findings|length == 1 else 's' }})</h2></summary>
{% if findings %}<ul class="findings">
{% for f in findings %}<li><b>{{ f.subject }}</b>: {{ f.change }}.<br><span class="evidence">Evidence: {{ f.evidence }}.</span></li>
{% endfor %}</ul>
{% else %}<p class="note">Nothing stands out: no failure or validity gap above {{ min_share }} of an arm's episodes, and no setting was compared.</p>
{% endif %}
<p class="note">From this run's rows (episodes.csv: <code>failure_stage</code>, <code>collision_a/b</code>, <code>object_*</code>). A "candidate setting" is the highest Wilson lower bound over the swept settings, not a tested win: <code>harness tune</code> confirms on fresh seeds.</p>
</details>

<details class="section"><summary><h2>Run details</h2></summary>
<dl class="overview">
{% for key, value in overview %}<dt>{{ key }}</dt><dd>{{ value }}</dd>
{% endfor %}</dl>
</details>

<details class="section"><summary><h2>Contents</h2></summary><nav class="contents"><ol>
{% for id, title in contents %}<li><a href="#{{ id }}">{{ title }}</a></li>
{% endfor %}</ol></nav></details>

{% if heatmaps %}
<details class="section" open><summary><h2 id="heatmaps">{{ objective|capitalize }} rate per robot, arm and object over the swept settings</h2></summary>
<p class="note">Colour: the {{ objective }} rate. Cells: {{ cell_text }}. Hover a cell for the 95% Wilson intervals, the failures and the error rows. {{ fallback_mark }}: the reference fallback supplied the candidates (the filter kept none; dotted frame){% if fallback_cells %}: {{ fallback_cells }} cell(s){% endif %}.</p>
{% for robot, maps in heatmaps %}<h3>{{ robot }}</h3><div class="heatmaps">
{% for h in maps %}{{ h.html|safe }}{% endfor %}
</div>
{% endfor %}
</details>
{% elif success_plot %}
<details class="section" open><summary><h2 id="heatmaps">{{ objective|capitalize }} rate over the swept settings</h2></summary>
{{ figure(success_plot) }}
</details>
{% endif %}

{% if placement %}
<details class="section"><summary><h2 id="placement">Outcome vs placement per robot arm</h2></summary>
<p class="note">Left: every episode at its object's position at reset in the arm base frame (green valid, orange a reference success that is not valid, red a failure; rings every 10 cm). Right: reference and valid rate per 5 cm of distance from the arm base, 95% Wilson intervals: where the rate falls is the arm's reach under these filters. Columns <code>object_x_m</code>, <code>object_y_m</code>, <code>object_distance_m</code>.</p>
{{ figure(placement) }}
</details>
{% endif %}

<p class="note" id="recordings">Recordings (<code>.rrd</code>, linked from episode ids): open one with <code>harness view RUN_DIR/episodes/ID.rrd</code>, or in a browser with <code>rerun --web-viewer RUN_DIR/episodes/ID.rrd</code> (<code>pip install rerun-sdk==0.41.*</code>); a plain click downloads the file.</p>

{% for t in tables %}
<details class="section" id="{{ t.id }}"><summary><h2>{{ t.title }}</h2> <span class="count">({{ t.rows|length }} row{{ '' if t.rows|length == 1 else 's' }})</span></summary>
{% if t.note %}<p class="note">{{ t.note }}</p>{% endif %}
<input class="filter" type="search" placeholder="filter rows (any text)" aria-label="filter {{ t.title }}">
<table class="sortable"><thead><tr>{% for h in t.header %}<th>{{ h }}</th>{% endfor %}</tr></thead><tbody>
{% for row in t.rows %}<tr{% if row.flag %} class="flag"{% endif %}>{% for cell in row.cells %}<td{% if cell.cls %} class="{{ cell.cls }}"{% endif %}>{% for piece in cell.pieces %}{% if not loop.first %}, {% endif %}{% if piece.href %}<a href="{{ piece.href }}" title="recording">{{ piece.text }}</a>{% else %}{{ piece.text }}{% endif %}{% endfor %}</td>{% endfor %}</tr>
{% endfor %}</tbody></table>
</details>
{% endfor %}

{% if clips %}
<details class="section" id="videos"><summary><h2>Videos: one per outcome class, one success and one failure per robot arm</h2></summary>
<p class="note">Replayed from the stored rows (harness replay), rendered offscreen with MuJoCo. Each holds on the frame that shows the cause (red mark); the poster is that frame.</p>
<div class="videos">
{% for c in clips %}<figure class="{{ c.kind }}">
{% if c.video %}<video controls muted loop playsinline preload="none"{% if c.poster %} poster="{{ c.poster }}"{% endif %} src="{{ c.video }}"></video>{% else %}<div class="novideo">no video</div>{% endif %}
<figcaption><b>{{ c.headline }}</b><br>{{ c.robot }} {{ c.arm }} arm · {{ c.object }} · seed {{ c.seed }}<br>
{% if c.recording %}<a href="{{ c.recording }}" title="recording">{{ c.episode_id }}</a>{% else %}{{ c.episode_id }}{% endif %}
{% if c.note %}<br><i>{{ c.note }}</i>{% endif %}</figcaption></figure>
{% endfor %}</div></details>
{% endif %}

{% if plots %}
<details class="section" id="plots"><summary><h2>Plots</h2></summary><div class="plots">
{% for p in plots %}{{ figure(p) }}{% endfor %}
</div></details>
{% endif %}
<script>{{ sorter|safe }}</script>
</body></html>
"""

FIGURE = """{% macro figure(p) %}<figure><img alt="{{ p.caption }}" src="{{ p.src }}"><figcaption>{{ p.caption }}</figcaption></figure>{% endmacro %}"""
