"""The servo schedule of a pick execution: control step, servo chunks and setpoints.

The control loop runs once per control step (``control_dt``, the reference's 1/30 s); inside it
the position servos get new setpoints every few physics steps (a chunk of ~10 ms, stepped inside
MuJoCo with ``mj_step(m, d, n)``), sampled in advance from the timed trajectory with velocity
feed-forward ``ctrl = q + (kv / kp) * qd``.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from harness.planning.timing import Trajectory, gripper_trajectory
from harness.sim import ArmHandles

SERVO_CHUNK_S = 0.010  # servo setpoint period inside a control step


class ServoTiming:
    """Control step length, chunk sizes and the servo setpoints of one arm in one model."""

    def __init__(self, model: mujoco.MjModel, handles: ArmHandles, control_dt: float) -> None:
        self.timestep = float(model.opt.timestep)
        self.substeps = max(1, round(control_dt / self.timestep))
        self.control_dt = self.substeps * self.timestep
        chunks = max(1, math.ceil(self.control_dt / SERVO_CHUNK_S - 1e-9))
        chunks = min(chunks, self.substeps)
        sizes = np.full(chunks, self.substeps // chunks)
        sizes[: self.substeps % chunks] += 1
        self.chunk_sizes = [int(size) for size in sizes]
        self.chunk_ends = np.cumsum(self.chunk_sizes) * self.timestep
        # Velocity feed-forward kv / kp per active servo (position servos damp absolute speed).
        active = handles.active_actuators
        kp = model.actuator_gainprm[active, 0]
        kv = -model.actuator_biasprm[active, 2]
        self.feedforward = np.where(kp > 0, kv / np.maximum(kp, 1e-12), 0.0)
        self.ctrl_lower = model.actuator_ctrlrange[active, 0].copy()
        self.ctrl_upper = model.actuator_ctrlrange[active, 1].copy()

    def chunk_times(self, duration: float) -> np.ndarray:
        """The end time of every chunk of every control step covering ``duration`` s."""
        rows = math.ceil(duration / self.control_dt - 1e-9) + 1
        return (np.arange(rows)[:, None] * self.control_dt + self.chunk_ends[None, :]).reshape(-1)

    def arm_setpoints(self, trajectory: Trajectory) -> np.ndarray:
        """(rows, chunks, n) servo targets ``q + (kv/kp) qd`` for every chunk of the segment."""
        ts = self.chunk_times(trajectory.duration)
        q, qd, _ = trajectory.sample_many(ts)
        ctrl = np.clip(q + qd * self.feedforward, self.ctrl_lower, self.ctrl_upper)
        return ctrl.reshape(-1, len(self.chunk_sizes), q.shape[1])

    def gripper_setpoints(
        self, start: float, goal: float, final: float, finger_speed: float, change_steps: int
    ) -> np.ndarray:
        """(rows, chunks) gripper targets: a ramp to ``goal`` at the robot's finger speed, sped
        up if needed to finish within half of the closing window (``change_steps`` control
        steps), then one control step at ``final`` (the squeeze target of a force-controlled
        grasp, below the closed width: the servo then presses with its force limit wherever the
        fingers stopped; ``goal`` otherwise)."""
        window = 0.5 * change_steps * self.control_dt
        speed = max(finger_speed, abs(goal - start) / max(window, 1e-3))
        trajectory = gripper_trajectory(start, goal, speed)
        q, _, _ = trajectory.sample_many(self.chunk_times(trajectory.duration))
        rows = q[:, 0].reshape(-1, len(self.chunk_sizes))
        return np.vstack([rows, np.full((1, len(self.chunk_sizes)), final)])
