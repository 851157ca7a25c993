# ruff: noqa: E501  (HTML template lines are not wrapped)
"""The Jinja2 template of ``report.html`` (autoescaped; ``harness.report.page`` fills it).

Kept as a module constant, not a package data file, so an installed wheel always has it.
Only the plotly fragments, the sorter / filter scripts and the style are inserted unescaped
(``|safe``); every text from the run (task names, messages, ids) is escaped by Jinja2.
"""

TEMPLATE = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<title>pick-harness report: {{ name }}</title>
<style>{{ style|safe }}</style>
{% if plotly_js %}<script type="text/javascript">{{ plotly_js|safe }}</script>{% endif %}
</head><body>
<h1>pick-harness report: {{ name }}</h1>
<dl class="overview">
{% for key, value in overview %}<dt>{{ key }}</dt><dd>{{ value }}</dd>
{% endfor %}</dl>

<h2 id="summary">Summary: what to change</h2>
{% if findings %}<ul class="findings">
{% for f in findings %}<li><b>{{ f.subject }}</b>: {{ f.change }}.<br><span class="evidence">Evidence: {{ f.evidence }}.</span></li>
{% endfor %}</ul>
{% else %}<p class="note">Nothing stands out: no failure or validity gap above {{ min_share }} of an arm's episodes, and no setting was compared.</p>
{% endif %}
<p class="note">From this run's rows (episodes.csv: <code>failure_stage</code>, <code>collision_a/b</code>, <code>object_*</code>). A "candidate setting" is the highest Wilson lower bound over the swept settings, not a tested win: <code>harness tune</code> confirms on fresh seeds.</p>

<nav class="contents"><h2>Contents</h2><ol>
{% for id, title in contents %}<li><a href="#{{ id }}">{{ title }}</a></li>
{% endfor %}</ol></nav>

{% if heatmaps %}
<h2 id="heatmaps">Success per robot, arm and object over the swept settings</h2>
<p class="note">Cells: reference successes / rated episodes, rate, valid successes / judged episodes. Hover a cell for the 95% Wilson intervals, the failures and the error rows. {{ fallback_mark }}: the reference fallback supplied the candidates (the filter kept none; dotted frame){% if fallback_cells %}: {{ fallback_cells }} cell(s){% endif %}.</p>
{% for robot, maps in heatmaps %}<h3>{{ robot }}</h3><div class="heatmaps">
{% for h in maps %}{{ h.html|safe }}{% endfor %}
</div>
{% endfor %}
{% elif success_plot %}
<h2 id="heatmaps">Success over the swept settings</h2>
{{ figure(success_plot) }}
{% endif %}

{% if placement %}
<h2 id="placement">Outcome vs placement per robot arm</h2>
<p class="note">Left: every episode at its object's position at reset in the arm base frame (green valid, orange a reference success that is not valid, red a failure; rings every 10 cm). Right: reference and valid rate per 5 cm of distance from the arm base, 95% Wilson intervals: where the rate falls is the arm's reach under these filters. Columns <code>object_x_m</code>, <code>object_y_m</code>, <code>object_distance_m</code>.</p>
{{ figure(placement) }}
{% endif %}

<p class="note" id="recordings">Recordings (<code>.rrd</code>, linked from episode ids): open one with <code>harness view RUN_DIR/episodes/ID.rrd</code>, or in a browser with <code>rerun --web-viewer RUN_DIR/episodes/ID.rrd</code> (<code>pip install rerun-sdk==0.41.*</code>); a plain click downloads the file.</p>

{% for t in tables %}
<section id="{{ t.id }}"><h2>{{ t.title }}</h2>
{% if t.note %}<p class="note">{{ t.note }}</p>{% endif %}
{% if t.collapsed %}<details><summary>{{ t.rows|length }} rows (show)</summary>{% endif %}
<input class="filter" type="search" placeholder="filter rows (any text)" aria-label="filter {{ t.title }}">
<table class="sortable"><thead><tr>{% for h in t.header %}<th>{{ h }}</th>{% endfor %}</tr></thead><tbody>
{% for row in t.rows %}<tr{% if row.flag %} class="flag"{% endif %}>{% for cell in row.cells %}<td{% if cell.cls %} class="{{ cell.cls }}"{% endif %}>{% for piece in cell.pieces %}{% if not loop.first %}, {% endif %}{% if piece.href %}<a href="{{ piece.href }}" title="recording">{{ piece.text }}</a>{% else %}{{ piece.text }}{% endif %}{% endfor %}</td>{% endfor %}</tr>
{% endfor %}</tbody></table>
{% if t.collapsed %}</details>{% endif %}
</section>
{% endfor %}

{% if clips %}
<section id="videos"><h2>Videos: one per outcome class, one success and one failure per robot arm</h2>
<p class="note">Replayed from the stored rows (harness replay), rendered offscreen with MuJoCo. Each holds on the frame that shows the cause (red mark); the poster is that frame.</p>
<div class="videos">
{% for c in clips %}<figure class="{{ c.kind }}">
{% if c.video %}<video controls muted loop playsinline preload="none"{% if c.poster %} poster="{{ c.poster }}"{% endif %} src="{{ c.video }}"></video>{% else %}<div class="novideo">no video</div>{% endif %}
<figcaption><b>{{ c.headline }}</b><br>{{ c.robot }} {{ c.arm }} arm · {{ c.object }} · seed {{ c.seed }}<br>
{% if c.recording %}<a href="{{ c.recording }}" title="recording">{{ c.episode_id }}</a>{% else %}{{ c.episode_id }}{% endif %}
{% if c.note %}<br><i>{{ c.note }}</i>{% endif %}</figcaption></figure>
{% endfor %}</div></section>
{% endif %}

{% if plots %}
<h2 id="plots">Plots</h2><div class="plots">
{% for p in plots %}{{ figure(p) }}{% endfor %}
</div>
{% endif %}
<script>{{ sorter|safe }}</script>
</body></html>
"""

FIGURE = """{% macro figure(p) %}<figure><img alt="{{ p.caption }}" src="{{ p.src }}"><figcaption>{{ p.caption }}</figcaption></figure>{% endmacro %}"""
