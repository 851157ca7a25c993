"""The Warp kernels of the lanes (``harness.engines.mjwarp.lanes``): each world of the data is a
lane that runs episodes one after another, at its own phase.

Per physics step, inside one captured CUDA graph: ``lane_ctrl`` sets the controls of the lanes
at the start of a servo chunk, MuJoCo Warp steps every world, ``lane_tick`` advances each lane's
phase and says what it records (``row_of``: a signal row at the end of a control step, its start
row at the end of the warm-up), the signal kernels of ``kernels`` record, and
``lane_release`` frees the lanes whose span ended. The host loads new jobs into free lanes
between replays (``scatter_*``) and gathers the finished jobs' rows (``gather_rows``).

A free lane can also run a tug *rung* (``kernels.load_rungs`` into the lane, then
``lane_rung_start``): the held state of a job slot with
the rung's pull on the object, for ``rung_left`` physics steps; ``lane_rung_tick`` counts them
down, marks the lane's rung row (``BASELINE``: the rung's one end row, recorded into the
lanes' rung rows) at the last, and takes the pull off.

A lane's phase counts the physics steps since its job was loaded: ``warmup`` steps with the
start controls, then control steps of ``substeps`` physics steps each, chunk by chunk, exactly
the order of the lockstep motion (``motion``), so a job's rows do not depend on the
lane or on the other lanes (``tests/test_lanes.py`` compares them bit for bit on Warp's CPU
device).
"""

from __future__ import annotations

from typing import Any

import warp as wp

from harness.engines.mjwarp.kernels import BASELINE, NO_ROW


@wp.kernel
def lane_ctrl(
    table: wp.array3d(dtype=wp.float32),  # (job slot, rows * chunks, nu)
    last_row: wp.array(dtype=wp.int32),  # per job slot: its last schedule row
    warmup: wp.array(dtype=wp.int32),  # per job slot: its warm-up physics steps
    job_of: wp.array(dtype=wp.int32),  # per lane: its job slot, -1 when free
    phase: wp.array(dtype=wp.int32),  # per lane: physics steps since its job was loaded
    chunk_at: wp.array(dtype=wp.int32),  # per physics step of a control step: the chunk it
    # starts, else -1
    nchunks: int,
    ctrl: wp.array2d(dtype=wp.float32),
):
    """The controls of each lane whose next physics step starts a servo chunk."""
    lane, a = wp.tid()
    j = job_of[lane]
    if j < 0:
        return
    q = phase[lane] - warmup[j]
    if q < 0:
        return
    substeps = chunk_at.shape[0]
    chunk = chunk_at[q % substeps]
    if chunk < 0:
        return
    row = wp.min((q // substeps) * nchunks + chunk, last_row[j])
    ctrl[lane, a] = table[j, row, a]


@wp.kernel
def lane_tick(
    warmup: wp.array(dtype=wp.int32),
    span: wp.array(dtype=wp.int32),  # per job slot: control steps recorded (motion + window)
    substeps: int,
    job_of: wp.array(dtype=wp.int32),
    phase: wp.array(dtype=wp.int32),
    ended: wp.array(dtype=wp.int32),  # per lane: 1 once its span's last row is recorded
    row_of: wp.array(dtype=wp.int32),  # per lane, out: what it records after this step
):
    """After a physics step: each busy lane's phase, and the row it records now."""
    lane = wp.tid()
    j = job_of[lane]
    if j < 0:
        row_of[lane] = NO_ROW
        return
    p = phase[lane] + 1
    phase[lane] = p
    q = p - warmup[j]
    row_of[lane] = NO_ROW
    if q == 0:
        row_of[lane] = BASELINE
    elif q > 0 and q % substeps == 0:
        row = q // substeps - 1
        row_of[lane] = row
        if row == span[j] - 1:
            ended[lane] = 1


@wp.kernel
def lane_release(job_of: wp.array(dtype=wp.int32), ended: wp.array(dtype=wp.int32)):
    """Free the lanes whose span ended (after their last row is recorded)."""
    lane = wp.tid()
    if ended[lane] == 1:
        job_of[lane] = -1
        ended[lane] = 0


@wp.kernel
def lane_rung_start(
    lanes: wp.array(dtype=wp.int32),  # per rung: its lane (its state set by ``load_rungs``)
    steps: int,  # the rung's physics steps
    rung_left: wp.array(dtype=wp.int32),
    peak_rows: wp.array(dtype=wp.int32),
):
    """Each rung's lane counts its steps down from ``steps``, its buffer use from 0."""
    lane = lanes[wp.tid()]
    rung_left[lane] = steps
    peak_rows[lane] = 0


@wp.kernel
def lane_rung_tick(
    rung_left: wp.array(dtype=wp.int32),  # per lane: the rung's physics steps to go (0: none)
    obj_body: int,
    xfrc: wp.array2d(dtype=wp.spatial_vector),
    rung_row: wp.array(dtype=wp.int32),  # per lane, out: BASELINE once the rung's last step ran
):
    """After a physics step: count each rung lane down; at its last step it records its end
    row and the pull is taken off the lane (a job loaded next starts without it)."""
    lane = wp.tid()
    rung_row[lane] = NO_ROW
    n = rung_left[lane]
    if n <= 0:
        return
    n = n - 1
    rung_left[lane] = n
    if n == 0:
        rung_row[lane] = BASELINE
        xfrc[lane, obj_body] = wp.spatial_vector(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


@wp.kernel
def lane_track(
    nefc: wp.array(dtype=wp.int32),
    nacon: wp.array(dtype=wp.int32),
    peak_rows: wp.array(dtype=wp.int32),  # per lane: since its job was loaded
    peak_contacts: wp.array(dtype=wp.int32),  # the data's, since the last replay
):
    """``kernels.track_use`` for lanes (the same rule: after every physics step)."""
    lane = wp.tid()
    peak_rows[lane] = wp.max(peak_rows[lane], nefc[lane])
    if lane == 0:
        peak_contacts[0] = wp.max(peak_contacts[0], nacon[0])


@wp.kernel
def scatter_1d(src: wp.array(dtype=Any), index: wp.array(dtype=wp.int32), dst: wp.array(dtype=Any)):
    i = wp.tid()
    dst[index[i]] = src[i]


@wp.kernel
def scatter_2d(
    src: wp.array2d(dtype=Any), index: wp.array(dtype=wp.int32), dst: wp.array2d(dtype=Any)
):
    i, k = wp.tid()
    dst[index[i], k] = src[i, k]


@wp.kernel
def scatter_3d(
    src: wp.array3d(dtype=Any), index: wp.array(dtype=wp.int32), dst: wp.array3d(dtype=Any)
):
    i, r, k = wp.tid()
    dst[index[i], r, k] = src[i, r, k]


@wp.kernel
def gather_rows(
    src: wp.array3d(dtype=wp.float32),
    index: wp.array(dtype=wp.int32),
    dst: wp.array3d(dtype=wp.float32),
):
    """``dst[i] = src[index[i]]`` (the finished jobs' signal rows, for one download)."""
    i, r, k = wp.tid()
    dst[i, r, k] = src[index[i], r, k]
