"""The reference's ``goto__pose`` targets: end-effector poses in the arm base frame.

InternDataEngine's ``Goto_Pose`` skill (workflows/simbox/core/skills/goto_pose.py, commit
c4fa389) moves the arm, gripper closed or open, to a position in the arm base frame:

- a fixed orientation (``quaternion`` / ``euler``, perturbed by ``max_noise_deg``) gives one
  target (36-51);
- otherwise (68-123) it reads the held object's pose relative to the end effector now
  (``T_obj_ee``), draws 3000 uniform random rotations, keeps those whose axes pass the
  ``filter_*_dir`` tests and whose object axis ``align_obj_axis`` lies within
  ``align_obj_tol`` degrees of ``align_ref_axis`` (149-221), draws ``CUROBO_BATCH_SIZE`` (20)
  of them with replacement, pairs each with ``position`` + U(+-``max_noise_m``) per axis, and
  with ``position_constraint: object`` puts the **object** at that position with the end
  effector kept where it holds it (94-98). The targets are tested in order (``forward``: a
  joint-space plan; ``ik``: IK) and the first that passes is the goal; when none passes the
  last one is (the loop's index ends there), and its plan then fails.

Its own success test (264-272) is position within 5 mm **or** orientation within 0.087 rad.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from harness.config.handover import GotoPoseConfig
from harness.transforms import invert_T

# core/utils/constants.py: CUROBO_BATCH_SIZE = 20 (targets drawn per goto).
CUROBO_BATCH_SIZE = 20
ROTATION_DRAWS = 3000  # goto_pose.py 149: generate_constrained_rotation_batch(batch_size=3000)
# goto_pose.py 264: is_success(t_eps=5e-3, o_eps=0.087), either one suffices.
SUCCESS_POSITION_M = 5e-3
SUCCESS_ORIENTATION_RAD = 0.087

# (row, column, sign) of the rotation-matrix entry each direction word tests, per axis
# (goto_pose.py 150-175): the axis' component along the base's x (forward), y (leftward) or z.
_ROWS = {"forward": (0, 1), "backward": (0, -1), "leftward": (1, 1), "rightward": (1, -1)}
_ROWS |= {"upward": (2, 1), "downward": (2, -1)}
_COLUMNS = {"x": 0, "y": 1, "z": 2}


def rotation_mask(config: GotoPoseConfig, rotations: np.ndarray) -> np.ndarray:
    """Which of ``rotations`` (N, 3, 3; base <- ee) pass the ``filter_*_dir`` tests."""
    mask = np.ones(len(rotations), dtype=bool)
    for axis, column in _COLUMNS.items():
        spec = getattr(config, f"filter_{axis}_dir")
        if spec is None:
            continue
        row, sign = _ROWS[spec[0]]
        elements = rotations[:, row, column]
        if len(spec) == 2:
            cos_value = np.cos(np.deg2rad(spec[1]))
            mask &= elements >= cos_value if sign > 0 else elements <= cos_value
        else:
            cos1, cos2 = np.cos(np.deg2rad(spec[1])), np.cos(np.deg2rad(spec[2]))
            if sign > 0:
                mask &= (elements >= cos1) & (elements <= cos2)
            else:
                mask &= (elements <= cos1) & (elements >= cos2)
    return mask


def alignment_mask(
    config: GotoPoseConfig, rotations: np.ndarray, T_obj_ee: np.ndarray
) -> np.ndarray:
    """Which rotations put the object's ``align_obj_axis`` within ``align_obj_tol`` degrees of
    ``align_ref_axis`` (base frame), the object held as ``T_obj_ee`` (goto_pose.py 201-212)."""
    if config.align_obj_axis is None or config.align_ref_axis is None:
        return np.ones(len(rotations), dtype=bool)
    assert config.align_obj_tol is not None
    R_ee_obj = invert_T(T_obj_ee)[:3, :3]
    obj_axis = np.asarray(config.align_obj_axis, dtype=float)
    ref_axis = np.asarray(config.align_ref_axis, dtype=float)
    vectors = (rotations @ R_ee_obj) @ obj_axis
    cosines = vectors @ ref_axis / (np.linalg.norm(vectors, axis=1) * np.linalg.norm(ref_axis))
    angles = np.arccos(np.clip(cosines, -1.0, 1.0))
    return angles < np.deg2rad(config.align_obj_tol)


def goto_targets(
    config: GotoPoseConfig, T_obj_ee: np.ndarray, rng: np.random.Generator
) -> tuple[np.ndarray, int]:
    """The goto's candidate end-effector poses in the arm base frame (N, 4, 4), in the order the
    reference tests them, and how many of the 3000 drawn rotations passed its tests (the
    reference falls back to the first 20 draws when none does, goto_pose.py 216-218)."""
    position = np.asarray(config.position, dtype=float)
    if config.quaternion is not None or config.euler is not None:
        return _fixed_target(config, position, rng), 1
    rotations = Rotation.random(ROTATION_DRAWS, rng=rng).as_matrix()
    mask = rotation_mask(config, rotations) & alignment_mask(config, rotations, T_obj_ee)
    valid = rotations[mask]
    if len(valid) == 0:
        chosen = rotations[:CUROBO_BATCH_SIZE]
    else:
        chosen = valid[rng.integers(len(valid), size=CUROBO_BATCH_SIZE)]
    noise = rng.uniform(-config.max_noise_m, config.max_noise_m, size=(CUROBO_BATCH_SIZE, 3))
    positions = position + noise
    targets = np.tile(np.eye(4), (CUROBO_BATCH_SIZE, 1, 1))
    if config.position_constraint == "gripper":
        targets[:, :3, :3] = chosen
        targets[:, :3, 3] = positions
        return targets, int(mask.sum())
    # The object at the position, the end effector where it holds it (goto_pose.py 94-98).
    R_ee_obj = invert_T(T_obj_ee)[:3, :3]
    T_base_obj = np.tile(np.eye(4), (CUROBO_BATCH_SIZE, 1, 1))
    T_base_obj[:, :3, :3] = chosen @ R_ee_obj
    T_base_obj[:, :3, 3] = positions
    return T_base_obj @ T_obj_ee, int(mask.sum())


def _fixed_target(
    config: GotoPoseConfig, position: np.ndarray, rng: np.random.Generator
) -> np.ndarray:
    """One target at a fixed orientation, both perturbed (goto_pose.py 36-51)."""
    if config.quaternion is not None:
        w, x, y, z = config.quaternion
        rotation = Rotation.from_quat([x, y, z, w])
    else:
        assert config.euler is not None
        rotation = Rotation.from_euler("xyz", config.euler, degrees=True)
    # perturb_orientation: a random axis, an angle U(-max_noise_deg, max_noise_deg).
    axis = rng.normal(size=3)
    axis /= max(float(np.linalg.norm(axis)), 1e-12)
    angle = np.deg2rad(rng.uniform(-config.max_noise_deg, config.max_noise_deg))
    rotation = rotation * Rotation.from_rotvec(axis * angle)
    target = np.eye(4)
    target[:3, :3] = rotation.as_matrix()
    target[:3, 3] = position + rng.uniform(-config.max_noise_m, config.max_noise_m, size=3)
    return target[None]


def goto_reached(T_base_ee: np.ndarray, T_base_target: np.ndarray) -> tuple[bool, float, float]:
    """The reference's goto success (goto_pose.py 264-272): within 5 mm **or** 0.087 rad.
    Returns (passed, position error m, orientation error rad)."""
    position_error = float(np.linalg.norm(T_base_ee[:3, 3] - T_base_target[:3, 3]))
    relative = T_base_ee[:3, :3].T @ T_base_target[:3, :3]
    cos_angle = np.clip((np.trace(relative) - 1.0) / 2.0, -1.0, 1.0)
    orientation_error = float(np.arccos(cos_angle))
    passed = position_error < SUCCESS_POSITION_M or orientation_error < SUCCESS_ORIENTATION_RAD
    return passed, position_error, orientation_error
