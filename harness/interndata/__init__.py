"""InternDataEngine task YAML -> harness tasks, one per ``pick`` skill.

People who generate data with InternDataEngine already have task files (robots, objects, regions,
a tree of skills). ``load_interndata_tasks`` reads such a file as it is and turns every ``pick``
skill into a :class:`~harness.config.TaskConfig` for its robot arm, so filters can be tuned
here and the numbers carried back. The mapping, key by key, is in ``docs/interndata.md``; in short:

- OmegaConf interpolations (``${tasks.0.robots.0.name}``, relative ``${.x}``, nested
  ``${a.${b}}``) are resolved first, over the whole file, as the reference's
  ``OmegaConf.to_container(resolve=True)`` does; a broken one is an error naming its key.
- Robots by ``robot_config_file`` basename (fr3, lift2, split_aloha). ``euler`` yaw plus the
  robot's ``A_on_B_region_sampler`` region -> ``robot_placement`` (root position in the world,
  origin at the table-top centre; absolute yaw). ``<arm>_joint_home`` / ``_std`` -> ``home`` /
  ``home_noise_std``; without them the reference robot file's home (no noise) is used, as the
  reference does.
- Objects by ``path`` under the asset root, or substituted (``objects={name: path}``); ``scale``,
  ``euler``, ``orientation_mode`` (``suggested``: per-category table; ``random``: a 30 degree
  grid over x and y with a free yaw) and the object's region -> ``Placement``.
- The ``skills`` tree (stages -> robot -> phases -> arm -> skills): every ``pick`` becomes a task
  in execution order, its block passed to ``PickConfig`` unchanged; other skills are skipped with
  a warning, rendering keys ignored with a note.

Errors are ``ConfigError`` lines ``file:line key.path: message`` naming the InternData file and
the key in it (``tasks[0].objects[0].path``), whatever harness key the value ended up in.

Modules: ``loader`` (the entry point), ``interpolation`` (``${...}``), ``resolver`` (robots,
objects, regions, skills of a task entry), ``mapper`` (a pick skill -> ``TaskConfig``),
``categories`` / ``orientations`` (object orientations), ``keys`` (what happens to each key),
``substitutes`` (``--object``), ``result`` and ``notes``
(what a run takes from the file). This package re-exports the public names.
"""

from harness.interndata.categories import CATEGORY_ORIENTATIONS
from harness.interndata.interpolation import resolve_interpolations
from harness.interndata.keys import (
    OBJECT_KEYS_IGNORED,
    ROBOT_KEYS_IGNORED,
    TASK_KEYS_IGNORED,
    TASK_KEYS_MAPPED,
)
from harness.interndata.loader import load_interndata_tasks
from harness.interndata.notes import NOTES_FILE, note_lines, summary_lines, write_notes
from harness.interndata.orientations import random_orientations, suggested_orientations
from harness.interndata.result import InternDataPick, SkippedSkill
from harness.interndata.substitutes import parse_object_substitutions, split_substitute

__all__ = [
    "CATEGORY_ORIENTATIONS",
    "NOTES_FILE",
    "OBJECT_KEYS_IGNORED",
    "ROBOT_KEYS_IGNORED",
    "TASK_KEYS_IGNORED",
    "TASK_KEYS_MAPPED",
    "InternDataPick",
    "SkippedSkill",
    "load_interndata_tasks",
    "note_lines",
    "parse_object_substitutions",
    "random_orientations",
    "resolve_interpolations",
    "split_substitute",
    "suggested_orientations",
    "summary_lines",
    "write_notes",
]
