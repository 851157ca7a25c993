"""Direction filters (docs/reference-pick-skill.md sections 4.2-4.4) and the robot-neutral filter
names.

- :func:`filter_poses` / :func:`filter_ee_poses` -> :class:`FilterResult`: the direction filters
  and ``direction_to_obj`` in the arm base frame, every mask kept;
- :func:`resolve_filters` / :func:`neutral_form`: robot-neutral ``approach_filter`` /
  ``facing_filter`` <-> per-axis ``filter_{x,y,z}_dir``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from harness.config import AxisFilter, ConfigError, PickConfig, reversed_band_message
from harness.grasps.conventions import AXES, GripperConvention
from harness.grasps.ee_poses import EEPoses

# --------------------------------------------------------------------------------------------
# Direction filters in the arm base frame (docs/reference-pick-skill.md sections 4.2, 4.3)

FILTER_KEYS: dict[str, str] = {axis: f"filter_{axis}_dir" for axis in AXES}
# direction -> (row of T_base_ee: base +X or +Z, sign)
DIRECTION_ROW_SIGN: dict[str, tuple[int, int]] = {
    "forward": (0, 1),
    "backward": (0, -1),
    "upward": (2, 1),
    "downward": (2, -1),
}


def axis_filter_mask(component: ArrayLike, spec: AxisFilter) -> np.ndarray:
    """Keep-mask of one direction filter given ``e = T_base_ee[:, row, column]``.

    ``[dir, a]`` keeps ``e >= cos a`` (forward/upward) or ``e <= cos a`` (backward/downward);
    ``[dir, a1, a2]`` keeps ``cos a1 <= e <= cos a2`` or ``cos a2 <= e <= cos a1``. The angles are
    measured from base +X or +Z, and cos(90 deg) is 6.1e-17, so ``forward 90`` rejects an axis
    that is exactly perpendicular -- both as in the reference.
    """
    e = np.asarray(component)
    _, sign = DIRECTION_ROW_SIGN[spec.direction]
    angles = spec.angles
    if len(angles) != 2:  # not spec.is_band, written so that the type checker narrows angles
        limit = np.cos(np.deg2rad(angles[0]))
        return e >= limit if sign > 0 else e <= limit
    cos1, cos2 = np.cos(np.deg2rad(angles[0])), np.cos(np.deg2rad(angles[1]))
    if sign > 0:
        return (e >= cos1) & (e <= cos2)
    return (e <= cos1) & (e >= cos2)


@dataclass(frozen=True, eq=False)
class FilterResult:
    """Every active filter's keep-mask over the 2N poses, and their AND.

    ``masks`` is keyed by the reference config key (``filter_x_dir``, ``filter_z_dir``,
    ``direction_to_obj``) so reports can say which filter rejected what. With no active filter
    every pose passes, as in the reference.
    """

    masks: dict[str, np.ndarray]
    combined: np.ndarray

    @property
    def total(self) -> int:
        return int(self.combined.shape[0])

    @property
    def passed(self) -> int:
        return int(np.count_nonzero(self.combined))

    @property
    def passing_indices(self) -> np.ndarray:
        return np.flatnonzero(self.combined)

    def counts(self) -> dict[str, int]:
        """Pass count per filter key."""
        return {key: int(np.count_nonzero(mask)) for key, mask in self.masks.items()}


def _combine(masks: dict[str, np.ndarray], total: int) -> FilterResult:
    if not masks:
        return FilterResult(masks={}, combined=np.ones(total, dtype=bool))
    combined = np.logical_and.reduce(list(masks.values()))
    return FilterResult(masks=masks, combined=combined)


def _direction_to_obj_mask(ee_y: np.ndarray, obj_y: float, side: str) -> np.ndarray:
    if side == "right":
        return ee_y <= obj_y
    if side == "left":
        return ee_y > obj_y
    raise ValueError(f"direction_to_obj must be 'left' or 'right', got {side!r}")


def filter_poses(
    T_base_ee: ArrayLike,
    filters: Mapping[str, AxisFilter],
    direction_to_obj: str | None = None,
    T_base_obj: ArrayLike | None = None,
) -> FilterResult:
    """Direction filters on base-frame poses ``T_base_ee`` ``(M, 4, 4)`` (sections 4.2-4.4).

    ``filters`` maps ``filter_{x,y,z}_dir`` (or the bare letter) to an :class:`AxisFilter`; the
    letter selects the EE axis (column of the rotation); masks are keyed ``filter_{x,y,z}_dir``.
    ``direction_to_obj`` ("left" / "right") compares the EE origin's base y with the object's,
    ``T_base_obj[1, 3]``.
    """
    T = np.asarray(T_base_ee, dtype=np.float64)
    masks: dict[str, np.ndarray] = {}
    for key, spec in filters.items():
        column = _filter_column(key)
        row, _ = DIRECTION_ROW_SIGN[spec.direction]
        masks[FILTER_KEYS[AXES[column]]] = axis_filter_mask(T[:, row, column], spec)
    if direction_to_obj is not None:
        if T_base_obj is None:
            raise ValueError("direction_to_obj needs T_base_obj")
        obj_y = float(np.asarray(T_base_obj, dtype=np.float64)[1, 3])
        masks["direction_to_obj"] = _direction_to_obj_mask(T[:, 1, 3], obj_y, direction_to_obj)
    return _combine(masks, T.shape[0])


def filter_ee_poses(
    ee_poses: EEPoses,
    T_base_obj: ArrayLike,
    filters: Mapping[str, AxisFilter],
    direction_to_obj: str | None = None,
) -> FilterResult:
    """:func:`filter_poses` of ``T_base_obj @ T_obj_ee``, computing only the entries it needs.

    Each filter reads one entry of ``T_base_ee`` per pose, ``R_base_obj[row] . R_obj_ee[:, col]``;
    computing just those (instead of 2N full 4x4 products) is what makes a million poses cheap.
    """
    T_bo = np.asarray(T_base_obj, dtype=np.float64)
    masks: dict[str, np.ndarray] = {}
    for key, spec in filters.items():
        row, _ = DIRECTION_ROW_SIGN[spec.direction]
        column = _filter_column(key)
        component = ee_poses.axis_component(column, T_bo[row, :3])
        masks[FILTER_KEYS[AXES[column]]] = axis_filter_mask(component, spec)
    if direction_to_obj is not None:
        ee_y = ee_poses.grasp_positions @ T_bo[1, :3] + T_bo[1, 3]
        side = _direction_to_obj_mask(ee_y, float(T_bo[1, 3]), direction_to_obj)
        masks["direction_to_obj"] = np.concatenate([side, side])
    return _combine(masks, len(ee_poses))


def _filter_column(key: str) -> int:
    """EE axis (rotation column) of a filter key: ``filter_y_dir`` (or just ``y``) -> 1."""
    for axis, name in FILTER_KEYS.items():
        if key in (name, axis):
            return AXES.index(axis)
    raise ValueError(f"unknown filter key {key!r}; expected one of {list(FILTER_KEYS.values())}")


# --------------------------------------------------------------------------------------------
# Robot-neutral filters

NEUTRAL_KEYS = ("approach_filter", "facing_filter")


def _neutral_axis(key: str, convention: GripperConvention) -> str:
    return convention.approach_axis if key == "approach_filter" else convention.facing_axis


def resolve_filter_sources(pick: PickConfig, convention: GripperConvention) -> dict[str, str]:
    """For each active ``filter_*_dir`` of :func:`resolve_filters`, the pick key that set it."""
    sources = {key: key for key in pick.axis_filters()}
    for neutral in NEUTRAL_KEYS:
        if getattr(pick, neutral) is not None:
            sources[FILTER_KEYS[_neutral_axis(neutral, convention)]] = neutral
    return dict(sorted(sources.items()))


def resolve_filters(pick: PickConfig, convention: GripperConvention) -> dict[str, AxisFilter]:
    """The per-axis filters for this robot: explicit ``filter_*_dir`` plus the neutral ones.

    ``approach_filter`` becomes ``filter_{approach_axis}_dir`` and ``facing_filter`` becomes
    ``filter_{facing_axis}_dir``. Setting the same EE axis twice is a ``ConfigError``.
    """
    resolved: dict[str, AxisFilter] = dict(pick.axis_filters())
    for neutral in NEUTRAL_KEYS:
        spec: AxisFilter | None = getattr(pick, neutral)
        if spec is None:
            continue
        axis = _neutral_axis(neutral, convention)
        key = FILTER_KEYS[axis]
        if key in resolved:
            role = "approach" if neutral == "approach_filter" else "facing"
            raise ConfigError(
                f"{neutral} {spec.as_list()} filters this robot's {role} axis, EE {axis}, "
                f"which {key} {resolved[key].as_list()} already filters; set only one of them",
                key=neutral,
            )
        resolved[key] = spec
    return dict(sorted(resolved.items()))


def neutral_form(
    filters: Mapping[str, AxisFilter], convention: GripperConvention
) -> dict[str, AxisFilter]:
    """The inverse of :func:`resolve_filters`: per-axis filters as approach / facing filters.

    The filter on the approach axis becomes ``approach_filter``, the one on the facing axis
    ``facing_filter``; a filter on the third axis has no neutral name and keeps its key.
    """
    names = {
        FILTER_KEYS[convention.approach_axis]: "approach_filter",
        FILTER_KEYS[convention.facing_axis]: "facing_filter",
    }
    for key in filters:
        _filter_column(key)
    return {names.get(key, key): spec for key, spec in filters.items()}


def check_strict_filters(filters: Mapping[str, AxisFilter]) -> None:
    """Strict semantics: a 3-element filter whose angle order can never pass is a ConfigError."""
    for key, spec in filters.items():
        if spec.never_passes():
            raise ConfigError(reversed_band_message(key, spec), key=key)
