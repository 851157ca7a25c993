"""What happens to each key of an InternDataEngine task file, and the reference names it uses.

``docs/interndata.md`` has the full table; a test checks it mentions every key listed here.
"""

from __future__ import annotations

REGION_SAMPLER = "A_on_B_region_sampler"
# The reference's neglect_collision_names entries are matched as substrings of scene names; the
# harness table is named "table" like the reference's table fixture.
TABLE_NAME = "table"

# Keys of a task entry, with what happens to them (docs/interndata.md has the full table).
TASK_KEYS_MAPPED = (
    "robots",
    "objects",
    "regions",
    "skills",
    "data",
    "neglect_collision_names",
    "distractors",
)
TASK_KEYS_IGNORED: dict[str, str] = {
    "name": "the harness names tasks after the file",
    "asset_root": "replaced by the asset_root argument (--asset-root) when one is given",
    "task": "task class; the harness has one pick episode",
    "task_id": "bookkeeping",
    "offset": "task offset in a multi-task stage",
    "render": "rendering",
    "arena_file": "arena (table, room) assets; the harness uses its own table",
    "env_map": "rendering (lighting)",
    "cameras": "rendering (cameras)",
    "random_region_list": "not used by the single-pick tasks",
}
ROBOT_KEYS_IGNORED: dict[str, str] = {
    "target_class": "robot class; the harness robot comes from robot_config_file",
    "translation": "the robot's region sets its position",
    "constrain_grasp_approach": "no effect in the reference (the pose-cost metric is reset)",
    "collision_activation_distance": "cuRobo planning setting",
    "use_batch": "the harness tests candidates sequentially (the reference default)",
    "lift_home": "the lift home comes from robots/lift2/robot.yaml (0.46, the reference value)",
}
OBJECT_KEYS_IGNORED: dict[str, str] = {
    "dataset": "bookkeeping",
    "prim_path_child": "USD prim under the file's root; the harness reads the file's mesh",
    "optimize_2d_layout": "objects are placed independently (no overlap optimisation)",
    "randomization_scope": "one asset per object (no instance randomisation)",
    "texture": "rendering",
    "visible": "rendering",
    "gap": "used by place skills",
}
