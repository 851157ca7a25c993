"""The episode row: one typed record per episode, and the column schema derived from it.

One episode = one flat row. ``EpisodeRow`` is the single definition of its fixed columns: field
order is column order, field types are column types, field defaults are the values an episode's
row starts from (``harness.episode.pipeline.base_row``), and each field's metadata holds its
description and the value a stored row that lacks the column reads back as. ``SCHEMA`` (name ->
``Column``) is derived from it; the store, the CSV / Parquet export and the report read rows
through it.

Besides the fixed columns a row carries one ``param.<dotted key>`` column per swept axis
(dynamic, after the fixed columns). ``identity_columns`` is the one writer of the identity
columns (episode id, run, point, task, robot, arm, object, seed, index and ``param.*``): the
episode's own row, the sweep's executor and the error row of a lost episode all use it.
"""

from __future__ import annotations

import json
import math
import typing
from dataclasses import dataclass, field, fields
from typing import TYPE_CHECKING, Any, Literal, Protocol

from harness.pick.terms import ROBUSTNESS_LEVELS_G, VALIDITY_REASONS

if TYPE_CHECKING:
    from harness.config import TaskConfig

Dtype = Literal["str", "int", "float", "bool"]
PARAM_PREFIX = "param."
FILTER_OUTCOMES: tuple[str, ...] = ("ok", "fallback", "filter_empty")
# ``VALIDITY_REASONS`` (the validity causes in the order the phase meets them, then ``not_run``)
# and ``ROBUSTNESS_LEVELS_G`` (the tug levels) come from the verdict terms' table
# (``harness.pick.terms``).
__all__ = [
    "FILTER_OUTCOMES",
    "IDENTITY_COLUMNS",
    "KEY_COLUMNS",
    "PARAM_PREFIX",
    "ROBUSTNESS_LEVELS_G",
    "SCHEMA",
    "VALIDITY_REASONS",
    "Column",
    "EpisodeIdentity",
    "EpisodeRow",
    "empty_row",
    "identity_columns",
    "param_columns",
]
KEY_COLUMNS: tuple[str, ...] = ("task", "robot", "arm", "object")


def _doc(description: str, null: Any = None) -> dict[str, Any]:
    """Field metadata: the column's meaning and, when not the dtype's, its null value."""
    return {"description": description, "null": null}


