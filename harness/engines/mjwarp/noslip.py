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
from mujoco_warp._src import math as mjmath
from mujoco_warp._src import solver, support, types

BLOCK_DIM = 32
"""Threads per world: a warp, which covers every dof of the harness's models (FR3 15, Split
ALOHA 22, Lift-2 23); a model with more dofs gives a thread several (strided)."""

KERNEL_ENV = "HARNESS_NOSLIP_KERNEL"
"""``block`` (default): this module's kernel where it applies; ``mjwarp``: MuJoCo Warp's."""

_ORIGINAL = solver.noslip


@wp.func
def _block_sum(part: float) -> float:
    """The sum over the block of every thread's ``part``, broadcast to every thread."""
    return wp.tile_extract(wp.tile_reduce(wp.add, wp.tile(part)), 0)


@wp.func
def _row_dot(
    efc_J_in: wp.array3d[float],
    qacc_io: wp.array2d[float],
    worldid: int,
    efcid: int,
    nv: int,
    lane: int,
    stride: int,
) -> float:
    """``J[efcid] . qacc`` of a dense Jacobian, over the block."""
    part = wp.float32(0.0)
    for k in range(lane, nv, stride):
        part += efc_J_in[worldid, efcid, k] * qacc_io[worldid, k]
    return _block_sum(part)


@wp.func
def _dry_friction_sweep(
    nv: int,
    nefc: int,
    efc_type_in: wp.array2d[int],
    efc_J_in: wp.array3d[float],
    efc_aref_in: wp.array2d[float],
    efc_frictionloss_in: wp.array2d[float],
    noslip_Y_in: wp.array3d[float],
    noslip_A_in: wp.array2d[types.vec5],
    worldid: int,
    lane: int,
    stride: int,
    qacc_io: wp.array2d[float],
    efc_force_io: wp.array2d[float],
) -> float:
    """One Gauss-Seidel sweep over the dof and tendon friction-loss rows; the cost change."""
    change = wp.float32(0.0)
    for efcid in range(nefc):
        efc_type = efc_type_in[worldid, efcid]
        if efc_type != int(types.ConstraintType.FRICTION_DOF) and efc_type != int(
            types.ConstraintType.FRICTION_TENDON
        ):
            continue
        res = _row_dot(efc_J_in, qacc_io, worldid, efcid, nv, lane, stride)
        res -= efc_aref_in[worldid, efcid]
        Adiag = wp.max(types.MJ_MINVAL, noslip_A_in[worldid, efcid][0])
        oldforce = efc_force_io[worldid, efcid]
        frictionloss = efc_frictionloss_in[worldid, efcid]
        force = wp.clamp(oldforce - res / Adiag, -frictionloss, frictionloss)
        delta = force - oldforce
        change -= 0.5 * delta * delta * Adiag + delta * res
        efc_force_io[worldid, efcid] = force
        if delta != 0.0:
            for k in range(lane, nv, stride):
                qacc_io[worldid, k] += delta * noslip_Y_in[worldid, efcid, k]
    return change


