"""Tuning filter settings and grasp annotations from runs (``harness tune``, ``grasps audit``).

- ``grid``: the approach x facing grid a tune sweeps, and the task's current setting;
- ``analysis``: success maps with Wilson intervals, the best setting, McNemar vs the current;
- ``heatmaps``: one PNG per robot, arm and object;
- ``blocks``: ``tuned.yaml`` (paste-ready pick blocks in each robot's keys) and ``tuned.md``;
- ``run``: ``tune`` runs the grid as one sweep and ``analyse`` writes ``<run dir>/tune/``;
- ``audit``: which annotated grasps were executed, which never succeed and why, cleaned files.
"""