@dataclass(frozen=True, kw_only=True)
class EpisodeRow:
    """The fixed columns of an episode's row, in column order.

    Fields without a default are set by every episode (identity, configuration, versions); the
    measured ones start at their default. The last three are added by the sweep executors and
    are not written while ``None``.
    """

    # Identity
    episode_id: str = field(metadata=_doc("deterministic id: hash of (task, point, episode index)"))
    run: str = field(metadata=_doc("run / sweep name"))
    point_id: int = field(metadata=_doc("index of the sweep point", -1))
    point: str = field(metadata=_doc("JSON of the swept parameter values of the point", "{}"))
    task: str = field(metadata=_doc("task name"))
    robot: str = field(metadata=_doc("robot name"))
    arm: str = field(metadata=_doc("arm used (left | right)"))
    object: str = field(metadata=_doc("name of the picked object"))
    seed: int = field(metadata=_doc("seed of the episode's random generator", -1))
    episode_index: int = field(metadata=_doc("index of the episode within its point", -1))
    # Configuration
    semantics: str = field(metadata=_doc("reference | strict"))
    test_mode: str = field(metadata=_doc("feasibility test: forward | ik"))
    timing: str = field(metadata=_doc("transport timing: toppra | ruckig"))
    filter_x_dir: str = field(metadata=_doc("reference filter as JSON, '' when unset"))
    filter_y_dir: str = field(metadata=_doc("reference filter as JSON, '' when unset"))
    filter_z_dir: str = field(metadata=_doc("reference filter as JSON, '' when unset"))
    approach_filter: str = field(
        metadata=_doc("robot-neutral approach-axis filter as JSON, '' when unset")
    )
    facing_filter: str = field(
        metadata=_doc("robot-neutral facing-axis filter as JSON, '' when unset")
    )
    direction_to_obj: str = field(metadata=_doc("left | right | '' when unset"))
    pre_grasp_offset: float = field(metadata=_doc("pre-grasp distance along the approach axis (m)"))
    post_grasp_offset: float = field(
        default=math.nan, metadata=_doc("lift height drawn for this episode (m)")
    )
    # Candidates
    n_total: int = field(
        default=0, metadata=_doc("grasp poses considered (grasps x symmetric flips)")
    )
    n_passed_filter: int = field(
        default=0, metadata=_doc("poses that passed the direction filters")
    )
    n_feasible: int = field(
        default=0, metadata=_doc("candidates found feasible by the feasibility test")
    )
    n_tested: int = field(default=0, metadata=_doc("candidates run through the feasibility test"))
    candidate_failures: str = field(
        default="{}",
        metadata=_doc(
            "JSON object: distinct tested candidates that failed the feasibility test, per stage "
            '(ik_pregrasp, ik_grasp, transport, approach, lift, return), e.g. {"ik_pregrasp": 12}; '
            "with n_feasible it sums to the distinct candidates tested",
            "{}",
        ),
    )
    filter_outcome: str = field(default="", metadata=_doc("ok | fallback | filter_empty"))
    chosen_index: int = field(
        default=-1, metadata=_doc("index of the chosen grasp pose, -1 for none", -1)
    )
    chosen_score: float = field(
        default=math.nan, metadata=_doc("grasp score of the chosen candidate")
    )
    approach_angle_deg: float = field(
        default=math.nan, metadata=_doc("angle of the chosen approach axis from straight down")
    )
    # Timing
    ik_time_s: float = field(default=0.0, metadata=_doc("wall time spent in IK (s)"))
    plan_time_s: float = field(
        default=0.0, metadata=_doc("wall time spent planning and timing (s)")
    )
    traj_duration_s: float = field(
        default=0.0, metadata=_doc("duration of the executed trajectory (s)")
    )
    sim_time_s: float = field(default=0.0, metadata=_doc("simulated time (s)"))
    sim_steps: int = field(default=0, metadata=_doc("MuJoCo steps taken"))
    wall_time_s: float = field(default=0.0, metadata=_doc("wall time of the whole episode (s)"))
    # Physics
    finger_force_left_n: float = field(
        default=math.nan, metadata=_doc("normal force on the left finger after closing (N)")
    )
    finger_force_right_n: float = field(
        default=math.nan, metadata=_doc("normal force on the right finger after closing (N)")
    )
    grip_force_limit_n: float = field(
        default=math.nan, metadata=_doc("the gripper's grasp force limit per pad (N)")
    )
    gripper_variant: str = field(
        default="", metadata=_doc("the robot.yaml gripper variant the episode ran with")
    )
    lift_height_m: float = field(default=math.nan, metadata=_doc("object z rise over the lift (m)"))
    slip_m: float = field(
        default=math.nan,
        metadata=_doc("object motion relative to the gripper during the hold (m)"),
    )
    max_joint_vel: float = field(
        default=math.nan, metadata=_doc("peak |joint velocity| (rad/s or m/s)")
    )
    max_object_vel: float = field(default=math.nan, metadata=_doc("peak object speed (m/s)"))
    tcp_grasp_error_m: float = field(
        default=math.nan,
        metadata=_doc("executed vs planned TCP at grasp (m), NaN if not reached"),
    )
    speed_scale: float = field(
        default=math.nan,
        metadata=_doc(
            "fraction of the joint limits the plans were timed at (pick.speed_scale; 0.3 = "
            "the reference's pace)"
        ),
    )
    planning_world: str = field(
        default="",
        metadata=_doc(
            "the planning-world rule: reference (target out, attached for the lift, only the "
            "planned arm) or strict (everything, the table with a clearance)"
        ),
    )
    object_friction: float = field(
        default=math.nan,
        metadata=_doc(
            "sliding friction of the target's contacts with the pads and the table (the "
            "object's friction: the task's, else its USD physics material's, else object.yaml "
            "or 1.0; docs/config.md, Friction)"
        ),
    )
    object_mass_kg: float = field(
        default=math.nan,
        metadata=_doc(
            "mass of the picked object (kg): the task's, else its USD's physics:mass "
            "(0.5 on the reference objects), else object.yaml or 0.1"
        ),
    )
    # Verdict
    success: bool = field(default=False, metadata=_doc("the pick succeeded under its semantics"))
    failure_reason: str = field(
        default="", metadata=_doc("first failure cause (FAILURE_REASONS), '' on success")
    )
    error_message: str = field(default="", metadata=_doc("message of an error or of the failure"))
    # Validity (harness.pick.validity): after the reference verdict; see docs/semantics.md
    valid: bool = field(
        default=False,
        metadata=_doc("the grasp really holds: no table penetration, two fingers, hold, tug"),
    )
    invalid_reason: str = field(
        default="",
        metadata=_doc("first validity cause (VALIDITY_REASONS); '' when valid or validity is off"),
    )
    robustness_g: float = field(
        default=math.nan,
        metadata=_doc("largest tug (x g x mass) survived in all six directions, 0 for none"),
    )
    hold_slip_m: float = field(
        default=math.nan,
        metadata=_doc(
            "validity: drift of the object origin relative to the TCP from the closing to the "
            "end of the hold (m)"
        ),
    )
    hold_rotation_rad: float = field(
        default=math.nan,
        metadata=_doc(
            "validity: rotation of the object relative to the TCP from the closing to the end "
            "of the hold (rad)"
        ),
    )
    min_finger_force_n: float = field(
        default=math.nan,
        metadata=_doc("smaller finger normal force on the object after the validity hold (N)"),
    )
    table_penetration_m: float = field(
        default=math.nan,
        metadata=_doc(
            "deepest any moving robot collision geom went into the table slab during the motion "
            "(m, MuJoCo signed distance)"
        ),
    )
    table_replay: str = field(
        default="",
        metadata=_doc(
            "the same plan executed again with the table physical, where the task makes "
            "robot-table contact non-physical and a robot geom went below the table top: "
            "held (valid), the cause it failed with, or '' when no replay ran "
            "(harness.episode.table_verdict)"
        ),
    )
    # Location (harness.episode.location): where the object stood, where the episode failed
    object_x_m: float = field(
        default=math.nan, metadata=_doc("object x at reset in the arm base frame (m, forward)")
    )
    object_y_m: float = field(
        default=math.nan, metadata=_doc("object y at reset in the arm base frame (m, left)")
    )
    object_z_m: float = field(
        default=math.nan, metadata=_doc("object z at reset in the arm base frame (m, up)")
    )
    object_yaw_deg: float = field(
        default=math.nan, metadata=_doc("object yaw at reset about the arm base z (degrees)")
    )
    object_distance_m: float = field(
        default=math.nan,
        metadata=_doc("horizontal distance of the object at reset from the arm base (m)"),
    )
    failure_stage: str = field(
        default="",
        metadata=_doc(
            "where the episode failed: settle, warmup, filter, feasibility:<stage>, "
            "plan:<stage>, execute:<command>; a handover's earlier phases prefix theirs with "
            "first_pick: or goto_pose:; '' on success (harness.episode.location)"
        ),
    )
    collision_a: str = field(
        default="", metadata=_doc("first body of the colliding pair that failed it, '' if none")
    )
    collision_b: str = field(
        default="", metadata=_doc("second body of the colliding pair that failed it, '' if none")
    )
    limit_joint: str = field(
        default="",
        metadata=_doc(
            "an unreachable target's best IK attempt: the joint at a position limit there, "
            "as name:lower / name:upper; '' if none (or not a reach failure)"
        ),
    )
    ik_residual_mm: float = field(
        default=math.nan,
        metadata=_doc("an unreachable target's best IK position residual (mm); NaN otherwise"),
    )
    reach_limit: str = field(
        default="",
        metadata=_doc(
            "what limits a plan failure's reach, from the best IK attempt's final state: "
            "joint_limit, lift_height (reached with the held lift free), collision, "
            "beyond_reach (the arm stretched towards a target farther than it got), "
            "unconverged; '' if not a reach or collision failure (harness.planning.reach)"
        ),
    )
    # A handover's second pick (harness.episode.handover); NaN for every other pick
    goto_error_mm: float = field(
        default=math.nan,
        metadata=_doc(
            "handover: the first arm's end-effector distance from its goto goal after the goto "
            "(mm; the reference's goto passes within 5 mm or 0.087 rad)"
        ),
    )
    goto_error_rad: float = field(
        default=math.nan,
        metadata=_doc("handover: the same end effector's angle from the goto goal (rad)"),
    )
    first_gripper_force_n: float = field(
        default=math.nan,
        metadata=_doc(
            "handover: the larger finger force of the opened first gripper on the object after "
            "the release (N; valid needs 0, harness.pick.release)"
        ),
    )
    harness_version: str = field(metadata=_doc("pick-harness version"))
    mujoco_version: str = field(metadata=_doc("MuJoCo version"))
    # Added by the sweep executors
    worker_peak_rss_mb: float | None = field(
        default=None, metadata=_doc("peak memory of the worker process (MiB)")
    )
    recording: str | None = field(
        default=None, metadata=_doc("episode recording (.rrd) relative to the run directory")
    )
    recording_error: str | None = field(
        default=None, metadata=_doc("why the episode recording could not be written")
    )
    config_sha256: str | None = field(
        default=None,
        metadata=_doc(
            "sha256 of the run's sweep.yaml body when the row was stored (--resume "
            "refuses rows of another configuration)"
        ),
    )

    def as_dict(self) -> dict[str, Any]:
        """The row's columns in order; optional columns (default ``None``) only once set."""
        out: dict[str, Any] = {}
        for column in fields(self):
            value = getattr(self, column.name)
            if value is None and column.default is None:
                continue
            out[column.name] = value
        return out


