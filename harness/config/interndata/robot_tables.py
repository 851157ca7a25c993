"""The robots pick-harness maps from InternDataEngine files, by ``robot_config_file`` basename.

These are facts about the reference robot config files (arms, home joint values); they live
here, in one module, until they move into ``robots/<name>/robot.yaml``.
"""

from __future__ import annotations

SUPPORTED_ROBOTS: dict[str, str] = {
    "fr3.yaml": "fr3",
    "lift2.yaml": "lift2",
    "split_aloha.yaml": "split_aloha",
}
ROBOT_ARMS: dict[str, tuple[str, ...]] = {
    "fr3": ("left",),
    "lift2": ("left", "right"),
    "split_aloha": ("left", "right"),
}
# Home of each arm in the reference robot config files (robots_*.yaml, pick-skill.md section 3),
# used when a task file does not override it. Their home noise std is zero.
REFERENCE_ROBOT_HOMES: dict[str, list[float]] = {
    "fr3": [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785],
    "lift2": [0.0] * 6,
    "split_aloha": [0.0] * 6,
}
