"""The Warp kernels of the ``mjwarp`` engine: apply the schedule, record the signals, copy states.

Every kernel runs inside the captured CUDA graph of one control step (or eagerly on Warp's CPU
device), so the control schedule stays on the device and is indexed by a device step counter:
no host copy per step (``harness.engines.mjwarp.batch``). The signal layout is
``harness.engines.mjwarp.signals``.
"""

from __future__ import annotations

import warp as wp

SIG_FORCE = 0
SIG_OBJ_POS = 2
SIG_OBJ_VEL = 5
SIG_JOINT_SPEED = 8
SIG_PENETRATION = 9
SIG_MAX_QVEL = 10
SIG_NONFINITE = 11
SIG_EE = 12
SIG_TCP = 24
SIG_OBJ_MAT = 36

# What a world records after a physics step (``row_of``): nothing, its start row (the state the
# table penetration is counted from, written to the warm-up rows, penetration 0), or a signal
# row >= 0 of ``out``.
NO_ROW = -1
BASELINE = -2


@wp.kernel
def set_ctrl(
    schedule: wp.array3d(dtype=wp.float32),  # (batch world, rows, nu): chunk rows, then held
    step: wp.array(dtype=wp.int32),
    chunk: int,
    nchunks: int,
    last_row: wp.array(dtype=wp.int32),
    world_of: wp.array(dtype=wp.int32),  # per stepped world: its world of the batch
    ctrl: wp.array2d(dtype=wp.float32),
):
    w, a = wp.tid()
    o = world_of[w]
    row = wp.min(step[0] * nchunks + chunk, last_row[o])
    ctrl[w, a] = schedule[o, row, a]


@wp.kernel
def track_use(
    nefc: wp.array(dtype=wp.int32),
    nacon: wp.array(dtype=wp.int32),
    peak_rows: wp.array(dtype=wp.int32),
    peak_contacts: wp.array(dtype=wp.int32),
):
    """Keep each world's most constraint rows asked for (``nefc`` counts the rows that did not
    fit ``njmax`` too) and the batch's most contacts (``nacon``, all worlds): after every physics
    step, so an overflow anywhere in a control step is seen."""
    w = wp.tid()
    peak_rows[w] = wp.max(peak_rows[w], nefc[w])
    if w == 0:
        peak_contacts[0] = wp.max(peak_contacts[0], nacon[0])


@wp.kernel
def advance(step: wp.array(dtype=wp.int32)):
    step[0] = step[0] + 1


@wp.kernel
def rows_at_step(step: wp.array(dtype=wp.int32), row_of: wp.array(dtype=wp.int32)):
    """Lockstep: every world records the row of the batch's control step."""
    row_of[wp.tid()] = step[0]


@wp.func
def _pose(out: wp.array3d(dtype=wp.float32), w: int, s: int, at: int, p: wp.vec3, R: wp.mat33):
    for i in range(3):
        out[w, s, at + i] = p[i]
    for i in range(3):
        for j in range(3):
            out[w, s, at + 3 + 3 * i + j] = R[i, j]


@wp.func
def slab_depth(
    c: wp.vec3,
    R: wp.mat33,
    box: wp.vec3,
    radial: wp.float32,
    rounding: wp.float32,
    offset: wp.vec3,
    table: wp.vec3,
    table_half: wp.vec3,
) -> wp.float32:
    """How deep one geom is inside the table slab (m, >= 0): the smallest overlap of the geom's
    extent with the slab along the slab's three face normals (world x, y, z), 0 when one of
    them separates them. The extent along world axis ``a`` is ``TablePenetration``'s
    lowest-point formula on row ``a`` of the rotation. The CPU executor asks
    ``mj_geomDistance`` (every separating axis, exact hull for meshes); this bound uses only
    the slab's axes and a mesh's bounding box, so it is never below the CPU's depth and equals
    it for a geom pressed through the top face inside the footprint (docs/engines.md)."""
    depth = wp.float32(1.0e9)
    for a in range(3):
        r = wp.vec3(R[a, 0], R[a, 1], R[a, 2])
        centre = c[a] + wp.dot(r, offset)
        ca = wp.min(wp.abs(r[2]), 1.0)
        extent = wp.abs(r[0]) * box[0] + wp.abs(r[1]) * box[1] + wp.abs(r[2]) * box[2]
        extent = extent + radial * wp.sqrt(1.0 - ca * ca) + rounding
        gap = wp.abs(centre - table[a])
        overlap = extent + table_half[a] - gap
        depth = wp.min(depth, overlap)
    return wp.max(depth, 0.0)


