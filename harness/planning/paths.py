"""Path geometry: RRT-Connect and shortcutting in joint space, pose interpolation for lines.

Pure functions of their inputs (and the given ``numpy.random.Generator``): the collision tests
come in as callables, so these know nothing of MuJoCo or the scene. Budgets are counts, never
wall time, so a path depends only on the inputs and the generator.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

Collides = Callable[[np.ndarray], bool]


def rrt_connect(
    start: np.ndarray,
    goal: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    config_free: Callable[[np.ndarray], bool],
    edge_free: Callable[[np.ndarray, np.ndarray], bool],
    rng: np.random.Generator,
    step: float,
    max_iterations: int,
    max_nodes: int,
) -> list[np.ndarray] | None:
    """Bidirectional RRT (RRT-Connect) from ``start`` to ``goal``; None when the budget runs out.

    The budget is ``max_iterations`` samples and ``max_nodes`` tree nodes, never wall time, so
    the result depends only on the inputs and ``rng``.

    ``config_free(q)`` and ``edge_free(qa, qb)`` are the collision tests. Trees grow by at most
    ``step`` (max-norm) per extension; the other tree greedily connects towards each new node.
    """
    trees: list[tuple[list[np.ndarray], list[int]]] = [([start], [-1]), ([goal], [-1])]

    def nearest(nodes: list[np.ndarray], q: np.ndarray) -> int:
        return int(np.argmin(np.max(np.abs(np.asarray(nodes) - q), axis=1)))

    def extend(tree: tuple[list[np.ndarray], list[int]], q: np.ndarray) -> tuple[str, int]:
        nodes, parents = tree
        i = nearest(nodes, q)
        delta = q - nodes[i]
        dist = float(np.max(np.abs(delta)))
        new = q if dist <= step else nodes[i] + delta * (step / dist)
        if not config_free(new) or not edge_free(nodes[i], new):
            return "trapped", -1
        nodes.append(new)
        parents.append(i)
        return ("reached" if dist <= step else "advanced"), len(nodes) - 1

    def path_to_root(tree: tuple[list[np.ndarray], list[int]], index: int) -> list[np.ndarray]:
        nodes, parents = tree
        out = []
        while index >= 0:
            out.append(nodes[index])
            index = parents[index]
        return out

    a, b = 0, 1
    for _ in range(max_iterations):
        if len(trees[0][0]) + len(trees[1][0]) >= max_nodes:
            break
        sample = lower + (upper - lower) * rng.random(len(lower))
        status, new_index = extend(trees[a], sample)
        if status != "trapped":
            target = trees[a][0][new_index]
            while True:
                status_b, index_b = extend(trees[b], target)
                if status_b != "advanced":
                    break
            if status_b == "reached":
                half_a = path_to_root(trees[a], new_index)[::-1]
                half_b = path_to_root(trees[b], index_b)
                path = half_a + half_b[1:]
                return path if a == 0 else path[::-1]
        a, b = b, a
    return None


def shortcut(
    path: list[np.ndarray],
    edge_free: Callable[[np.ndarray, np.ndarray], bool],
    rng: np.random.Generator,
    iterations: int,
) -> list[np.ndarray]:
    """Random shortcutting: replace sub-paths by straight segments when they are free."""
    path = list(path)
    for _ in range(iterations):
        if len(path) <= 2:
            break
        i, j = sorted(rng.choice(len(path), size=2, replace=False))
        if j - i < 2:
            continue
        if edge_free(path[i], path[j]):
            path = path[: i + 1] + path[j:]
    return path


class PoseLine:
    """The line between two poses: linear position, slerp orientation (``at(s)``, ``s`` in
    [0, 1]). What does not depend on ``s`` (the relative rotation's angle and axis) is found
    once per line: a Cartesian path asks for one pose per step along it."""

    def __init__(self, T_a: np.ndarray, T_b: np.ndarray) -> None:
        self.T_a, self.T_b = T_a, T_b
        R_rel = T_a[:3, :3].T @ T_b[:3, :3]
        self.angle = float(np.arccos(np.clip(0.5 * (np.trace(R_rel) - 1.0), -1.0, 1.0)))
        self.axis: np.ndarray | None = None  # None: no rotation to interpolate
        if self.angle < 1e-9:
            return
        axis = np.array(
            [R_rel[2, 1] - R_rel[1, 2], R_rel[0, 2] - R_rel[2, 0], R_rel[1, 0] - R_rel[0, 1]]
        )
        norm = np.linalg.norm(axis)
        if norm < 1e-12:  # angle ~ pi: pick the axis from the symmetric part
            w, v = np.linalg.eigh(R_rel)
            self.axis = v[:, int(np.argmax(w))]
        else:
            self.axis = axis / norm

    def at(self, s: float) -> np.ndarray:
        """The pose at ``s`` (``T_a`` at 0, ``T_b`` at 1)."""
        T_a, T_b = self.T_a, self.T_b
        out = np.eye(4)
        out[:3, 3] = T_a[:3, 3] + (T_b[:3, 3] - T_a[:3, 3]) * s
        if self.axis is None:
            out[:3, :3] = T_a[:3, :3] if s < 0.5 else T_b[:3, :3]
        else:
            out[:3, :3] = T_a[:3, :3] @ _axis_angle(self.axis, self.angle * s)
        return out


def interpolate_pose(T_a: np.ndarray, T_b: np.ndarray, s: float) -> np.ndarray:
    """Linear position and slerp orientation between two poses, ``s`` in [0, 1]."""
    return PoseLine(T_a, T_b).at(s)


def _axis_angle(axis: np.ndarray, angle: float) -> np.ndarray:
    x, y, z = axis
    K = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return np.eye(3) + np.sin(angle) * K + (1.0 - np.cos(angle)) * (K @ K)
