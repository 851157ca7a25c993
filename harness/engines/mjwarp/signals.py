"""What a batched engine records per world and control step, and where the validity window is.

One row of ``SIGNALS`` floats per world per control step, taken after the step's last physics
chunk (where the CPU executor reads its inputs): the finger normal forces on the target object,
the object's position and linear velocity, the robot's largest joint speed, the deepest robot
robot geom's depth inside the table slab beyond its depth at the start (the measure of
``harness.pick.penetration``, bounded on the device by the slab's separating axes:
``kernels.slab_depth``), the largest |qvel| and a non-finite flag (the instability
test), the end-effector and TCP poses and the object's orientation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from harness.pick.validity import REST_SPEED, REST_WAIT_S
from harness.sim.scene import MAX_FALL_M, MAX_REACH_M, MAX_SANE_SPEED

FORCE_LEFT, FORCE_RIGHT = 0, 1
OBJ_POS = slice(2, 5)
OBJ_VEL = slice(5, 8)
JOINT_SPEED = 8
PENETRATION = 9
MAX_QVEL = 10
NONFINITE = 11
EE_POS = slice(12, 15)
EE_MAT = slice(15, 24)
TCP_POS = slice(24, 27)
TCP_MAT = slice(27, 36)
OBJ_MAT = slice(36, 45)
SIGNALS = 45


def rest_steps(control_dt: float) -> int:
    """The most control steps the validity phase waits for the object to come to rest."""
    return math.ceil((REST_WAIT_S - 1e-9) / control_dt)


def hold_steps(hold_time: float, control_dt: float) -> int:
    """Control steps of the validity hold."""
    return max(0, math.ceil(hold_time / control_dt - 1e-9))


def window_steps(hold_time: float, control_dt: float) -> int:
    """Control steps after the planned motion that a batched engine always runs (rest at most,
    then the hold): the physics is the same whatever the rest lasted (every servo holds)."""
    return rest_steps(control_dt) + hold_steps(hold_time, control_dt)


def unstable_reason(row: np.ndarray) -> str | None:
    """The CPU scene's instability test (``Scene.unstable``) on one signal row; MJWarp keeps no
    per-world warning counters, so the bad-acceleration test is not made (the full-buffer test
    is: ``steps.BufferUse``)."""
    if row[NONFINITE] > 0 or not np.all(np.isfinite(row)):
        return "NaN in the simulation state"
    if row[MAX_QVEL] > MAX_SANE_SPEED:
        return f"a velocity of {row[MAX_QVEL]:.3g} (rad or m)/s: the integration diverged"
    x, y, z = (float(v) for v in row[OBJ_POS])
    if z < -MAX_FALL_M or max(abs(x), abs(y), z) > MAX_REACH_M:
        return f"the target object left the scene at ({x:.3g}, {y:.3g}, {z:.3g}) m"
    return None


def unstable_rows(rows: np.ndarray) -> np.ndarray:
    """``unstable_reason(row) is not None`` for each row of ``rows``, in one pass (the batch
    judge's hot path): the same tests with the same precision (the speed compared in the row's
    float32, the position in float64)."""
    nonfinite = (rows[:, NONFINITE] > 0) | ~np.all(np.isfinite(rows), axis=1)
    with np.errstate(invalid="ignore"):
        fast = rows[:, MAX_QVEL] > np.float32(MAX_SANE_SPEED)
        pos = rows[:, OBJ_POS].astype(np.float64)
        reach = np.maximum(np.maximum(np.abs(pos[:, 0]), np.abs(pos[:, 1])), pos[:, 2])
        escaped = (pos[:, 2] < -MAX_FALL_M) | (reach > MAX_REACH_M)
    return nonfinite | fast | escaped


def running_peak(start: float, values: np.ndarray) -> float:
    """``max(start, float(v))`` folded over ``values`` as the CPU loop folds it (a NaN never
    becomes the peak)."""
    if values.size == 0:
        return start
    return float(np.fmax.reduce(values.astype(np.float64), initial=start))


def object_in_tcp(row: np.ndarray) -> np.ndarray:
    """The object's position in the TCP frame."""
    R = row[TCP_MAT].reshape(3, 3)
    return R.T @ (row[OBJ_POS] - row[TCP_POS])


def object_pose_in_tcp(row: np.ndarray) -> np.ndarray:
    """The object's pose in the TCP frame (4 x 4; ``PickExecutor.object_pose_in_tcp``)."""
    R_tcp = row[TCP_MAT].reshape(3, 3)
    T = np.eye(4)
    T[:3, :3] = R_tcp.T @ row[OBJ_MAT].reshape(3, 3)
    T[:3, 3] = R_tcp.T @ (row[OBJ_POS] - row[TCP_POS])
    return T


def object_speed(row: np.ndarray) -> float:
    return float(np.linalg.norm(row[OBJ_VEL]))


@dataclass(frozen=True)
class HoldWindow:
    """Where, in the signal rows after the motion, the rest ended and the hold ended.

    ``rest_end`` and ``hold_end`` index the rows of the whole run; ``rest_end`` is the row the
    hold's slip is measured from (the motion's last row when no rest was needed)."""

    rest_end: int
    hold_end: int


def hold_window(steps: np.ndarray, motion_steps: int, hold_time: float, dt: float) -> HoldWindow:
    """The CPU phase's rest rule (``ValidityPhase.run``): hold while the object's speed is at or
    over ``REST_SPEED``, at most ``REST_WAIT_S``; then ``hold_time``."""
    row = motion_steps - 1
    for _ in range(rest_steps(dt)):
        if object_speed(steps[row]) < REST_SPEED:
            break
        row += 1
    return HoldWindow(row, row + hold_steps(hold_time, dt))