@wp.func
def _emit(
    out: wp.array3d(dtype=wp.float32),
    w: int,
    s: int,
    w_state: int,
    qvel: wp.array2d(dtype=wp.float32),
    xpos: wp.array2d(dtype=wp.vec3),
    xmat: wp.array2d(dtype=wp.mat33),
    obj_body: int,
    obj_dof: int,
    ee_body: int,
    tcp_body: int,
    joint: wp.float32,
    penetration: wp.float32,
    fastest: wp.float32,
    bad: wp.float32,
):
    """Write one signal row (finger forces zeroed: ``finger_forces`` adds them)."""
    out[w, s, SIG_FORCE] = 0.0
    out[w, s, SIG_FORCE + 1] = 0.0
    p = xpos[w_state, obj_body]
    for i in range(3):
        out[w, s, SIG_OBJ_POS + i] = p[i]
        out[w, s, SIG_OBJ_VEL + i] = qvel[w_state, obj_dof + i]
    out[w, s, SIG_JOINT_SPEED] = joint
    out[w, s, SIG_PENETRATION] = penetration
    out[w, s, SIG_MAX_QVEL] = fastest
    out[w, s, SIG_NONFINITE] = bad
    _pose(out, w, s, SIG_EE, xpos[w_state, ee_body], xmat[w_state, ee_body])
    _pose(out, w, s, SIG_TCP, xpos[w_state, tcp_body], xmat[w_state, tcp_body])
    R_obj = xmat[w_state, obj_body]
    for i in range(3):
        for j in range(3):
            out[w, s, SIG_OBJ_MAT + 3 * i + j] = R_obj[i, j]


@wp.kernel
def record(
    qpos: wp.array2d(dtype=wp.float32),
    qvel: wp.array2d(dtype=wp.float32),
    xpos: wp.array2d(dtype=wp.vec3),
    xmat: wp.array2d(dtype=wp.mat33),
    geom_xpos: wp.array2d(dtype=wp.vec3),
    geom_xmat: wp.array2d(dtype=wp.mat33),
    robot_dof: wp.array(dtype=wp.int32),
    obj_body: int,
    obj_dof: int,
    ee_body: wp.array(dtype=wp.int32),  # per arm of the scene
    tcp_body: wp.array(dtype=wp.int32),  # per arm of the scene
    pen_geom: wp.array(dtype=wp.int32),
    pen_box: wp.array(dtype=wp.vec3),
    pen_radial: wp.array(dtype=wp.float32),
    pen_round: wp.array(dtype=wp.float32),
    pen_offset: wp.array(dtype=wp.vec3),
    table: wp.vec3,  # the slab's centre
    table_half: wp.vec3,  # the slab's half sizes
    pen_initial: wp.array2d(dtype=wp.float32),  # (batch world, geom): depth at the start
    row_of: wp.array(dtype=wp.int32),  # per stepped world: NO_ROW, BASELINE or its row
    world_of: wp.array(dtype=wp.int32),  # per stepped world: its world of the batch
    arm_of: wp.array(dtype=wp.int32),  # per batch world: its job's arm (index into ee_body)
    out: wp.array3d(dtype=wp.float32),  # (batch world, row, signal)
    start_out: wp.array3d(dtype=wp.float32),  # (batch world, 1, signal): the BASELINE rows
):
    """One signal row per world that records now: stepped world ``w`` reads its state at
    ``w`` and writes its batch world's row (a ``BASELINE`` row: into ``start_out``, the depth
    of each geom noted in ``pen_initial``); the end effector and TCP are its job's arm's."""
    w_state = wp.tid()
    s = row_of[w_state]
    if s == NO_ROW:
        return
    w = world_of[w_state]
    arm = arm_of[w]
    joint = wp.float32(0.0)
    for i in range(robot_dof.shape[0]):
        joint = wp.max(joint, wp.abs(qvel[w_state, robot_dof[i]]))
    fastest = wp.float32(0.0)
    bad = wp.float32(0.0)
    for i in range(qvel.shape[1]):
        v = qvel[w_state, i]
        if not wp.isfinite(v):
            bad = wp.float32(1.0)
        else:
            fastest = wp.max(fastest, wp.abs(v))
    for i in range(qpos.shape[1]):
        if not wp.isfinite(qpos[w_state, i]):
            bad = wp.float32(1.0)
    # harness.pick.penetration.TablePenetration.depth, per world, bounded by the separating
    # axes of the slab's faces (see slab_depth)
    deepest = wp.float32(0.0)
    for i in range(pen_geom.shape[0]):
        g = pen_geom[i]
        inside = slab_depth(
            geom_xpos[w_state, g], geom_xmat[w_state, g], pen_box[i], pen_radial[i], pen_round[i],
            pen_offset[i], table, table_half,
        )  # fmt: skip
        if s == BASELINE:
            pen_initial[w, i] = inside
        else:
            deepest = wp.max(deepest, inside - pen_initial[w, i])
    if s == BASELINE:
        _emit(
            start_out, w, 0, w_state, qvel, xpos, xmat, obj_body, obj_dof, ee_body[arm],
            tcp_body[arm], joint, deepest, fastest, bad,
        )  # fmt: skip
    else:
        _emit(
            out, w, s, w_state, qvel, xpos, xmat, obj_body, obj_dof, ee_body[arm],
            tcp_body[arm], joint, deepest, fastest, bad,
        )  # fmt: skip