# --------------------------------------------------------------------------------------------
# Identity


class EpisodeIdentity(Protocol):
    """What names an episode (``harness.episode.spec.EpisodeSpec`` has it)."""

    @property
    def task(self) -> TaskConfig: ...
    @property
    def seed(self) -> int: ...
    @property
    def episode_index(self) -> int: ...
    @property
    def point_id(self) -> int: ...
    @property
    def point(self) -> dict[str, Any]: ...
    @property
    def run(self) -> str: ...
    @property
    def resolved_id(self) -> str: ...
    @property
    def resolved_task_name(self) -> str: ...


IDENTITY_COLUMNS: tuple[str, ...] = (
    "episode_id",
    "run",
    "point_id",
    "point",
    "task",
    "robot",
    "arm",
    "object",
    "seed",
    "episode_index",
)


def identity_columns(spec: EpisodeIdentity) -> dict[str, Any]:
    """The identity columns of an episode's row (``IDENTITY_COLUMNS``), then its ``param.*``.

    Non-scalar parameter values (lists such as ``["downward", 140]``) are written as JSON.
    """
    task = spec.task
    columns: dict[str, Any] = {
        "episode_id": spec.resolved_id,
        "run": spec.run,
        "point_id": spec.point_id,
        "point": json.dumps(spec.point, sort_keys=True, default=str),
        "task": spec.resolved_task_name,
        "robot": task.robot,
        "arm": task.arm,
        "object": task.target_object.name,
        "seed": spec.seed,
        "episode_index": spec.episode_index,
    }
    for key, value in spec.point.items():
        columns[f"{PARAM_PREFIX}{key}"] = (
            value if isinstance(value, (int, float, str, bool)) else json.dumps(value)
        )
    return columns


