"""The typed records the episode's stages return: each field is a column of the row.

A stage says what it found as one of these dataclasses (``harness.row.EpisodeRow`` names every
field; tests/test_episode_records.py keeps it so); ``merge_records`` is the one place they enter
the row, in the order the stages produced them. A field left ``None`` is not written (the row
keeps the value it had: the ``EpisodeRow`` default), which is how a record says "not measured"
for a column whose real value may be anything, NaN included.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any, ClassVar, Protocol

from harness.pick.outcome import ValidityColumns


class RowRecord(Protocol):
    """A dataclass whose fields are row columns."""

    __dataclass_fields__: ClassVar[dict[str, Any]]


@dataclass(frozen=True)
class SceneColumns:
    """The reset stage: facts of the scene the episode runs in."""

    object_friction: float
    object_mass_kg: float
    grip_force_limit_n: float
    gripper_variant: str
    speed_scale: float  # the pace the plans are timed at (pick.speed_scale)
    planning_world: str  # the planning-world rule (Semantics.planning_world)


@dataclass(frozen=True)
class CandidateColumns:
    """The candidates stage: how many poses, how many passed the filters, the lift drawn."""

    n_total: int
    n_passed_filter: int
    filter_outcome: str
    post_grasp_offset: float


@dataclass(frozen=True)
class TestedColumns:
    """The feasibility stage: what was tested and how it failed."""

    n_tested: int
    n_feasible: int
    candidate_failures: str


@dataclass(frozen=True)
class ChoiceColumns:
    """The feasibility stage: the candidate the episode executes."""

    chosen_index: int
    chosen_score: float
    approach_angle_deg: float


@dataclass(frozen=True)
class PlanTimeColumns:
    """Wall time of the planning (selection to timed plan); never shared between episodes."""

    plan_time_s: float
    ik_time_s: float


@dataclass(frozen=True)
class MotionColumns:
    """The execution plan stage: the timed motion."""

    traj_duration_s: float


@dataclass(frozen=True)
class ExecutionColumns:
    """The execution stage: what the simulation measured."""

    sim_time_s: float
    sim_steps: int
    finger_force_left_n: float
    finger_force_right_n: float
    lift_height_m: float
    slip_m: float
    max_joint_vel: float
    max_object_vel: float
    tcp_grasp_error_m: float


@dataclass(frozen=True)
class PlacementColumns:
    """The reset stage: the target object's pose at reset in the arm base frame
    (``harness.episode.location``)."""

    object_x_m: float
    object_y_m: float
    object_z_m: float
    object_yaw_deg: float
    object_distance_m: float


@dataclass(frozen=True)
class TableReplayColumns:
    """The table verdict's replay on a physical table (``harness.episode.table_verdict``)."""

    table_replay: str


@dataclass(frozen=True)
class FailureLocationColumns:
    """Where the episode stopped and which pair of bodies collided there
    (``harness.episode.location``)."""

    failure_stage: str
    collision_a: str
    collision_b: str
    limit_joint: str = ""
    ik_residual_mm: float | None = None
    reach_limit: str = ""


@dataclass(frozen=True)
class GotoColumns:
    """A handover's goto (``harness.episode.handover``): how far the first arm ended from the
    goal the reference's goto test judges (within 5 mm or 0.087 rad, goto_pose.py 264-272)."""

    goto_error_mm: float
    goto_error_rad: float


@dataclass(frozen=True)
class ReleaseColumns:
    """A handover's release after the second pick (``harness.pick.release``)."""

    first_gripper_force_n: float


@dataclass(frozen=True)
class EndColumns:
    """How the episode ended (the pipeline's own record)."""

    failure_reason: str
    error_message: str
    success: bool


@dataclass(frozen=True)
class WallTimeColumns:
    """Wall time of the whole episode."""

    wall_time_s: float


# Every record type a row is made of (the schema test walks these).
ROW_RECORDS: tuple[type, ...] = (
    SceneColumns,
    CandidateColumns,
    TestedColumns,
    ChoiceColumns,
    PlanTimeColumns,
    MotionColumns,
    ExecutionColumns,
    ValidityColumns,
    TableReplayColumns,
    PlacementColumns,
    FailureLocationColumns,
    GotoColumns,
    ReleaseColumns,
    EndColumns,
    WallTimeColumns,
)


def record_columns(record: RowRecord) -> dict[str, Any]:
    """The columns ``record`` writes: its fields, less those left ``None``."""
    values = {f.name: getattr(record, f.name) for f in fields(record)}
    return {name: value for name, value in values.items() if value is not None}


def merge_records(row: dict[str, Any], records: list[RowRecord] | tuple[RowRecord, ...]) -> None:
    """Write ``records`` into ``row`` in order (a later record wins a column)."""
    for record in records:
        row.update(record_columns(record))
