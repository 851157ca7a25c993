"""A handover's release: the first gripper opens once the second pick's verdict is taken.

In the reference's handover files the phase after the second pick closes the second gripper
and opens the first (``gripper__action`` with ``gripper_state: 1`` on the first arm,
tasks/long_horizon/split_aloha/handover/lr/bowl.yaml 196-206; gripper_action.py: the open
command held for ``wait_steps`` control steps, default 10). The second pick's validity phase
(``harness.pick.validity``) runs after this release, so its hold and tug judge the second
gripper alone; the opened first gripper must then carry no force on the object
(the validity term ``first_gripper_contact``, harness.pick.terms; chosen: an open hand still
under the object is a support, not a handover).
"""

from __future__ import annotations

from typing import Protocol

from harness.pick.servo import ServoTiming
from harness.sim import Scene

# gripper_action.py simple_generate_manip_cmds: the command repeated wait_steps (default 10)
# times; each pops on reaching its pose, so the opening takes at least that many steps.
RELEASE_STEPS = 10


class ReleaseHost(Protocol):
    """What the release needs of the executor that ran the second pick."""

    scene: Scene
    control_dt: float
    object_name: str

    def hold_step(self, label: str) -> None: ...

    def event(self, text: str) -> None: ...


def release_gripper(executor: ReleaseHost, arm: str) -> tuple[float, float]:
    """Open ``arm``'s gripper (a ramp at its finger speed within ``RELEASE_STEPS`` control
    steps, then held open for ``RELEASE_STEPS`` more), every other servo holding; returns the
    forces its fingers still exert on the object (N)."""
    scene = executor.scene
    handles = scene.arms[arm]
    spec = scene.robot.arm(arm)
    servo = ServoTiming(scene.model, handles, executor.control_dt)
    ctrl = scene.data.ctrl
    start = float(ctrl[handles.gripper_actuator])
    goal = spec.finger_open_position
    rows = servo.gripper_setpoints(start, goal, goal, spec.gripper.speed, 2 * RELEASE_STEPS)
    executor.event(f"handover: {arm} gripper opens")
    steps = max(RELEASE_STEPS, len(rows))
    for step in range(steps + RELEASE_STEPS):
        ctrl[handles.gripper_actuator] = rows[min(step, len(rows) - 1)][-1]
        executor.hold_step("handover:release")
    forces = scene.finger_forces(arm, executor.object_name)
    executor.event(f"handover: {arm} fingers on the object {forces[0]:.2f} / {forces[1]:.2f} N")
    return forces
