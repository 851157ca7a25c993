"""What an episode recording shows about *why* (rerun-sdk 0.41): every grasp candidate coloured
by its verdict with the reason as a label, the pre-grasp and grasp targets of the chosen and of
each tested candidate, the finger-object contacts with their forces, and the verdict with its
failure message as a Markdown document (``/verdict``, shown by the episode blueprint).

Targets are drawn at the TCP (the EE pose moved ``tcp_offset`` along the approach axis): the
point the fingers close on. Quaternions never reach Rerun here (arrows and points only).
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np

from harness.pick.terms import term_columns
from harness.viz.headline import caption, headline
from harness.viz.label_layout import LabelLayout, log_labels
from harness.viz.scene_geometry import rerun_sdk

# Candidate verdict -> RGB. Chosen is drawn on top, thicker; ``fallback`` is the infeasible
# candidate the reference went on with when nothing passed (never drawn as chosen).
VERDICT_COLORS: dict[str, tuple[int, int, int]] = {
    "rejected": (150, 150, 150),
    "passed": (70, 130, 230),
    "infeasible": (230, 140, 40),
    "feasible": (60, 190, 90),
    "chosen": (220, 30, 200),
    "fallback": (230, 40, 40),
}
TESTED = ("infeasible", "feasible", "chosen", "fallback")  # drawn as arrows, the rest as points
ALWAYS_LABELLED = ("chosen", "fallback")
MAX_LABELS = 3  # per other tested verdict: the first few in test order carry a label
FAILURE_POSE_TIME_S = 0.5  # sim_time at which an unexecuted failing configuration is posed
CAUSE_COLOR = (255, 30, 30)
AXIS_COLORS = ((230, 60, 60), (60, 200, 60), (60, 90, 230))  # x, y, z of a target's frame
TARGET_AXIS_M = 0.03
FORCE_ARROW_M_PER_N = 0.005  # a finger contact force of 10 N is drawn 5 cm long
CONTACT_COLORS = ((40, 200, 230), (240, 200, 40))  # left, right finger


def tcp_point(T_world_ee: np.ndarray, approach_index: int, tcp_offset: float) -> np.ndarray:
    """The TCP of an EE pose: its origin moved ``tcp_offset`` along the approach axis."""
    return T_world_ee[:3, 3] + T_world_ee[:3, approach_index] * tcp_offset


def candidate_label(status: str, index: int, detail: str) -> str:
    """The label of a tested candidate's arrow: its pose index and, if it failed, the stage."""
    stage = detail.split(":", 1)[0] if detail else ""
    if status == "chosen":
        return f"chosen #{index}"
    if status == "fallback":
        return f"fallback #{index} (none feasible): {stage}"
    return f"#{index} {stage}".rstrip()


def _label_rows(trace: Any, status: str, rows: np.ndarray) -> set[int]:
    """The rows of ``status`` that carry a visible label: chosen / fallback always, else the
    first ``MAX_LABELS`` in test order (every label stays readable; the rest show on hover)."""
    if status in ALWAYS_LABELLED:
        return set(rows.tolist())
    order = trace.tested_index.tolist() if trace.tested_index is not None else []
    rank = {index: k for k, index in enumerate(order)}
    ranked = sorted(rows.tolist(), key=lambda r: rank.get(int(trace.candidate_index[r]), 1 << 30))
    return set(ranked[:MAX_LABELS])


def log_candidates(
    rec: Any, trace: Any, approach_index: int, tcp_offset: float, layout: LabelLayout | None = None
) -> None:
    """The tested candidates as arrows from their EE origin to their TCP (the chosen or
    fallback one and the first few of each verdict labelled with pose index and failing
    stage, the others labelled on hover only), the untested ones as points at their TCP; one
    entity per verdict."""
    rr = rerun_sdk()
    statuses = np.asarray(trace.candidate_status, dtype=str)
    for status in dict.fromkeys(statuses.tolist()):
        rows = np.flatnonzero(statuses == status)
        T = np.asarray(trace.candidate_T_world_ee)[rows]
        origins = T[:, :3, 3]
        vectors = T[:, :3, approach_index] * tcp_offset
        color = VERDICT_COLORS.get(status, (255, 255, 255))
        entity = f"/world/candidates/{status}"
        if status not in TESTED:
            rec.log(
                entity,
                rr.Points3D(origins + vectors, colors=[color], radii=[0.0025]),
                static=True,
            )
            continue
        shown = _label_rows(trace, status, rows)
        labels = [
            candidate_label(status, int(trace.candidate_index[r]), trace.candidate_detail[r])
            for r in rows
        ]
        radius = 0.004 if status in ALWAYS_LABELLED else 0.0015
        rec.log(
            entity,
            rr.Arrows3D(
                origins=origins,
                vectors=vectors,
                colors=[color] * len(rows),
                radii=[radius] * len(rows),
                labels=labels,
                show_labels=False,
            ),
            static=True,
        )
        # Hover shows every arrow's instance; the readable few carry their label in the scene.
        picked = [k for k, r in enumerate(rows.tolist()) if r in shown]
        if picked:  # anchors placed apart (``layout``) so the labels do not print over each other
            tips = (origins + vectors)[picked]
            log_labels(rec, f"{entity}/labels", tips, [labels[k] for k in picked], color, layout)


