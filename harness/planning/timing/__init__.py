"""Time parameterisation of joint paths: TOPP-RA and Ruckig -> a ``Trajectory`` sampled by time.

Two methods, chosen per task by ``pick.timing`` (../shared/reference/libraries.md sections 4-5):

- **TOPP-RA** follows a geometric path through joint waypoints (a cubic spline over a
  chord-length path parameter, a straight line for two waypoints) as fast as the joint velocity
  and acceleration limits allow, starting and ending at rest. Jerk is unbounded (piecewise
  constant path acceleration).
- **Ruckig** computes jerk-limited rest-to-rest moves. With Phase synchronisation the path is the
  straight joint-space line between the two states. Offline Ruckig has no intermediate
  waypoints, so a waypoint list becomes a chain of rest-to-rest segments (it stops at every
  waypoint).

``speed_scale`` dilates time: velocity limits are multiplied by ``s``, accelerations by ``s**2``
and jerks by ``s**3``, so the same path is followed ``1/s`` times slower and every derivative
limit stays respected.

A ``Trajectory`` is a sequence of timed segments (transport, approach, lift, gripper moves, holds)
that the executor samples by time; ``Trajectory.concatenate`` plays several plans as one.
"""

from harness.planning.timing.errors import TimingError
from harness.planning.timing.inputs import DUPLICATE_TOLERANCE, TimingLimits
from harness.planning.timing.method import TimingMethod, plan_timing
from harness.planning.timing.ruckig_moves import (
    RuckigProfile,
    gripper_trajectory,
    ruckig_through,
    time_parameterize_ruckig,
)
from harness.planning.timing.toppra_path import (
    GRID_MAX_ERROR,
    GRID_MAX_POINTS,
    ConstAccelPathProfile,
    propose_grid,
    time_parameterize_toppra,
)
from harness.planning.timing.trajectory import (
    CONTINUITY_TOLERANCE,
    HoldProfile,
    Profile,
    Samples,
    Segment,
    Trajectory,
)

__all__ = [
    "CONTINUITY_TOLERANCE",
    "DUPLICATE_TOLERANCE",
    "GRID_MAX_ERROR",
    "GRID_MAX_POINTS",
    "ConstAccelPathProfile",
    "HoldProfile",
    "Profile",
    "RuckigProfile",
    "Samples",
    "Segment",
    "TimingError",
    "TimingLimits",
    "TimingMethod",
    "Trajectory",
    "gripper_trajectory",
    "plan_timing",
    "propose_grid",
    "ruckig_through",
    "time_parameterize_ruckig",
    "time_parameterize_toppra",
]
