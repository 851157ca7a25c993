"""The gripper a task runs with: the robot.yaml default or a named variant, plus task overrides.

robot.yaml describes one gripper in each arm's block (``open_width``, ``closed_width``,
``gripper``), named by ``gripper_variant``; ``gripper_variants`` lists alternatives by the values
that differ (the Split ALOHA's reference 0.10 m jaw and the SDK's 0.07 m one). A task picks a
variant and may override grip physics (``robot: {name, gripper: {variant, force_limit, ...}}``);
:func:`resolve_arm` folds both into the arm spec every consumer reads.
"""

from __future__ import annotations

from typing import Any

from harness.config.task import GripperChoice
from harness.errors import HarnessError
from harness.robots.spec import GRIPPER_FIELDS, ArmSpec, RobotFile


def variant_name(spec: RobotFile, choice: GripperChoice | None) -> str:
    """The variant a task selects (the robot.yaml default when it names none)."""
    name = choice.variant if choice is not None and choice.variant else spec.gripper_variant
    if name not in spec.variant_names:
        raise HarnessError(
            f"robot {spec.name!r} has no gripper variant {name!r} "
            f"(variants: {', '.join(spec.variant_names)})"
        )
    return name


def resolve_arm(spec: RobotFile, arm: ArmSpec, choice: GripperChoice | None) -> ArmSpec:
    """``arm`` with the selected variant's widths and gripper values and the task overrides."""
    name = variant_name(spec, choice)
    values: dict[str, Any] = {}
    if name != spec.gripper_variant:
        variant = spec.gripper_variants[name]
        values = {
            k: v for k, v in variant.model_dump(exclude={"description"}).items() if v is not None
        }
    if choice is not None:
        values.update(choice.overrides())
    widths = {k: values.pop(k) for k in ("open_width", "closed_width") if k in values}
    gripper = arm.gripper.model_copy(
        update={k: v for k, v in values.items() if k in GRIPPER_FIELDS}
    )
    resolved = arm.model_copy(update={**widths, "gripper": gripper})
    if resolved.closed_width >= resolved.open_width:
        raise HarnessError(
            f"gripper variant {name!r}: closed_width {resolved.closed_width} must be below "
            f"open_width {resolved.open_width}"
        )
    return resolved
