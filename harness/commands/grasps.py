"""``harness grasps inspect FILE --robot NAME ...``: filter and order a grasp file for a robot.

Shows what the Pick skill would do with one grasp file for one object pose in the arm base frame
(``--object-pose``, default identity): how many of the 2N end-effector poses each direction
filter keeps, how many pass them all, and the candidate order (reference or strict semantics).
``--json`` prints the same as one object; ``--plot`` draws the approach directions on a sphere.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from harness.commands.console import say
from harness.config import PickConfig, validate_model
from harness.errors import HarnessError
from harness.grasps import (
    AXES,
    CandidateSelection,
    GripperConvention,
    ee_poses_for_pick,
    load_grasp_file,
    select_candidates,
)
from harness.pick.semantics import Semantics
from harness.robots import RobotModel
from harness.transforms import matrix_to_quat, pose_to_T
from harness.viz.formats import PLOT_SUFFIXES, check_suffix
from harness.writes import write_through

if TYPE_CHECKING:  # matplotlib is imported only when a plot is asked for
    from mpl_toolkits.mplot3d.axes3d import Axes3D


def robot_convention(name: str, arm: str) -> GripperConvention:
    """The gripper convention of robot ``name`` (robots/<name>/robot.yaml), checking its ``arm``."""
    model = RobotModel.load(name)
    if arm not in model.arms:
        arms = ", ".join(model.arms)
        raise HarnessError(f"robot {name!r} has no {arm} arm; its arms: {arms}")
    return model.convention


def _filter_value(flag: str, values: list[str] | None) -> list[Any] | None:
    """``DIR A [B]`` from the command line as a filter list with numeric angles."""
    if values is None:
        return None
    if len(values) not in (2, 3):
        raise HarnessError(f"{flag} takes DIR ANGLE [ANGLE2], got {' '.join(values)!r}")
    direction, *angles = values
    try:
        return [direction, *(float(a) for a in angles)]
    except ValueError:
        raise HarnessError(f"{flag}: angles must be numbers of degrees, got {angles}") from None


def pick_from_args(args: argparse.Namespace) -> PickConfig:
    """The pick block the command-line options describe, validated like a YAML one."""
    data: dict[str, Any] = {"semantics": args.semantics, "grasp_scale": args.grasp_scale}
    for axis in AXES:
        value = _filter_value(f"--filter-{axis}", getattr(args, f"filter_{axis}"))
        if value is not None:
            data[f"filter_{axis}_dir"] = value
    for flag, key in (("approach", "approach_filter"), ("facing", "facing_filter")):
        value = _filter_value(f"--{flag}", getattr(args, flag))
        if value is not None:
            data[key] = value
    if args.direction_to_obj:
        data["direction_to_obj"] = args.direction_to_obj
    if args.constraints:
        c_axis, rmin, rmax = args.constraints
        try:
            data["constraints"] = [c_axis, float(rmin), float(rmax)]
        except ValueError:
            raise HarnessError(
                f"--constraints AXIS MIN MAX needs numbers, got {args.constraints}"
            ) from None
    return validate_model(PickConfig, data)


def object_pose(values: list[float] | None) -> np.ndarray:
    """``T_base_obj`` from ``X Y Z QW QX QY QZ`` (identity when absent)."""
    if values is None:
        return np.eye(4)
    quat = np.asarray(values[3:], dtype=float)
    if not np.all(np.isfinite(values)) or np.linalg.norm(quat) < 1e-9:
        raise HarnessError(f"--object-pose needs finite values and a non-zero quaternion: {values}")
    return pose_to_T(values[:3], quat)


def summary(selection: CandidateSelection, args: argparse.Namespace) -> dict[str, Any]:
    """Everything ``inspect`` reports, as JSON-ready values."""
    result, order, poses = selection.filter_result, selection.order, selection.ee_poses
    position = selection.T_base_obj[:3, 3]
    return {
        "file": str(args.file),
        "robot": args.robot,
        "arm": args.arm,
        "semantics": order.semantics,
        "seed": args.seed,
        "object_pose": [*position.tolist(), *matrix_to_quat(selection.T_base_obj[:3, :3]).tolist()],
        "grasps": poses.n_grasps,
        "total": result.total,
        "filters": {key: spec.as_list() for key, spec in selection.filters.items()},
        "direction_to_obj": args.direction_to_obj,
        "filter_sources": selection.filter_sources,
        "per_filter": result.counts(),
        "passed": result.passed,
        "passing_indices": result.passing_indices.tolist(),
        "top_candidates": order.top_candidates.tolist(),
        "top_candidate_scores": poses.scores[order.top_candidates].tolist(),
        "outcome": order.outcome,
        "note": order.note,
        "candidates": order.indices.tolist(),
        "candidate_scores": order.scores.tolist(),
    }


def _candidate_rows(selection: CandidateSelection, indices: np.ndarray) -> list[str]:
    poses = selection.ee_poses
    R_base_obj = selection.T_base_obj[:3, :3]
    approach = poses.rotations_at(indices)[:, :, poses.approach_index] @ R_base_obj.T
    rows = [f"  {'#':>3}  {'pose':>6}  {'row':>5}  {'flipped':>7}  {'score':>6}  approach (base)"]
    for rank, (index, direction) in enumerate(zip(indices, approach, strict=True)):
        rows.append(
            f"  {rank:>3}  {index:>6}  {poses.source_row[index]:>5}  "
            f"{'yes' if poses.flipped[index] else 'no':>7}  {poses.scores[index]:>6.3g}  "
            f"[{direction[0]:+.3f} {direction[1]:+.3f} {direction[2]:+.3f}]"
        )
    return rows


def format_text(selection: CandidateSelection, info: dict[str, Any]) -> str:
    """The human-readable report: filter table, then the candidate order."""
    result, order = selection.filter_result, selection.order
    total = result.total
    lines = [
        f"grasp file  {info['file']}",
        f"robot       {info['robot']} (arm {info['arm']}), semantics {info['semantics']}, "
        f"seed {info['seed']}",
        "object pose "
        + " ".join(f"{v:.4g}" for v in info["object_pose"])
        + "  (x y z qw qx qy qz)",
        f"poses       {total} ({info['grasps']} grasps + their 180-degree flips)",
        "",
        f"  {'filter':<18} {'setting':<28} {'from':<16} {'pass':>7} {'of':>7} {'%':>6}",
    ]
    for key, count in result.counts().items():
        spec = selection.filters.get(key)
        setting = str(spec.as_list()) if spec is not None else str(info.get("direction_to_obj"))
        source = selection.filter_sources.get(key, key)
        lines.append(
            f"  {key:<18} {setting:<28} {source:<16} {count:>7} {total:>7} "
            f"{100.0 * count / max(total, 1):>5.1f}%"
        )
    if not result.masks:
        lines.append("  (no filters: every pose passes)")
    lines.append(
        f"  {'combined':<18} {'':<28} {'':<16} {result.passed:>7} {total:>7} "
        f"{100.0 * result.passed / max(total, 1):>5.1f}%"
    )
    lines += ["", f"outcome     {order.outcome}" + (f" -- {order.note}" if order.note else "")]
    if order.top_candidates.size:
        title = "fallback list" if order.outcome == "fallback" else "top candidates"
        lines += ["", f"{title} (deterministic, before any draw):"]
        lines += _candidate_rows(selection, order.top_candidates)
    same_as_top = np.array_equal(order.indices, order.top_candidates)
    if order.outcome == "ok" and same_as_top:
        lines += ["", "candidate order: the top candidates above, each once"]
    elif order.outcome == "ok":
        how = (
            f"{len(order)} weighted draws with replacement, sorted by score"
            if order.semantics == "reference"
            else "weighted sample without replacement, sorted by score"
        )
        lines += ["", f"candidate order ({how}):"]
        lines += _candidate_rows(selection, order.indices)
    return "\n".join(lines)


def plot_directions(selection: CandidateSelection, path: str | Path, title: str) -> None:
    """Approach directions in the arm base frame on the unit sphere, coloured by verdict."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    poses = selection.ee_poses
    passed = selection.filter_result.combined
    direction = poses.approach_axes @ selection.T_base_obj[:3, :3].T
    rng = np.random.default_rng(0)  # subsample only for drawing huge files
    shown = np.arange(len(poses))
    if shown.size > 20_000:
        shown = np.sort(rng.choice(shown, size=20_000, replace=False))
    rejected_shown = shown[~passed[shown]]
    passed_shown = shown[passed[shown]]
    candidates = np.unique(selection.order.indices)

    fig = plt.figure(figsize=(8, 7))
    ax = cast("Axes3D", fig.add_subplot(projection="3d"))
    u, v = np.mgrid[0 : 2 * np.pi : 37j, 0 : np.pi : 19j]
    ax.plot_wireframe(
        np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v), color="0.85", linewidth=0.4
    )
    ax.scatter(*direction[rejected_shown].T, s=3, c="tab:red", alpha=0.25, label="rejected")
    ax.scatter(*direction[passed_shown].T, s=6, c="tab:green", alpha=0.7, label="passed")
    if candidates.size:
        ax.scatter(
            *direction[candidates].T,
            s=60,
            facecolors="none",
            edgecolors="black",
            linewidths=1.2,
            label=f"candidates ({selection.order.outcome})",
        )
    for axis_vec, name in ((np.eye(3)[0], "+X forward"), (np.eye(3)[2], "+Z up")):
        ax.quiver(0, 0, 0, *(1.35 * axis_vec), color="tab:blue", arrow_length_ratio=0.08)
        x, y, z = 1.45 * axis_vec
        ax.text(x, y, z, name, color="tab:blue")
    ax.set_xlabel("base x (forward)")
    ax.set_ylabel("base y (left)")
    ax.set_zlabel("base z (up)")
    ax.set_box_aspect((1, 1, 1))
    ax.set_title(title, fontsize=10)
    ax.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    try:
        write_through(Path(path), lambda tmp: fig.savefig(tmp, dpi=110))
    finally:
        plt.close(fig)


