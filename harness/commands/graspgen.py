"""``harness grasps generate MESH --out FILE``: antipodal grasp annotations for a mesh."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from harness.commands.console import say
from harness.errors import HarnessError
from harness.objects.assets import resolve_mesh
from harness.objects.graspgen import GraspGenParams, generate_grasps
from harness.objects.meshes import load_mesh


def summary(grasps: np.ndarray) -> str:
    """Score histogram and width / depth ranges of an N x 17 array, on one line."""
    if len(grasps) == 0:
        return "no grasps"
    scores, counts = np.unique(np.round(grasps[:, 0], 1), return_counts=True)
    histogram = ", ".join(f"{s:.1f}: {c}" for s, c in zip(scores, counts, strict=True))
    return (
        f"scores {{{histogram}}}, width {grasps[:, 1].min():.3f}-{grasps[:, 1].max():.3f} m, "
        f"depths {sorted({round(float(d), 3) for d in grasps[:, 3]})}"
    )


def generate(args: argparse.Namespace) -> int:
    if args.num <= 0:
        raise HarnessError(f"-n must be positive, got {args.num}")
    if not (0 < args.max_width <= 1.0):
        raise HarnessError(f"--max-width must be in (0, 1] m, got {args.max_width}")
    if not (args.scale > 0 and np.isfinite(args.scale)):
        raise HarnessError(f"--scale must be positive, got {args.scale}")
    mesh_path = resolve_mesh(args.mesh, Path.cwd())
    mesh = load_mesh(mesh_path, args.scale)
    result = generate_grasps(
        mesh, n=args.num, seed=args.seed, params=GraspGenParams(max_width=args.max_width)
    )
    out = result.save(args.out)
    stats = result.stats
    say(
        f"wrote {out}: {len(result.grasps)} grasps for {mesh_path} "
        f"({len(mesh.vertices)} vertices, scale {args.scale:g}) in {stats['seconds']:.1f} s; "
        f"{summary(result.grasps)}"
    )
    if len(result.grasps) < args.num:
        say(
            f"warning: only {len(result.grasps)} of {args.num} grasps found "
            f"({stats['pairs_valid']} valid contact pairs, {stats['checked']} gripper checks)"
        )
    return 0
