"""What one pick execution measured and concluded (``PickOutcome``).

Its own module so that the verdict terms (``harness.pick.verdict``) read the measurements
without importing the control loop that fills them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from harness.failures import FailureReason
from harness.pick.recorder import ExecutionTrace


@dataclass
class PickOutcome:
    """What the execution measured and concluded."""

    success: bool = False
    failure_reason: FailureReason = ""
    message: str = ""
    sim_time_s: float = 0.0
    sim_steps: int = 0
    control_steps: int = 0
    finger_force_left_n: float = float("nan")  # after closing
    finger_force_right_n: float = float("nan")
    lift_height_m: float = float("nan")
    slip_m: float = float("nan")
    max_joint_vel: float = 0.0  # peak over the execution
    max_object_vel: float = 0.0  # peak object speed over the execution
    verdict_joint_speed: float = float("nan")  # at the verdict (the reference's check)
    verdict_object_speed: float = float("nan")
    verdict_forces: tuple[float, float] = (float("nan"), float("nan"))
    tcp_grasp_error_m: float = float("nan")
    object_z_before: float = float("nan")
    object_z_after: float = float("nan")
    contact_during_close: bool = False
    collisions: list[str] = field(default_factory=list)
    trace: ExecutionTrace | None = None