def inspect(args: argparse.Namespace) -> int:
    """Entry point of ``harness grasps inspect``."""
    if args.plot:
        check_suffix(args.plot, PLOT_SUFFIXES, "--plot")
    convention = robot_convention(args.robot, args.arm)
    pick = pick_from_args(args)
    grasps = load_grasp_file(args.file)
    poses = ee_poses_for_pick(grasps, convention, pick)
    rng = np.random.default_rng(args.seed)
    rule = Semantics.from_pick(pick).candidates
    selection = select_candidates(poses, convention, pick, object_pose(args.object_pose), rng, rule)
    info = summary(selection, args)
    if args.json:
        print(json.dumps(info))  # JSON escapes controls itself (ensure_ascii); say() would break it
    else:
        say(format_text(selection, info))
    if args.plot:
        result = selection.filter_result
        title = (
            f"{Path(args.file).parent.name}/{Path(args.file).name} on {args.robot}: "
            f"{result.passed} of {result.total} approach directions pass"
        )
        plot_directions(selection, args.plot, title)
        if not args.json:
            say(f"\nwrote {args.plot}")
    return 0


def audit(args: argparse.Namespace) -> int:
    """``harness grasps audit RUN_DIR``: executed grasps, never-succeeding ones, cleaned files."""
    from harness.commands.console import make_console, styled
    from harness.tuning.audit import audit_run, flagged_rows

    run_dir = Path(args.run_dir)
    if not run_dir.is_dir():
        raise HarnessError(f"{run_dir}: run directory not found")
    result = audit_run(run_dir, args.min_trials)
    console = make_console()
    table = result.table
    if table.empty:
        console.print(f"{run_dir}: no episode executed a grasp")
        return 0
    from harness.report.frames import column

    for obj, group in table.groupby("object"):
        never = int((column(group, "successes") == 0).sum())
        console.print(
            styled(
                "[bold]{obj}[/]: {rest}",
                obj=obj,
                rest=f"{len(group)} annotated grasp(s) executed in "
                f"{int(column(group, 'trials').sum())} distinct execution(s) "
                f"({int(column(group, 'rows').sum())} rows); {never} never succeeded, "
                f"{int(column(group, 'flagged').sum())} flagged (>= {args.min_trials} trials)",
            ),
            soft_wrap=True,
        )
    for row in flagged_rows(table):
        console.print(
            f"  {row['object']} grasp {row['grasp_row']} (width {row['width_m'] * 1000:.0f} mm): "
            f"0/{row['trials']} on {row['robots']}: {row['causes']}",
            soft_wrap=True,
            highlight=False,
            markup=False,
        )
    for source, target in result.cleaned.items():
        console.print(f"  cleaned  {source} -> {target}", soft_wrap=True, highlight=False)
    console.print(f"  audit    {result.csv}", soft_wrap=True, highlight=False)
    return 0
