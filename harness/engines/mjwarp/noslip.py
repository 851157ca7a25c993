"""MuJoCo Warp's noslip pass with each world's dofs spread over a thread block.

Why: MuJoCo Warp 4.0 runs the noslip pass's projected Gauss-Seidel sweeps in one kernel launched
with one thread per world (``mujoco_warp/_src/solver.py``, ``noslip``: ``wp.launch(_noslip_solve
(...), dim=d.nworld)``), so a world walks its frictional rows x iterations x dofs serially. On
an H200 that made an episode's span 4.2x longer (47.4 s against 11.3 s on 1,024 lanes,
docs/engines.md), and ``harness sweep --engine mjwarp`` slower than the CPU engine.

What: the same sweeps, in the same row order, with the same arithmetic per row, but a world is a
block of ``BLOCK_DIM`` threads: each thread owns the dofs ``lane, lane + BLOCK_DIM, ...`` of the
world's ``qacc``, a row's residual ``J[row] . qacc`` is a block reduction (``wp.tile_reduce``),
and the update ``qacc += delta * Y[row]`` is spread over the threads. The row logic (the clamp of
a dry-friction row, the QCQP of an elliptic contact's friction rows, the cost-change test, the
termination on the scaled improvement) is computed identically by every thread of the block from
the broadcast sums, so the block stays in step and every thread writes the same forces. The
other kernels of the pass (inertia factor, ``M^-1 J'``, Delassus blocks, final ``qacc`` and
``qfrc_constraint``, constraint states) are MuJoCo Warp's own, launched as its ``noslip`` does.

Only the summation order of a row's dot product differs from MuJoCo Warp's kernel (a tree
instead of a serial sum), so forces agree to float32 rounding (``tests/test_noslip_kernel.py``
compares both kernels on the same states). Models this kernel does not cover (pyramidal cones,
sparse Jacobians, sleeping) keep MuJoCo Warp's kernel. ``HARNESS_NOSLIP_KERNEL=mjwarp`` selects
MuJoCo Warp's kernel for every model (to measure one against the other).
"""

from __future__ import annotations

import os
from typing import Any

import warp as wp
from mujoco_warp._src import solver, support, types

from harness.engines.mjwarp.noslip_block import solve_block

BLOCK_DIM = 32
"""Threads per world: a warp, which covers every dof of the harness's models (FR3 15, Split
ALOHA 22, Lift-2 23); a model with more dofs gives a thread several (strided)."""

KERNEL_ENV = "HARNESS_NOSLIP_KERNEL"
"""``block`` (default): this module's kernel where it applies; ``mjwarp``: MuJoCo Warp's."""

_ORIGINAL = solver.noslip


def covers(m: types.Model) -> bool:
    """Whether this module's kernel runs ``m``'s pass (else MuJoCo Warp's does)."""
    if os.environ.get(KERNEL_ENV, "block") == "mjwarp":
        return False
    sleep = bool(m.opt.enableflags & types.EnableBit.SLEEP)
    return (not m.is_sparse) and (not sleep) and m.opt.cone == types.ConeType.ELLIPTIC


def noslip(m: types.Model, d: types.Data) -> None:
    """MuJoCo Warp's ``noslip`` with the Gauss-Seidel kernel spread over a block per world
    where ``covers(m)``; MuJoCo Warp's own pass otherwise."""
    if not covers(m) or m.opt.integrator == types.IntegratorType.DISCRETE:
        _ORIGINAL(m, d)
        return
    if d.njmax == 0 or m.nv == 0:
        return
    noslip_L, noslip_Y, noslip_A, inertia_scale = _buffers(m, d)
    _prepare(m, d, noslip_L, noslip_Y, noslip_A, inertia_scale)
    wp.launch_tiled(
        solve_block, dim=[d.nworld], block_dim=BLOCK_DIM,
        inputs=[
            m.nv, m.opt.noslip_tolerance, m.opt.noslip_iterations, d.nefc, d.contact.friction,
            d.contact.dim, d.efc.type, d.efc.id, d.efc.J, d.efc.D, d.efc.aref,
            d.efc.frictionloss, d.njmax, noslip_Y, noslip_A, inertia_scale,
        ],
        outputs=[d.solver_niter, d.qacc, d.efc.force],
    )  # fmt: skip
    _finish(m, d, noslip_Y)