def log_cause(
    rec: Any, cause: Any, time_s: float | None, layout: LabelLayout | None = None
) -> None:
    """The cause's mark (``harness.viz.cause``): a red sphere at its point, labelled, static so
    it shows at any time (its label says when, for an executed moment). Placed first in the
    scene's ``layout``: other labels make way for it."""
    rr = rerun_sdk()
    if cause.point is None:
        return
    if layout is not None:
        layout.place(np.asarray(cause.point, dtype=float))
    rec.log(
        "/world/cause",
        rr.Points3D(
            [np.asarray(cause.point, dtype=float)],
            colors=[CAUSE_COLOR],
            radii=[0.015],
            labels=[cause.label],
            show_labels=True,
        ),
        static=True,
    )


def log_targets(
    rec: Any, trace: Any, approach_index: int, tcp_offset: float, layout: LabelLayout | None = None
) -> None:
    """The tested candidates' approach (pre-grasp TCP -> grasp TCP, coloured by verdict), and
    the chosen candidate's pre-grasp, grasp and lift as small frames, each named by a label
    placed apart from the others (``<frame>/label``, ``layout``)."""
    rr = rerun_sdk()
    tested = trace.tested_index if trace.tested_index is not None else np.zeros(0)
    statuses = np.asarray(trace.tested_status if len(tested) else [], dtype=str)
    pregrasps, grasps = trace.tested_T_world_pregrasp, trace.tested_T_world_grasp
    for status in dict.fromkeys(statuses.tolist()):
        rows = np.flatnonzero(statuses == status)
        pre = [tcp_point(T, approach_index, tcp_offset) for T in pregrasps[rows]]
        grasp = [tcp_point(T, approach_index, tcp_offset) for T in grasps[rows]]
        color = VERDICT_COLORS.get(status, (255, 255, 255))
        entity = f"/world/targets/tested/{status}"
        rec.log(
            f"{entity}/approach",
            rr.LineStrips3D(
                [[p, g] for p, g in zip(pre, grasp, strict=True)],
                colors=[color] * len(rows),
                radii=[0.001] * len(rows),
            ),
            static=True,
        )
        rec.log(f"{entity}/pregrasp", rr.Points3D(pre, colors=[color], radii=[0.004]), static=True)
        rec.log(f"{entity}/grasp", rr.Points3D(grasp, colors=[color], radii=[0.003]), static=True)
    for name, T in _chosen_targets(trace, statuses).items():
        origin = tcp_point(T, approach_index, tcp_offset)
        rec.log(
            f"/world/targets/chosen/{name}",
            rr.Arrows3D(
                origins=[origin] * 3,
                vectors=[T[:3, axis] * TARGET_AXIS_M for axis in range(3)],
                colors=list(AXIS_COLORS),
                radii=[0.002] * 3,
                labels=[name, "", ""],
                show_labels=False,
            ),
            static=True,
        )
        label_colour = (230, 230, 230)
        log_labels(rec, f"/world/targets/chosen/{name}/label", origin, [name], label_colour, layout)


def _chosen_targets(trace: Any, tested_status: np.ndarray) -> dict[str, np.ndarray]:
    """The chosen candidate's targets: as planned for execution when a plan exists (fixed
    orientation applied), else as tested (a plan that failed, or a fallback)."""
    if trace.T_world_grasp is not None and trace.T_world_pregrasp is not None:
        targets = {"pre-grasp": trace.T_world_pregrasp, "grasp": trace.T_world_grasp}
        if trace.T_world_lift is not None:
            targets["lift"] = trace.T_world_lift
        return targets
    rows = np.flatnonzero(np.isin(tested_status, ("chosen", "fallback")))
    if not len(rows):
        return {}
    row = int(rows[-1])
    return {
        "pre-grasp": trace.tested_T_world_pregrasp[row],
        "grasp": trace.tested_T_world_grasp[row],
    }


