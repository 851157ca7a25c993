"""Tuning filter settings and grasp annotations from runs (``harness tune``, ``grasps audit``).

- ``grid``: the approach x facing grid a tune screens (deduplicated), the current setting;
- ``analysis``: the screening's success maps, the challengers it selects, the neighbour check;
- ``decide``: the race's tests and the verdict (pure logic on paired outcomes);
- ``sequential``: the race's plan (group-sequential levels, seeds for 80% power);
- ``planning``: each unit's plan from its screening, said up front; ``options``: ``tune.json``;
- ``intervals``: Wilson, exact and Newcombe paired-gain intervals (numpy, for simulations too);
- ``causes``: the dominant failure cause and its physical fact ("no setting helps");
- ``recommend``: ``recommendation(units_df)``, what a sweep report may call "best";
- ``race``: running the race's rounds on fresh seeds; ``simulate``: its error and power;
- ``decisions``: the decision tables; ``blocks``: ``tuned.yaml`` / ``tuned.md``;
- ``write``: ``--write DIR``, task files with only their filter keys merged;
- ``heatmaps``: one PNG per robot, arm and object;
- ``run``: ``tune`` screens, races and decides, writing ``<out>/tune/``;
- ``audit``: which annotated grasps were executed, which never succeed and why, cleaned files.
"""