@wp.kernel
def finger_forces(
    nacon: wp.array(dtype=wp.int32),
    contact_geom: wp.array(dtype=wp.vec2i),
    contact_world: wp.array(dtype=wp.int32),
    contact_efc: wp.array2d(dtype=wp.int32),
    efc_force: wp.array2d(dtype=wp.float32),
    finger_side: wp.array2d(dtype=wp.int32),  # (arm, geom): 0 left, 1 right, -1 other
    object_geom: wp.array(dtype=wp.int32),  # (ngeom,) 1 for the target object's geoms
    row_of: wp.array(dtype=wp.int32),  # per stepped world: NO_ROW, BASELINE or its row
    world_of: wp.array(dtype=wp.int32),  # per stepped world: its world of the batch
    arm_of: wp.array(dtype=wp.int32),  # per batch world: its job's arm (a row of finger_side)
    out: wp.array3d(dtype=wp.float32),
    start_out: wp.array3d(dtype=wp.float32),
):
    """``Scene.finger_forces``: the summed normal force of each finger of the world's arm in
    contact with the object (elliptic cones: the contact's first constraint row is its normal
    force), into the rows ``record`` wrote."""
    c = wp.tid()
    if c >= nacon[0]:
        return
    w = contact_world[c]
    s = row_of[w]
    if s == NO_ROW:
        return
    b = world_of[w]
    arm = arm_of[b]
    g = contact_geom[c]
    side = wp.int32(-1)
    if finger_side[arm, g[0]] >= 0 and object_geom[g[1]] == 1:
        side = finger_side[arm, g[0]]
    elif finger_side[arm, g[1]] >= 0 and object_geom[g[0]] == 1:
        side = finger_side[arm, g[1]]
    adr = contact_efc[c, 0]
    if side < 0 or adr < 0:
        return
    force = wp.abs(efc_force[w, adr])
    if s == BASELINE:
        wp.atomic_add(start_out, b, 0, SIG_FORCE + side, force)
    else:
        wp.atomic_add(out, b, s, SIG_FORCE + side, force)


@wp.kernel
def save_state(
    qpos: wp.array2d(dtype=wp.float32),
    qvel: wp.array2d(dtype=wp.float32),
    warm: wp.array2d(dtype=wp.float32),
    first_row: wp.array(dtype=wp.int32),  # per batch world: the row whose state is saved first
    slots: int,
    row_of: wp.array(dtype=wp.int32),  # per stepped world: NO_ROW, BASELINE or its row
    world_of: wp.array(dtype=wp.int32),  # per stepped world: its world of the batch
    saved_qpos: wp.array3d(dtype=wp.float32),
    saved_qvel: wp.array3d(dtype=wp.float32),
    saved_warm: wp.array3d(dtype=wp.float32),
):
    """Keep the states of the validity window (the tug starts from the end of the hold)."""
    w = wp.tid()
    row = row_of[w]
    if row < 0:
        return
    o = world_of[w]
    slot = row - first_row[o]
    if slot < 0 or slot >= slots:
        return
    for i in range(qpos.shape[1]):
        saved_qpos[o, slot, i] = qpos[w, i]
    for i in range(qvel.shape[1]):
        saved_qvel[o, slot, i] = qvel[w, i]
        saved_warm[o, slot, i] = warm[w, i]


