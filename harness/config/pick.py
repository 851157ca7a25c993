"""The Pick block: every key of the reference Pick skill, plus the harness keys.

``PickConfig`` carries every key of the InternDataEngine Pick skill with the reference defaults
(docs/reference-pick-skill.md section 8), so a reference pick block pastes in unchanged,
plus the harness keys (``semantics``, ``approach_filter``, ``facing_filter``, ``timing``, the
strict-verdict thresholds).
"""

from __future__ import annotations

import math
from typing import Literal

from pydantic import Field, field_validator, model_validator
from pydantic.config import JsonDict

from harness.config.errors import KeyedValueError
from harness.config.filters import AxisFilter, FilterSpec, reversed_band_message
from harness.config.values import FiniteFloat, Probability, StrictModel

# The reference's pace: its controller plays one planner waypoint per physics step
# (template_controller.py ee_forward, ``cmd_idx += ds_ratio`` with ds_ratio 1), the planner
# interpolates at 0.01 s (template_controller.py _init_motion_gen, ``interpolation_dt=0.01``)
# and the physics steps at 1/30 s (robot and task configs): plans play at 0.01 x 30 = 0.3 of
# their timed speed. cuRobo times its plans at the robot's limits (time_dilation_factor 1.0).
REFERENCE_SPEED_SCALE = 0.3

# The marker of a pick key that only the harness reads (InternDataEngine's Pick skill does not):
# ``harness_only_keys`` lists them; ``harness tune`` leaves them out of its paste-ready block.
NOT_IN_REFERENCE: JsonDict = {"harness_only": True}


