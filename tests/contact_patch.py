"""The torsional friction of a finger pad, from the size of its contact patch: the derivation
of each robot.yaml's ``pad_torsion`` (its source cites this file), which
``tests/test_grip_friction.py`` recomputes from the compiled pads.

A point contact resists no torque about its normal; a real pad touches over a patch, and
friction over the patch resists a twist up to a limit proportional to the normal force N
(a "soft finger" contact). For a circular patch of radius a in full slip, with the pressure
distribution p(r) integrated as M = mu * integral of p(r) r dA:

- Hertzian pressure p(r) = p0 sqrt(1 - r^2 / a^2), N = (2/3) pi a^2 p0:
  M = (3 pi / 16) mu a N (K. L. Johnson, Contact Mechanics, 1985, torsion of a Hertzian contact;
  V. L. Popov, Contact Mechanics and Friction, 2010, section 8.2.4, whose derivation the OSRF
  "Torsional Friction" notebook behind Gazebo's torsional friction follows);
- uniform pressure p = N / (pi a^2): M = (2/3) mu a N.

MuJoCo's condim-4 contact takes this as its torsional coefficient mu_t = M / N (m). The pad's
patch is at most the largest disc its face holds (radius: half the face's narrower side); the
Hertzian factor is the smaller of the two, so the coefficient is the smaller of the two
classical estimates for the largest patch the pad can make.
"""

from __future__ import annotations

import math

import numpy as np

HERTZ_TORSION_FACTOR = 3.0 * math.pi / 16.0  # M / (mu a N), Hertzian pressure
UNIFORM_TORSION_FACTOR = 2.0 / 3.0  # M / (mu a N), uniform pressure


def patch_torsion(mu: float, patch_radius: float) -> float:
    """Torsional friction coefficient (m) of a circular Hertzian patch of ``patch_radius`` (m)
    with sliding friction ``mu``: the largest moment about the normal per newton of normal
    force."""
    return HERTZ_TORSION_FACTOR * mu * patch_radius


def face_patch_radius(box_full_size: np.ndarray, closing_axis: int) -> float:
    """Radius (m) of the largest disc on a box pad's face normal to ``closing_axis`` (0, 1, 2):
    half the face's narrower side."""
    face = [float(box_full_size[i]) for i in range(3) if i != closing_axis]
    return min(face) / 2.0
