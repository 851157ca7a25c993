"""How a run of physics steps is cut into captured CUDA graphs (no device here: the plan alone).

``steps.replay`` runs a step function ``times`` times: the first call eagerly (it loads the
kernels), the rest as replays of captured graphs. A graph of one step launched ``times - 1``
times issues one launch per physics step; a graph of ``per_graph`` steps issues that many times
fewer launches for the same kernels, plus one graph for the steps left over.
"""

from __future__ import annotations


def graph_plan(times: int, per_graph: int) -> list[tuple[int, int]]:
    """After the first (eager) call of ``times``: (calls captured in one graph, replays of it),
    ``per_graph`` calls a graph and one graph for the rest."""
    left = max(0, times - 1)
    if left == 0:
        return []
    each = max(1, min(per_graph, left))
    plan = [(each, left // each)]
    if left % each:
        plan.append((left % each, 1))
    return plan
