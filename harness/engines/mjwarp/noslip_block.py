"""The noslip pass's Gauss-Seidel kernel with a world's dofs spread over a thread block (Warp
kernel code; the host side and the why: ``harness.engines.mjwarp.noslip``)."""

from __future__ import annotations

import warp as wp
from mujoco_warp._src import math as mjmath
from mujoco_warp._src import solver, types


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
