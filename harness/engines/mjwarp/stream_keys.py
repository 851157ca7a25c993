"""Which jobs share a lane stream (``stream_key``) and the scene a stream's jobs run in
(``scene_for``): one device model and one timing per stream."""

from __future__ import annotations

import threading
from typing import Any

StreamKey = tuple[Any, ...]


def task_key(task: Any) -> tuple[Any, ...]:
    """The task-model part of a stream key: the device model (scene, target) and the hold time
    (what a task gives before its job's schedule exists). Not the arm: both arms of a two-arm
    robot share a scene's device model (each world records its job's arm), so their jobs share
    a stream, whose graphs step twice the lanes for about the cost of one. (Lift-2's arms share
    one; Split ALOHA's do not: its right-arm task lets the robot touch the table, another
    model. The demo's and the canonical tune's ten task models run as eight streams.)"""
    from harness.engines.mjwarp.lane_sizes import env_flag
    from harness.sim import scene_key

    # HARNESS_STREAM_PER_ARM=1: a stream per arm as before (the measurement's baseline)
    arm = task.arm if env_flag("HARNESS_STREAM_PER_ARM") else ""
    return (scene_key(task), task.target_object.name, float(task.pick.hold_time), arm)


def stream_key(job: Any) -> StreamKey:
    """Jobs of one key share a lane stream: one device model (scene, target, contact bits: the
    table verdict's replay is a model of its own) and one timing (the lanes take their window
    and servo chunks from the stream's first job)."""
    schedule = job.schedule
    return (
        *task_key(job.task),
        float(schedule.control_dt), tuple(schedule.chunk_sizes), int(schedule.warmup_steps),
        job.contact_key,
    )  # fmt: skip


def stream_label(key: StreamKey) -> str:
    """A log's name for a stream's task model: its robot and target (``"split_aloha cube"``)."""
    import json

    robot = json.loads(key[0])[0][0]
    return f"{robot} {key[1]}"


def scene_for(task: Any, scenes: dict[Any, Any], lock: threading.Lock, contact: Any = None) -> Any:
    """``task``'s scene from ``scenes``, built once per ``scene_key`` (under ``lock``); with
    ``contact`` (a job's contact bits) other than its model's, a variant of it with those bits
    (``harness.engines.mjwarp.contact.scene_with_contact``), made once per bits."""
    import numpy as np

    from harness.engines.mjwarp.contact import contact_key, scene_with_contact
    from harness.sim import Scene, scene_key
    from harness.sim.masks import contact_bits

    key = scene_key(task)
    with lock:
        if key not in scenes:
            scenes[key] = Scene.for_task(task)
        scene = scenes[key]
        if contact is None or np.array_equal(contact, contact_bits(scene.model)):
            return scene
        variant = (key, contact_key(contact))
        if variant not in scenes:
            scenes[variant] = scene_with_contact(scene, contact)
        return scenes[variant]
