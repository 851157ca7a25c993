"""Benchmark section ``grasps``: post-process + filter + order, one core, no loop over grasps.

Two sizes: one example grasp file (3000 rows -> 6000 poses; target under 1 ms) and a synthetic
set of 500,000 grasps (1,000,000 poses; target under 100 ms) made by tiling the example file
under random object-frame yaws, so the rotations are realistic and not all identical. Filters
are FR3's canonical pair (x forward 90, z downward 140) at a yawed object pose, reference
semantics. Loading and validating the file is timed separately (it happens once per object).

The example file is InternDataEngine's ``bottle_0`` grasps from ``../shared``; where that data
is absent, the default bottle's grasp file (``tasks/objects/bottle/grasps.npy``, the same N x 17
layout and convention, also 3000 rows) stands in and the figures' notes say so.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from harness.benchmarks.framework import Figure, figure, time_call
from harness.benchmarks.machine import one_core
from harness.config import PickConfig
from harness.grasps import (
    CandidateSelection,
    EEPoses,
    GraspSet,
    load_grasp_file,
    post_process,
    select_candidates,
)
from harness.pick.semantics import Semantics
from harness.robots.facts import reference_convention
from harness.transforms import make_T, yaw_matrix

SECTION = "grasps"
EXAMPLE = (
    Path(__file__).resolve().parents[2].parent
    / "shared/datasets/interndata-examples/objects/recyclable_garbage/bottle_0"
    / "Aligned_grasp_sparse.npy"
)
DEFAULT_OBJECTS = Path(__file__).resolve().parents[2] / "tasks" / "objects"
MILLION_GRASPS = 500_000  # -> 1,000,000 poses

# The filters in their YAML form (as PickConfig parses them).
PICK_FILTERS = {"filter_x_dir": ["forward", 90], "filter_z_dir": ["downward", 140]}


def grasp_source() -> tuple[Path, str]:
    """The grasp file to time and a label for the notes: the example file, else a default
    object's (the bottle, else the first with a grasp file)."""
    if EXAMPLE.is_file():
        return EXAMPLE, "example bottle_0"
    fallback = DEFAULT_OBJECTS / "bottle" / "grasps.npy"
    if not fallback.is_file():
        found = sorted(DEFAULT_OBJECTS.glob("*/grasps.npy"))
        if not found:
            raise FileNotFoundError(f"no grasp file: {EXAMPLE} and {DEFAULT_OBJECTS}/*/grasps.npy")
        fallback = found[0]
    return fallback, f"default {fallback.parent.name} (example data absent: {EXAMPLE} missing)"


def _synthetic_grasps(base: GraspSet, n: int, seed: int = 0) -> GraspSet:
    """``n`` grasps: the rows of ``base`` repeated, each copy turned by a random object yaw."""
    rng = np.random.default_rng(seed)
    copies = -(-n // len(base))
    R_yaw = yaw_matrix(rng.uniform(-np.pi, np.pi, size=copies))  # (copies, 3, 3)
    rotations = np.einsum("cij,njk->cnik", R_yaw, base.rotations).reshape(-1, 3, 3)[:n]
    translations = np.einsum("cij,nj->cni", R_yaw, base.translations).reshape(-1, 3)[:n]

    def tile(values: np.ndarray) -> np.ndarray:
        return np.tile(values, copies)[:n]

    return GraspSet(
        path=f"{base.path} x{copies} yawed",
        scores=tile(base.scores),
        widths=tile(base.widths),
        heights=tile(base.heights),
        depths=tile(base.depths),
        rotations=np.ascontiguousarray(rotations),
        translations=np.ascontiguousarray(translations),
        object_ids=tile(base.object_ids),
    )


def run(quick: bool) -> list[Figure]:
    with one_core() as pinned:
        return _figures(quick, pinned)


def _figures(quick: bool, pinned: str) -> list[Figure]:
    source, label = grasp_source()
    convention = reference_convention("fr3")
    pick = PickConfig.model_validate(PICK_FILTERS)
    rule = Semantics.from_pick(pick).candidates
    T_base_obj = make_T(yaw_matrix(35.0, degrees=True), [0.5, 0.05, 0.02])
    example = load_grasp_file(source)
    rows = len(example)

    def select(poses: EEPoses) -> CandidateSelection:
        return select_candidates(
            poses, convention, pick, T_base_obj, np.random.default_rng(0), rule
        )

    def pipeline(grasps: GraspSet) -> int:
        return select(post_process(grasps, convention)).filter_result.passed

    figures: list[Figure] = []
    reps = 50 if quick else 300
    passed = pipeline(example)
    figures.append(
        figure(
            SECTION,
            f"post-process + filter + order, one file ({2 * rows} poses)",
            time_call(lambda: pipeline(example), reps, warmup=5),
            "ms",
            scale=1e3,
            target=1.0,
            notes=f"{label} ({rows} rows), fr3 canonical filters, {passed} pass; {pinned}",
            extra={"grasp_file": str(source), "rows": rows, "passed": passed},
        )
    )
    figures.append(
        figure(
            SECTION,
            f"load + validate grasp file, {rows} rows",
            time_call(lambda: load_grasp_file(source), reps, warmup=2),
            "ms",
            scale=1e3,
            notes=f"{label}; once per object per worker",
        )
    )

    big = _synthetic_grasps(example, MILLION_GRASPS)
    big_reps = 5 if quick else 15
    passed = pipeline(big)
    poses = post_process(big, convention)
    figures.append(
        figure(
            SECTION,
            "post-process + filter + order, 1,000,000 poses",
            time_call(lambda: pipeline(big), big_reps, warmup=1),
            "ms",
            scale=1e3,
            target=100.0,
            notes=f"{MILLION_GRASPS} yawed copies of {label} rows, {passed} pass; {pinned}",
        )
    )
    figures.append(
        figure(
            SECTION,
            "post-process only, 1,000,000 poses",
            time_call(lambda: post_process(big, convention), big_reps, warmup=1),
            "ms",
            scale=1e3,
        )
    )
    figures.append(
        figure(
            SECTION,
            "filter + order only, 1,000,000 poses",
            time_call(lambda: select(poses), big_reps, warmup=1),
            "ms",
            scale=1e3,
        )
    )
    return figures
