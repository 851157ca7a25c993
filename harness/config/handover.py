"""What runs before a handover's second pick: the first arm's pick and its ``goto__pose``.

InternDataEngine's handover tasks (e.g. ``workflows/simbox/core/configs/tasks/long_horizon/
split_aloha/handover/lr/bowl.yaml`` 153-195, InternDataEngine commit c4fa389) run, per episode:
the left arm's ``pick`` (with a 0.1 m post-grasp lift), then its ``goto__pose`` (the held object
moved to a pose in the left arm's base frame), then the right arm's ``pick`` of the same object
in mid-air (no lift), then both grippers' ``gripper__action`` (right closes, left opens) and a
place. ``TaskConfig.handover`` (this model) carries the first two skills, so the second pick's
episode can start from the state they leave (``harness.episode.handover``).

``GotoPoseConfig`` holds every key of the reference's ``Goto_Pose`` skill
(``workflows/simbox/core/skills/goto_pose.py``) with its defaults; ``interp_nums >= 2`` (the
interpolated variant) is not modelled and is refused.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BeforeValidator, Field, model_validator

from harness.config.errors import KeyedValueError
from harness.config.pick import PickConfig
from harness.config.values import FiniteFloat, StrictModel

# The goto skill's direction words (goto_pose.py 150-175: the pick's four plus sideways).
GotoDirection = Literal["forward", "backward", "leftward", "rightward", "upward", "downward"]


def _as_tuple(value: object) -> object:
    return tuple(value) if isinstance(value, list) else value


GotoFilter = Annotated[
    tuple[GotoDirection, FiniteFloat] | tuple[GotoDirection, FiniteFloat, FiniteFloat] | None,
    BeforeValidator(_as_tuple),
]
Axis3 = tuple[FiniteFloat, FiniteFloat, FiniteFloat]


class GotoPoseConfig(StrictModel):
    """The reference ``goto__pose`` skill's keys (goto_pose.py), reference defaults."""

    name: str = "goto__pose"
    objects: list[str] = Field(default_factory=list)
    position: Axis3 = Field(description="Target position in the arm base frame (m).")
    position_constraint: Literal["gripper", "object"] = "gripper"
    gripper_state: Literal[1, -1] = 1
    quaternion: tuple[FiniteFloat, FiniteFloat, FiniteFloat, FiniteFloat] | None = None
    euler: Axis3 | None = None
    align_obj_axis: Axis3 | None = None
    align_ref_axis: Axis3 | None = None
    align_obj_tol: FiniteFloat | None = Field(default=None, gt=0.0, le=180.0)
    filter_x_dir: GotoFilter = None
    filter_y_dir: GotoFilter = None
    filter_z_dir: GotoFilter = None
    max_noise_m: FiniteFloat = Field(default=0.0, ge=0.0, le=1.0)
    max_noise_deg: FiniteFloat = Field(default=0.0, ge=0.0, le=180.0)
    interp_nums: int = Field(default=1, ge=0, le=1_000)
    test_mode: Literal["forward", "ik"] = "forward"
    frame: str = "robot"  # read by the reference, never used (goto_pose.py 34)
    ignore_substring: list[str] = Field(default_factory=list)

    @model_validator(mode="after")
    def _orientation_source(self) -> GotoPoseConfig:
        if self.interp_nums >= 2:
            raise KeyedValueError(
                "interp_nums", "interp_nums >= 2 (an interpolated goto) is not modelled; use 1"
            )
        fixed = self.quaternion is not None or self.euler is not None
        if fixed:
            return self
        # Without quaternion/euler the reference reads these three keys unconditionally
        # (goto_pose.py 83-85: a KeyError there).
        for key in ("align_obj_axis", "align_ref_axis", "align_obj_tol"):
            if getattr(self, key) is None:
                raise KeyedValueError(
                    key, f"{key} is required when neither quaternion nor euler is given"
                )
        if self.position_constraint == "object" and not self.objects:
            raise KeyedValueError(
                "objects", "position_constraint: object needs objects (the held object)"
            )
        return self


class HandoverPrelude(StrictModel):
    """The skills a handover's second pick starts after: the first arm's pick and goto."""

    arm: Literal["left", "right"] = Field(description="The arm that picks first and holds.")
    home: list[FiniteFloat] | None = None
    home_noise_std: list[Annotated[float, Field(ge=0.0, allow_inf_nan=False)]] | None = None
    pick: PickConfig = Field(default_factory=PickConfig)
    goto_pose: GotoPoseConfig | None = None
    first_key: str = ""  # where the first pick is in its InternData file (rows, messages)
    goto_key: str = ""
