"""Generate robots/<name>/<name>.urdf and collisions.json for every robot folder with a build.py.

The URDFs are the single kinematic description used by placo (IK) and MuJoCo (physics). Each
robot's joint origins, axes, limits, masses and primitive geometry live in its own
``robots/<name>/build.py`` (``build() -> Robot``, sources cited there); the shared writer is
``harness/robots/generator/``.

Run ``python robots/build_urdfs.py [name ...] [--no-collisions]`` after editing;
``tests/test_robot.py`` checks that the committed files equal the generator output.
"""

from __future__ import annotations

import sys
from pathlib import Path

if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from harness.robots.generator.generate import main

    main()