# --------------------------------------------------------------------------------------------
# Schema


@dataclass(frozen=True)
class Column:
    """One column of the episode row: its type, the value used when a row lacks it, meaning."""

    name: str
    dtype: Dtype
    description: str
    null: Any = None

    @property
    def null_value(self) -> Any:
        if self.null is not None:
            return self.null
        return {"str": "", "int": 0, "float": math.nan, "bool": False}[self.dtype]


_DTYPES: dict[Any, Dtype] = {str: "str", int: "int", float: "float", bool: "bool"}


def _dtype(annotation: Any) -> Dtype:
    """``float`` -> ``"float"``; an optional column (``str | None``) has its value's dtype."""
    kinds = typing.get_args(annotation) or (annotation,)
    return _DTYPES[next(kind for kind in kinds if kind is not type(None))]


def _schema() -> dict[str, Column]:
    hints = typing.get_type_hints(EpisodeRow)
    schema: dict[str, Column] = {}
    for column in fields(EpisodeRow):
        schema[column.name] = Column(
            column.name,
            _dtype(hints[column.name]),
            column.metadata["description"],
            column.metadata["null"],
        )
    return schema


SCHEMA: dict[str, Column] = _schema()


def param_columns(columns: Any) -> list[str]:
    """The ``param.*`` columns among ``columns``, in their order."""
    return [str(c) for c in columns if str(c).startswith(PARAM_PREFIX)]


def empty_row() -> dict[str, Any]:
    """A row with every schema column at its null value."""
    return {name: column.null_value for name, column in SCHEMA.items()}