def log_contacts(rec: Any, trace: Any) -> None:
    """The finger-object contacts at each row the trace sampled them: points (by finger) and
    the force on the object as arrows (``FORCE_ARROW_M_PER_N``); a sample without contacts (a
    touch ended) clears them."""
    rr = rerun_sdk()
    contacts = trace.contacts
    if contacts is None or not len(contacts.sampled):
        return
    order = np.argsort(contacts.row, kind="stable")
    rows = contacts.row[order]
    starts = np.searchsorted(rows, contacts.sampled, side="left")
    ends = np.searchsorted(rows, contacts.sampled, side="right")
    lengths = (ends - starts).tolist()
    colors = np.asarray(
        [CONTACT_COLORS[int(f) % 2] for f in contacts.finger[order]], dtype=np.uint8
    ).reshape(-1, 3)
    index = [rr.TimeColumn("sim_time", duration=np.asarray(trace.time)[contacts.sampled])]
    rec.send_columns(
        "/world/contacts/points",
        indexes=index,
        columns=rr.Points3D.columns(positions=contacts.position[order], colors=colors).partition(
            lengths
        ),
    )
    rec.send_columns(
        "/world/contacts/forces",
        indexes=index,
        columns=rr.Arrows3D.columns(
            origins=contacts.position[order],
            vectors=contacts.force[order] * FORCE_ARROW_M_PER_N,
            colors=colors,
        ).partition(lengths),
    )


# --------------------------------------------------------------------------------------------
# The verdict document

# The row columns the verdict document lists: the episode and its candidates, then the
# verdict's (the execution's own, the validity verdict, and every column a verdict term reads,
# from ``harness.pick.terms.TERMS``).
ROW_KEYS = tuple(
    dict.fromkeys(
        (
            "robot", "arm", "object", "seed", "episode_id", "semantics", "test_mode", "timing",
            "n_total", "n_passed_filter", "filter_outcome", "n_tested", "n_feasible",
            "candidate_failures", "chosen_index", "chosen_score", "approach_angle_deg",
            "slip_m", "tcp_grasp_error_m", "valid", "invalid_reason", *term_columns(),
            "failure_stage", "collision_a", "collision_b", "object_x_m", "object_y_m",
            "object_distance_m",
        )
    )
)  # fmt: skip


def verdict_title(row: dict[str, Any]) -> str:
    """The outcome headline with both verdicts (``harness.viz.headline``)."""
    return headline(row)


def verdict_markdown(row: dict[str, Any], trace: Any | None, cause: str = "") -> str:
    """The headline, what the episode was, the cause shown in the scene, the failure message,
    the failures per stage, each tested candidate's reason, and the row's main columns."""
    lines = [f"# {verdict_title(row)}", "", caption(row), ""]
    if cause:
        lines += [f"**Shown in the scene** (red mark, `/world/cause`): {_cell(cause)}", ""]
    if row.get("error_message"):
        lines += ["**Why:** " + _cell(str(row["error_message"])), ""]
    failures = _failure_counts(row.get("candidate_failures"))
    if failures:
        lines += ["## Failures of the tested candidates, by stage", "", "| stage | candidates |"]
        lines += ["|---|---|", *(f"| {stage} | {count} |" for stage, count in failures.items())]
        lines.append("")
    if trace is not None and trace.tested_index is not None and len(trace.tested_index):
        lines += _tested_table(trace)
    lines += ["## Row", "", "| key | value |", "|---|---|"]
    for key in ROW_KEYS:
        value = row.get(key)
        if value in ("", None) or (isinstance(value, float) and value != value):
            continue  # unset, or NaN: not measured in this episode
        text = f"{value:.4g}" if isinstance(value, float) else _cell(str(value))
        lines.append(f"| {key} | {text} |")
    return "\n".join(lines)


def _tested_table(trace: Any) -> list[str]:
    detail = dict(zip(trace.candidate_index.tolist(), trace.candidate_detail, strict=True))
    lines = ["## Tested candidates (test order)", "", "| pose | verdict | reason |"]
    lines.append("|---|---|---|")
    for index, status in zip(trace.tested_index.tolist(), trace.tested_status, strict=True):
        lines.append(f"| {index} | {status} | {_cell(detail.get(index, ''))} |")
    return [*lines, ""]


def _failure_counts(value: Any) -> dict[str, int]:
    try:
        counts = json.loads(value) if isinstance(value, str) and value else {}
    except json.JSONDecodeError:
        return {}
    return counts if isinstance(counts, dict) else {}


def _cell(text: str) -> str:
    """Text safe inside a Markdown table cell."""
    return text.replace("|", "\\|").replace("\n", " ")


def log_verdict(
    rec: Any, row: dict[str, Any], trace: Any | None, end_time: float, cause: str = ""
) -> None:
    """The verdict as the last event at the episode's end, and as the ``/verdict`` document."""
    rr = rerun_sdk()
    rec.set_time("sim_time", duration=end_time)
    level = rr.TextLogLevel.INFO if row.get("success") else rr.TextLogLevel.ERROR
    message = f" ({row['error_message']})" if row.get("error_message") else ""
    rec.log("/events", rr.TextLog(f"verdict: {verdict_title(row)}{message}", level=level))
    rec.log(
        "/verdict",
        rr.TextDocument(verdict_markdown(row, trace, cause), media_type="text/markdown"),
        static=True,
    )
