"""The grasp-annotation audit of a run: each executed grasp's record, never-succeeding grasps and
why, and cleaned grasp files without them (``harness grasps audit RUN_DIR``).

A row's ``chosen_index`` is a pose index into the 2N end-effector poses of its task's grasp file
(pose i and N + i are grasp i, after ``constraints``; ``EEPoses.grasp_rows`` maps a grasp back to
its file row), so the audit rebuilds the poses of every (task, point) and counts trials and
successes per grasp-file row, across robots, arms and seeds. A trial is a distinct execution
(task, seed, chosen pose, non-filter point values), not a row: points that differ only in their
filters share a seed's execution of the same grasp, and count it once. A grasp tried at least
``min_trials`` times that never succeeded is flagged with every cause the run supports:

- ``wider than the jaw``: its annotated width exceeds the widest jaw opening of a robot that
  executed it (robots/<name>/robot.yaml ``open_width``);
- ``approach from below``: its approach axis pointed up (``approach_angle_deg`` > 90, the angle
  from straight down), i.e. through the table, or its failures were ``collision`` /
  ``table_penetration``;
- ``IK / planning``: its failures were ``plan_failed`` (the pre-grasp, approach or lift found no
  joint path; ``no_feasible_candidate`` episodes execute no grasp and are not counted);
- otherwise ``other: <reasons>``.

Cleaned files (the same N' x 17 format, flagged rows removed) go to ``<run>/grasp_audit/``.
"""

from __future__ import annotations

import json
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

import numpy as np
import pandas as pd

from harness.config import TaskConfig, apply_overrides
from harness.episode.candidate_cache import SELECTION_KEYS
from harness.errors import HarnessError
from harness.files import safe_child
from harness.grasps.ee_poses import ee_poses_for_pick
from harness.grasps.grasp_set import load_grasp_file, read_grasp_array
from harness.objects.assets import find_grasp_file, resolve_mesh
from harness.report.frames import column, frame_of, series_rows
from harness.report.tables import load_episodes
from harness.robots.facts import max_jaw_opening, reference_convention
from harness.row import param_columns
from harness.runs.expansion import load_sweep_tasks, point_overrides
from harness.runs.rundir import RunDir
from harness.runs.safety import RunLock
from harness.writes import check_outputs, write_file, write_npy

AUDIT_DIR = "grasp_audit"
TABLE_REASONS = ("collision", "table_penetration")


@dataclass(frozen=True)
class AuditResult:
    """The per-grasp table (``audit.csv``) and the cleaned grasp files written."""

    table: pd.DataFrame
    cleaned: dict[str, Path]
    csv: Path


def grasp_file(task: TaskConfig) -> Path:
    """The target object's grasp file, by the same rule as the scene (``grasp_file_for``)."""
    obj = task.target_object
    mesh = resolve_mesh(obj.mesh, task.base_dir())
    if obj.grasps:
        path = Path(obj.grasps)
        return path if path.is_absolute() or path.is_file() else mesh.parent / path
    found = find_grasp_file(mesh, task.pick.npy_name)
    if found is None:
        raise HarnessError(f"task {task.name!r}: object {obj.name!r} ({mesh}) has no grasp file")
    return found


def _grasp_rows(task: TaskConfig, pose_indices: np.ndarray, path: Path) -> np.ndarray:
    """Grasp-file rows of pose indices of ``task`` (its convention, scale, tcp, constraints)."""
    poses = ee_poses_for_pick(load_grasp_file(path), reference_convention(task.robot), task.pick)
    return poses.grasp_rows[poses.grasp_index(pose_indices)]


def executed_grasps(run_dir: Path) -> pd.DataFrame:
    """The run's executed episodes with ``grasp_file`` and ``grasp_row`` columns added."""
    run = RunDir(run_dir)
    tasks = {t.name: t for t in load_sweep_tasks(run.load_sweep(), run.sweep_yaml)}
    frame = load_episodes(run_dir)
    executed = frame_of(frame[column(frame, "chosen_index") >= 0]).copy()
    executed["execution"] = execution_keys(executed)
    executed["grasp_file"] = ""
    executed["grasp_row"] = -1
    for key, group in executed.groupby(["task", "point"], sort=False):
        name, point = cast(tuple[Any, ...], key)
        task = apply_overrides(
            tasks[str(name)], point_overrides(tasks[str(name)], json.loads(str(point)))
        )
        path = grasp_file(task)
        rows = _grasp_rows(task, column(group, "chosen_index").to_numpy(np.int64), path)
        executed.loc[group.index, "grasp_file"] = str(path)
        executed.loc[group.index, "grasp_row"] = rows
    return executed