def _buffers(m: Any, d: Any) -> tuple[Any, Any, Any, Any]:
    """The pass's scratch arrays of ``d``, made at its first pass and kept on ``d``.

    MuJoCo Warp allocates them at every pass; inside a graph capture those allocations become
    graph memory nodes, allocated and freed at every replay. Made once (the first pass of a
    ``Data`` is an eager step: ``LaneRun.launch`` and ``steps.replay`` step once before they
    capture), a replay only runs kernels."""
    key = (m.nv, d.nworld, d.njmax)
    kept = getattr(d, "_harness_noslip", None)
    if kept is not None and kept[0] == key:
        return kept[1]
    arrays = (
        wp.empty((d.nworld, m.nv, m.nv), dtype=float),
        wp.empty((d.nworld, d.njmax, m.nv), dtype=float),
        wp.empty((d.nworld, d.njmax), dtype=types.vec5),  # pyright: ignore[reportArgumentType]
        wp.empty((d.nworld,), dtype=float),
    )
    if not wp.get_device(d.qpos.device).is_capturing:  # never keep a graph's own memory
        d._harness_noslip = (key, arrays)
    return arrays


def _prepare(
    m: Any, d: Any, noslip_L: Any, noslip_Y: Any, noslip_A: Any, inertia_scale: Any
) -> None:
    """MuJoCo Warp's kernels before the sweeps: the termination scale, ``M = L L'``,
    ``Y = M^-1 J'``, the Delassus blocks and ``qacc`` from the main solver's forces."""
    wp.launch(
        solver._inertia_scale, dim=d.nworld, inputs=[m.nv, m.M_rownnz, m.M_rowadr, d.M],
        outputs=[inertia_scale],
    )  # fmt: skip
    wp.launch(
        solver._noslip_factor_m(False), dim=d.nworld,
        inputs=[m.nv, m.M_rownnz, m.M_rowadr, m.M_colind, d.nefc, d.M, d.dof_cdof],
        outputs=[noslip_L],
    )  # fmt: skip
    wp.launch(
        solver._noslip_minv_jt(False, False), dim=(d.nworld, d.njmax),
        inputs=[
            m.nv, m.M_rowadr, m.M_colind, d.nefc, d.efc.J_rownnz, d.efc.J_rowadr, d.efc.J_colind,
            d.efc.J, d.dof_cdof, noslip_L,
        ],
        outputs=[noslip_Y],
    )  # fmt: skip
    wp.launch(
        solver._noslip_delassus(False), dim=(d.nworld, d.njmax),
        inputs=[
            m.nv, d.nefc, d.contact.dim, d.contact.efc_address, d.efc.type, d.efc.id,
            d.efc.J_rownnz, d.efc.J_rowadr, d.efc.J_colind, d.efc.J, noslip_Y,
        ],
        outputs=[noslip_A],
    )  # fmt: skip
    wp.launch(
        solver._noslip_qacc_init(False), dim=(d.nworld, m.nv),
        inputs=[d.nefc, d.qacc_smooth, d.efc.force, d.dof_cdof, d.njmax, noslip_Y],
        outputs=[d.qacc],
    )  # fmt: skip


def _finish(m: Any, d: Any, noslip_Y: Any) -> None:
    """MuJoCo Warp's kernels after the sweeps: ``qacc`` and ``qfrc_constraint`` from the new
    forces, the constraint states and ``efc.Ma``."""
    wp.launch(
        solver._noslip_qacc_qfrc(False, False), dim=(d.nworld, m.nv),
        inputs=[
            d.nefc, d.qacc_smooth, d.efc.J_rownnz, d.efc.J_rowadr, d.efc.J_colind, d.efc.J,
            d.efc.force, d.dof_cdof, d.njmax, noslip_Y,
        ],
        outputs=[d.qacc, d.qfrc_constraint],
    )  # fmt: skip
    wp.launch(
        solver._noslip_state, dim=(d.nworld, d.njmax),
        inputs=[
            m.opt.impratio_invsqrt, d.nefc, d.contact.friction, d.contact.dim,
            d.contact.efc_address, d.efc.type, d.efc.id, d.efc.frictionloss, d.efc.force, d.njmax,
        ],
        outputs=[d.efc.state],
    )  # fmt: skip
    support.mul_m(m, d, d.efc.Ma, d.qacc)


def install() -> None:
    """Route MuJoCo Warp's solver to ``noslip`` (idempotent). ``solver.solve`` looks the pass
    up by its module-level name at each call."""
    solver.noslip = noslip