@wp.kernel
def carry_state(
    pick: wp.array(dtype=wp.int32),  # per world of the new data: its world in the old
    time: wp.array(dtype=wp.float32),
    qpos: wp.array2d(dtype=wp.float32),
    qvel: wp.array2d(dtype=wp.float32),
    act: wp.array2d(dtype=wp.float32),
    warm: wp.array2d(dtype=wp.float32),
    ctrl: wp.array2d(dtype=wp.float32),
    time_out: wp.array(dtype=wp.float32),
    qpos_out: wp.array2d(dtype=wp.float32),
    qvel_out: wp.array2d(dtype=wp.float32),
    act_out: wp.array2d(dtype=wp.float32),
    warm_out: wp.array2d(dtype=wp.float32),
    ctrl_out: wp.array2d(dtype=wp.float32),
):
    """Carry the worlds that go on stepping into a smaller data: the state ``mj_step`` reads
    from the last step (time, qpos, qvel, act, qacc_warmstart, ctrl; the mocap poses are the
    jobs', set from the host)."""
    w = wp.tid()
    b = pick[w]
    time_out[w] = time[b]
    for i in range(qpos.shape[1]):
        qpos_out[w, i] = qpos[b, i]
    for i in range(qvel.shape[1]):
        qvel_out[w, i] = qvel[b, i]
        warm_out[w, i] = warm[b, i]
    for i in range(act.shape[1]):
        act_out[w, i] = act[b, i]
    for i in range(ctrl.shape[1]):
        ctrl_out[w, i] = ctrl[b, i]


@wp.kernel
def load_rungs(
    dest: wp.array(dtype=wp.int32),  # per rung: the world of the data that runs it
    source: wp.array(dtype=wp.int32),  # per rung: its episode world (or job slot)
    slot: wp.array(dtype=wp.int32),  # per rung: the saved slot (end of the hold)
    saved_qpos: wp.array3d(dtype=wp.float32),
    saved_qvel: wp.array3d(dtype=wp.float32),
    saved_warm: wp.array3d(dtype=wp.float32),
    hold_ctrl: wp.array2d(dtype=wp.float32),
    mocap_pos_src: wp.array2d(dtype=wp.vec3),
    mocap_quat_src: wp.array2d(dtype=wp.quat),
    force: wp.array(dtype=wp.vec3),
    obj_body: int,
    qpos: wp.array2d(dtype=wp.float32),
    qvel: wp.array2d(dtype=wp.float32),
    warm: wp.array2d(dtype=wp.float32),
    ctrl: wp.array2d(dtype=wp.float32),
    mocap_pos: wp.array2d(dtype=wp.vec3),
    mocap_quat: wp.array2d(dtype=wp.quat),
    xfrc: wp.array2d(dtype=wp.spatial_vector),
):
    """Start each tug rung in its world from its episode's held state with its pull applied
    (a round's own data: world ``r``; a stream's lanes: a free lane)."""
    i = wp.tid()
    r = dest[i]
    b = source[i]
    k = slot[i]
    for j in range(qpos.shape[1]):
        qpos[r, j] = saved_qpos[b, k, j]
    for j in range(qvel.shape[1]):
        qvel[r, j] = saved_qvel[b, k, j]
        warm[r, j] = saved_warm[b, k, j]
    for j in range(ctrl.shape[1]):
        ctrl[r, j] = hold_ctrl[b, j]
    for j in range(mocap_pos.shape[1]):
        mocap_pos[r, j] = mocap_pos_src[b, j]
        mocap_quat[r, j] = mocap_quat_src[b, j]
    f = force[i]
    xfrc[r, obj_body] = wp.spatial_vector(f[0], f[1], f[2], 0.0, 0.0, 0.0)
