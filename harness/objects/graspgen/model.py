"""What the grasp generator produces and with which settings: the N x 17 file, the gripper boxes.

The row layout is the GraspNet / InternDataEngine one (docs/reference-pick-skill.md section 2);
the gripper model is GraspNet's parallel jaw (fingers 6 cm long, 1 cm thick, 2 cm high).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from harness.writes import write_npy

DEPTHS = (0.005, 0.01, 0.02, 0.03, 0.04)
FRICTION_LEVELS = tuple(round(0.1 * k, 1) for k in range(1, 11))
GRASP_HEIGHT = 0.02
OBJECT_ID = -1.0
RAY_EPSILON = 1e-6


@dataclass(frozen=True)
class GripperModel:
    """Parallel-jaw gripper as boxes in the grasp frame (GraspNet's model: fingers 6 cm long,
    1 cm thick, 2 cm high; a 1 cm palm with 5 cm of approach clearance behind it)."""

    finger_length: float = 0.06
    finger_thickness: float = 0.01
    height: float = GRASP_HEIGHT
    palm_thickness: float = 0.01
    approach_clearance: float = 0.05

    def boxes(
        self, width: float, depth: float, inner_half_width: float
    ) -> list[tuple[np.ndarray, np.ndarray]]:
        """(centre, full size) of the left finger, right finger and palm in the grasp frame.

        Fingers span x in [depth - finger_length, depth] and |y| from ``inner_half_width`` to
        ``width / 2 + finger_thickness``; the palm (with its clearance) lies behind them.
        """
        outer = max(0.5 * width, inner_half_width) + self.finger_thickness
        x0, x1 = depth - self.finger_length, depth
        finger_size = np.array([x1 - x0, outer - inner_half_width, self.height])
        y_mid = 0.5 * (outer + inner_half_width)
        palm_back = x0 - self.palm_thickness - self.approach_clearance
        return [
            (np.array([0.5 * (x0 + x1), -y_mid, 0.0]), finger_size),
            (np.array([0.5 * (x0 + x1), y_mid, 0.0]), finger_size.copy()),
            (
                np.array([0.5 * (palm_back + x0), 0.0, 0.0]),
                np.array([x0 - palm_back, 2 * outer, self.height]),
            ),
        ]


@dataclass(frozen=True)
class GraspGenParams:
    """Generator settings; the defaults follow the reference (max width 0.1 m, 3000 grasps)."""

    max_width: float = 0.1
    # Stored width = contact distance + 2 * clearance. 0 is the reference's definition (measured
    # on the example files): the opening at which the fingers touch the object in their slab.
    clearance: float = 0.0
    contact_tolerance: float = 0.002  # finger boxes start this far outside the contacts
    tip_margin: float = 0.005  # contacts at least this far behind the fingertip line
    min_contact_distance: float = 0.002
    contact_patch_radius: float = 0.003  # normals are averaged over this patch
    cone_half_angle: float = math.atan(0.3)  # spread of the sampled closing directions
    approach_angles: int = 12  # approach directions tried per contact pair
    grasps_per_pair: int = 4  # at most this many approaches kept per pair (spread)
    pairs_per_round: int = 0  # contact pairs sampled per round; 0: max(10 n, 5000)
    max_rounds: int = 3  # more rounds only when a round yields fewer than n grasps
    batch_pairs: int = 500  # pairs expanded into approach candidates at a time
    depths: tuple[float, ...] = DEPTHS
    gripper: GripperModel = field(default_factory=GripperModel)


@dataclass
class GraspAnnotations:
    """Generated rows plus, per row, the contact points and normals they were built from."""

    grasps: np.ndarray  # (N, 17) float32, sorted by score
    contacts: np.ndarray  # (N, 2, 3): c1 (on the -g_y side) and c2, object frame
    normals: np.ndarray  # (N, 2, 3): outward surface normals at c1 and c2
    stats: dict[str, Any]

    def save(self, path: str | Path) -> Path:
        return save_grasps(path, self.grasps)


def save_grasps(path: str | Path, grasps: np.ndarray) -> Path:
    """Write an N x 17 float32 grasp file (``np.save``; byte-identical for identical arrays)."""
    data = np.ascontiguousarray(grasps, dtype=np.float32)
    return write_npy(Path(path), data)


# --------------------------------------------------------------------------------------------
