"""Generating a bundled robot's URDF and self-collision pairs from its ``robots/<name>/build.py``.

A robot folder's ``build.py`` defines ``build() -> Robot`` with the primitives of
:mod:`~harness.robots.generator.shapes`; :mod:`~harness.robots.generator.generate` writes
``<name>.urdf`` (:mod:`~harness.robots.generator.urdf_text`) and ``collisions.json``
(:mod:`~harness.robots.generator.collisions`). Run ``python robots/build_urdfs.py`` after an edit.
"""