def execution_keys(frame: pd.DataFrame) -> list[str]:
    """One key per distinct execution: the task, the seed, the chosen pose and the point's
    non-selection values. Points that differ only in filters share a seed's execution of the
    same candidate (``harness.episode.candidate_cache``): one execution, several rows."""
    selection = {f"param.pick.{key}" for key in SELECTION_KEYS}
    others = [c for c in param_columns(frame.columns) if c not in selection]
    cells = frame[["task", "seed", "chosen_index", *others]].astype(str)
    return [json.dumps(list(row)) for row in cells.itertuples(index=False, name=None)]


def _causes(group: pd.DataFrame, width: float) -> list[str]:
    """Why a grasp that never succeeded fails (every cause the rows support)."""
    causes = []
    robots = sorted(set(column(group, "robot")))
    too_wide = [r for r in robots if width > max_jaw_opening(r)]
    if too_wide:
        jaws = ", ".join(f"{r} {max_jaw_opening(r) * 1000:.0f} mm" for r in too_wide)
        causes.append(f"wider than the jaw ({width * 1000:.0f} mm > {jaws})")
    reasons = Counter(column(group, "failure_reason")) + Counter(
        r for r in column(group, "invalid_reason") if r
    )
    upward = float(np.nanmedian(column(group, "approach_angle_deg").to_numpy(float)))
    table = {r: reasons[r] for r in TABLE_REASONS if reasons[r]}
    if upward > 90.0 or table:
        detail = "".join(f"; {r} x{n}" for r, n in table.items())
        causes.append(f"approach from below (median {upward:.0f} deg from down{detail})")
    if reasons["plan_failed"]:
        causes.append(f"IK / planning (plan_failed x{reasons['plan_failed']})")
    if not causes:
        top = ", ".join(f"{r} x{n}" for r, n in reasons.most_common(3) if r)
        causes.append(f"other: {top}")
    return causes


def audit_table(executed: pd.DataFrame, min_trials: int) -> pd.DataFrame:
    """One row per (object, grasp file, grasp row): trials, successes, robots, flag, causes."""
    rows: list[dict[str, Any]] = []
    widths: dict[str, np.ndarray] = {}
    for key, group in executed.groupby(["object", "grasp_file", "grasp_row"]):
        obj, path, grasp = cast(tuple[Any, ...], key)
        if path not in widths:
            widths[str(path)] = read_grasp_array(str(path))[:, 1]
        width = float(widths[str(path)][int(grasp)])
        distinct = group.drop_duplicates("execution")
        trials = len(distinct)
        successes = int(column(distinct, "success").sum())
        flagged = successes == 0 and trials >= min_trials
        rows.append(
            {
                "object": obj,
                "grasp_file": path,
                "grasp_row": int(grasp),
                "width_m": width,
                "trials": trials,
                "successes": successes,
                "rows": len(group),
                "robots": " ".join(
                    sorted(set(column(group, "robot") + "/" + column(group, "arm")))
                ),
                "seeds": int(column(group, "seed").nunique()),
                "flagged": flagged,
                "causes": "; ".join(_causes(group, width)) if successes == 0 else "",
            }
        )
    return pd.DataFrame(rows)


def write_cleaned(table: pd.DataFrame, out_dir: Path) -> dict[str, Path]:
    """Per grasp file with flagged rows: a copy without them, ``<object>_cleaned.npy``."""
    cleaned: dict[str, Path] = {}
    flagged = frame_of(table[column(table, "flagged")])
    out_dir.parent.mkdir(parents=True, exist_ok=True)  # the run directory: out_dir is checked
    for key, group in flagged.groupby(["object", "grasp_file"]):
        obj, path = cast(tuple[Any, ...], key)
        data = read_grasp_array(str(path))
        keep = np.ones(len(data), dtype=bool)
        keep[column(group, "grasp_row").to_numpy(np.int64)] = False
        target = safe_child(out_dir, str(obj), "cleaned", suffix=".npy")
        write_npy(target, data[keep], root=out_dir.parent)
        cleaned[str(path)] = target
    return cleaned


def audit_run(run_dir: Path, min_trials: int = 3) -> AuditResult:
    """Audit the executed grasps of a run directory; write ``audit.csv`` and cleaned files."""
    with RunLock(run_dir):  # not while a sweep fills the directory (one line naming its pid)
        table = audit_table(executed_grasps(run_dir), min_trials)
        out_dir = run_dir / AUDIT_DIR
        check_outputs(run_dir, folders=(AUDIT_DIR,))  # a planted link in grasp_audit/: refused
        csv = write_file(out_dir / "audit.csv", table.to_csv(index=False), root=run_dir)
        return AuditResult(table, write_cleaned(table, out_dir), csv)


def flagged_rows(table: pd.DataFrame) -> list[Any]:
    """The flagged grasps, for printing."""
    return list(series_rows(frame_of(table[column(table, "flagged")])))