class PickConfig(StrictModel):
    """Every key of the reference Pick skill (reference defaults), plus the harness keys."""

    # Reference keys (docs/reference-pick-skill.md section 8).
    objects: list[str] | None = Field(
        default=None,
        min_length=1,
        description="Target object names; the first is picked (default: the task's first).",
    )
    npy_name: str = Field(default="Aligned_grasp_sparse.npy", min_length=1)
    grasp_scale: FiniteFloat = Field(default=1.0, gt=0.0)
    tcp_offset: FiniteFloat | None = Field(default=None, gt=0.0, lt=0.5)
    constraints: tuple[Literal["x", "y", "z"], Probability, Probability] | None = None
    final_gripper_state: Literal[1, -1] = -1
    fixed_orientation: tuple[FiniteFloat, FiniteFloat, FiniteFloat, FiniteFloat] | None = None
    filter_x_dir: FilterSpec = None
    filter_y_dir: FilterSpec = None
    filter_z_dir: FilterSpec = None
    direction_to_obj: Literal["left", "right"] | None = None
    pre_grasp_offset: FiniteFloat = Field(default=0.1, ge=-0.5, le=0.5)
    pre_grasp_hold_vec_weight: (
        tuple[FiniteFloat, FiniteFloat, FiniteFloat, FiniteFloat, FiniteFloat, FiniteFloat] | None
    ) = None
    gripper_change_steps: int = Field(default=40, ge=1, le=10_000)
    post_grasp_offset_min: FiniteFloat = Field(default=0.05, ge=0.0, le=1.0)
    post_grasp_offset_max: FiniteFloat = Field(default=0.05, ge=0.0, le=1.0)
    return_to_pregrasp: bool = False
    lift_th: FiniteFloat = Field(default=0.0, ge=0.0, le=1.0)
    ignore_substring: list[str] = Field(default_factory=list)
    robot_ignore_substring: list[str] | None = Field(
        default=None,
        json_schema_extra=NOT_IN_REFERENCE,
        description="The robot's planning-world ignore list (an InternData robot's "
        "ignore_substring): under reference it REPLACES the controllers' default list "
        "(template_controller.py __init__); None keeps the default.",
    )
    test_mode: Literal["forward", "ik"] = "forward"
    t_eps: FiniteFloat = Field(default=1e-3, gt=0.0)
    o_eps: FiniteFloat = Field(default=5e-3, gt=0.0)
    process_valid: bool = True

    # Keys that appear in reference configs but are never read there; accepted and ignored.
    name: Literal["pick"] | None = None
    close_wait_steps: int | None = None
    update_pose_cost_metric_none: bool | None = None
    constrain_grasp_approach: bool | None = None

    # Harness keys, not InternDataEngine's: each marked ``NOT_IN_REFERENCE`` (harness_only_keys).
    semantics: Literal["reference", "strict"] = Field(
        default="reference", json_schema_extra=NOT_IN_REFERENCE
    )
    approach_filter: FilterSpec = Field(
        default=None,
        json_schema_extra=NOT_IN_REFERENCE,
        description="Robot-neutral filter on the approach axis (robot.yaml approach_axis).",
    )
    facing_filter: FilterSpec = Field(
        default=None,
        json_schema_extra=NOT_IN_REFERENCE,
        description="Robot-neutral filter on the facing axis (robot.yaml facing_axis).",
    )
    strict_sampling: bool = Field(
        default=False,
        json_schema_extra=NOT_IN_REFERENCE,
        description="strict: order candidates by weighted sampling without replacement "
        "(weights 1/score) instead of plain score order.",
    )
    timing: Literal["toppra", "ruckig"] = Field(
        default="toppra", json_schema_extra=NOT_IN_REFERENCE
    )
    lift_path: Literal["joint", "cartesian"] | None = Field(
        default=None,
        json_schema_extra=NOT_IN_REFERENCE,
        description="How the lift is planned: joint (a joint-space plan to the lift pose, as "
        "the reference's cuRobo plan_single; 10 IK seeds per plan, 6 plans, 5 mm / 0.05 rad) "
        "or cartesian (the straight line up). Default: joint under reference, cartesian under "
        "strict.",
    )
    speed_scale: FiniteFloat = Field(
        default=REFERENCE_SPEED_SCALE,
        gt=0.0,
        le=1.0,
        json_schema_extra=NOT_IN_REFERENCE,
        description="Fraction of the joint limits the plans are timed at. Default: the "
        "reference's pace, one 0.01 s planner waypoint per 1/30 s physics step.",
    )
    validity: bool = Field(
        default=True,
        json_schema_extra=NOT_IN_REFERENCE,
        description="on: after the reference verdict, the validity phase (penetration, two "
        "fingers, hold, tug) fills the row's validity columns; off skips it (strict always "
        "runs it: it is strict's verdict).",
    )
    min_finger_force: FiniteFloat = Field(
        default=0.5,
        json_schema_extra=NOT_IN_REFERENCE,
        ge=0.0,
        description="validity and strict: normal force each finger must carry (N).",
    )
    hold_time: FiniteFloat = Field(
        default=1.0,
        json_schema_extra=NOT_IN_REFERENCE,
        ge=0.0,
        le=60.0,
        description="validity and strict: hold at the lifted pose (s).",
    )
    max_slip: FiniteFloat = Field(
        default=0.005,
        json_schema_extra=NOT_IN_REFERENCE,
        gt=0.0,
        description="validity and strict: object drift relative to the TCP allowed from the "
        "closing to the end of the hold (m).",
    )
    max_first_gripper_force: FiniteFloat = Field(
        default=0.0,
        json_schema_extra=NOT_IN_REFERENCE,
        ge=0.0,
        description="validity, a handover's second pick: the force the opened first gripper "
        "may still exert on the object after the release (N; chosen, no public source: any "
        "force is a support, not a handover).",
    )
    max_slip_rotation: FiniteFloat = Field(
        default=0.1,
        json_schema_extra=NOT_IN_REFERENCE,
        gt=0.0,
        description="validity and strict: object rotation relative to the TCP allowed from "
        "the closing to the end of the hold (rad; chosen, no public source).",
    )

    @field_validator("validity", mode="before")
    @classmethod
    def _on_off(cls, value: object) -> object:
        """``on`` / ``off`` (YAML 1.1 reads them as booleans already; strings from ``--set``)."""
        if isinstance(value, str) and value.strip().lower() in ("on", "off"):
            return value.strip().lower() == "on"
        return value

    @field_validator("fixed_orientation")
    @classmethod
    def _unit_quaternion(cls, q: tuple[float, ...] | None) -> tuple[float, ...] | None:
        if q is None:
            return q
        norm = math.sqrt(sum(c * c for c in q))
        if abs(norm - 1.0) > 1e-3:
            raise ValueError(f"fixed_orientation must be a unit wxyz quaternion (norm {norm:.4g})")
        return q

    @model_validator(mode="after")
    def _cross_checks(self) -> PickConfig:
        if self.post_grasp_offset_min > self.post_grasp_offset_max:
            given_max = "post_grasp_offset_max" in self.model_fields_set
            raise KeyedValueError(
                "post_grasp_offset_max" if given_max else "post_grasp_offset_min",
                f"post_grasp_offset_min ({self.post_grasp_offset_min}) must be <= "
                f"post_grasp_offset_max ({self.post_grasp_offset_max})",
            )
        if self.constraints is not None and self.constraints[1] > self.constraints[2]:
            raise KeyedValueError(
                "constraints",
                f"constraints [axis, rmin, rmax] needs rmin <= rmax, got {list(self.constraints)}",
            )
        if self.semantics == "strict":
            for key in (
                "filter_x_dir",
                "filter_y_dir",
                "filter_z_dir",
                "approach_filter",
                "facing_filter",
            ):
                spec: AxisFilter | None = getattr(self, key)
                if spec is not None and spec.never_passes():
                    raise KeyedValueError(key, reversed_band_message(key, spec))
        return self

    def axis_filters(self) -> dict[str, AxisFilter]:
        """The explicit per-axis filters that are set, keyed ``filter_x_dir`` etc."""
        return {
            key: spec
            for key in ("filter_x_dir", "filter_y_dir", "filter_z_dir")
            if (spec := getattr(self, key)) is not None
        }


def harness_only_keys() -> frozenset[str]:
    """The ``PickConfig`` keys marked ``NOT_IN_REFERENCE`` (not the reference's)."""
    return frozenset(
        name
        for name, info in PickConfig.model_fields.items()
        if isinstance(info.json_schema_extra, dict) and info.json_schema_extra.get("harness_only")
    )