@wp.func
def _elliptic_contact(
    nv: int,
    efc_J_in: wp.array3d[float],
    efc_aref_in: wp.array2d[float],
    noslip_Y_in: wp.array3d[float],
    noslip_A_in: wp.array2d[types.vec5],
    friction: types.vec5,
    worldid: int,
    efcid: int,
    dim: int,
    lane: int,
    stride: int,
    qacc_io: wp.array2d[float],
    efc_force_io: wp.array2d[float],
) -> float:
    """The friction rows of one elliptic contact (MuJoCo Warp's ``_noslip_elliptic``, dense, no
    sleeping); returns the cost change (<= 0)."""
    n = dim - 1
    Ac = types.mat55()
    for k in range(n):
        Ak = noslip_A_in[worldid, efcid + 1 + k]
        for l in range(k, n):
            Ac[k, l] = Ak[l]
            Ac[l, k] = Ak[l]

    res = types.vec5(0.0)
    oldforce = types.vec5(0.0)
    for k in range(n):
        rowk = efcid + 1 + k
        dot = _row_dot(efc_J_in, qacc_io, worldid, rowk, nv, lane, stride)
        res[k] = dot - efc_aref_in[worldid, rowk]
        oldforce[k] = efc_force_io[worldid, rowk]
        Ac[k, k] = wp.max(1.0e-10, Ac[k, k])

    bc = types.vec5(0.0)
    for k in range(n):
        val = res[k]
        for l in range(n):
            val -= Ac[k, l] * oldforce[l]
        bc[k] = val

    normal = efc_force_io[worldid, efcid]
    force = types.vec5(0.0)
    if normal >= types.MJ_MINVAL:
        active = wp.bool(False)
        if n == 2:
            force, active = solver._qcqp2(Ac, bc, friction, normal)
        elif n == 3:
            force, active = solver._qcqp3(Ac, bc, friction, normal)
        else:
            force, active = solver._qcqp(Ac, bc, friction, normal, n)
        if active:
            s = wp.float32(0.0)
            for k in range(n):
                fk = mjmath.safe_div(force[k], friction[k])
                s += fk * fk
            scl = wp.sqrt(normal * normal / wp.max(types.MJ_MINVAL, s))
            for k in range(n):
                force[k] = force[k] * scl

    delta = types.vec5(0.0)
    for k in range(n):
        delta[k] = force[k] - oldforce[k]
    change = wp.float32(0.0)
    for k in range(n):
        Adelta = wp.float32(0.0)
        for l in range(n):
            Adelta += Ac[k, l] * delta[l]
        change += 0.5 * delta[k] * Adelta + delta[k] * res[k]
    if change > 1.0e-10:
        return 0.0

    for k in range(n):
        efc_force_io[worldid, efcid + 1 + k] = force[k]
    for i in range(lane, nv, stride):
        dqacc = wp.float32(0.0)
        for k in range(n):
            dqacc += delta[k] * noslip_Y_in[worldid, efcid + 1 + k, i]
        qacc_io[worldid, i] += dqacc
    return change


@wp.kernel(module="unique", enable_backward=False)
def solve_block(
    nv: int,
    opt_noslip_tolerance: wp.array[float],
    opt_noslip_iterations: int,
    nefc_in: wp.array[int],
    contact_friction_in: wp.array[types.vec5],
    contact_dim_in: wp.array[int],
    efc_type_in: wp.array2d[int],
    efc_id_in: wp.array2d[int],
    efc_J_in: wp.array3d[float],
    efc_D_in: wp.array2d[float],
    efc_aref_in: wp.array2d[float],
    efc_frictionloss_in: wp.array2d[float],
    njmax_in: int,
    noslip_Y_in: wp.array3d[float],
    noslip_A_in: wp.array2d[types.vec5],
    inertia_scale_in: wp.array[float],
    solver_niter_out: wp.array[int],
    qacc_io: wp.array2d[float],
    efc_force_io: wp.array2d[float],
):
    """Projected Gauss-Seidel sweeps over a world's frictional rows, one block per world
    (launched with ``wp.launch_tiled``, dense Jacobian, elliptic cones, no sleeping)."""
    worldid, lane = wp.tid()
    stride = wp.block_dim()
    nefc = wp.min(nefc_in[worldid], njmax_in)
    if nefc == 0:
        return

    scale = inertia_scale_in[worldid]
    tolerance = opt_noslip_tolerance[worldid % opt_noslip_tolerance.shape[0]]

    niter = wp.int32(0)
    while niter < opt_noslip_iterations:
        improvement = wp.float32(0.0)
        if niter == 0:
            part = wp.float32(0.0)
            for efcid in range(lane, nefc, stride):
                efc_D = efc_D_in[worldid, efcid]
                if efc_D > 0.0:
                    force = efc_force_io[worldid, efcid]
                    part += 0.5 * force * force / efc_D
            improvement += _block_sum(part)

        improvement += _dry_friction_sweep(
            nv, nefc, efc_type_in, efc_J_in, efc_aref_in, efc_frictionloss_in, noslip_Y_in,
            noslip_A_in, worldid, lane, stride, qacc_io, efc_force_io,
        )  # fmt: skip

        rowid = wp.int32(0)
        while rowid < nefc:
            if efc_type_in[worldid, rowid] == int(types.ConstraintType.CONTACT_ELLIPTIC):
                conid = efc_id_in[worldid, rowid]
                dim = contact_dim_in[conid]
                if rowid + dim > nefc:
                    break
                improvement -= _elliptic_contact(
                    nv, efc_J_in, efc_aref_in, noslip_Y_in, noslip_A_in,
                    contact_friction_in[conid], worldid, rowid, dim, lane, stride, qacc_io,
                    efc_force_io,
                )  # fmt: skip
                rowid += dim
            else:
                rowid += 1

        improvement *= scale
        niter += 1
        if improvement < tolerance:
            break

    if lane == 0:
        solver_niter_out[worldid] += niter


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
        wp.empty((d.nworld, d.njmax), dtype=types.vec5),
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
