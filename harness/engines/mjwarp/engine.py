"""The ``mjwarp`` engine: execution jobs on MuJoCo Warp (the optional extra ``gpu``).

``execute`` (one job, what ``harness sweep --engine mjwarp`` calls in each worker) and
``execute_many`` (a batch of jobs of one task model, what the throughput bench feeds) both make
each job's control schedule on the CPU (``harness.engines.mjwarp.schedule``), step the worlds in
lockstep on the device (``harness.engines.mjwarp.batch``) and judge the recorded signals with the
CPU's verdict terms (``harness.engines.mjwarp.judge``). The throughput bench can stream its jobs
through lanes instead (``harness.engines.mjwarp.stream``: one fixed set of worlds, each running
jobs one after another). The device is ``HARNESS_WARP_DEVICE`` when set
(``cpu`` for Warp's CPU device, ``cuda:1`` ...), else the first CUDA device, else the CPU: one
engine per device. A sweep's shared device service (``harness.engines.mjwarp.service``) and the
throughput bench run one engine on each device of ``default_devices`` (every CUDA device, or
the comma-separated ``HARNESS_WARP_DEVICE``).
"""

from __future__ import annotations

import contextlib
import os
from typing import Any

import numpy as np

from harness.config import TaskConfig
from harness.engines.base import Execution, ExecutionJob
from harness.engines.mjwarp.schedule import DeviceJob, device_job
from harness.errors import HarnessError
from harness.pick.outcome import PickOutcome
from harness.pick.validity import validity_enabled
from harness.sim import Scene
from harness.sim.masks import contact_bits

_NOTED = False  # the CPU device's note is said once per process
CPU_DEVICE_NOTE = (
    "mjwarp on Warp's CPU device: a test device (~60 world-steps/s on 2 cores, minutes per "
    "episode; the first use compiles its kernels for minutes); use a CUDA device for speed"
)


def _import_warp() -> tuple[Any, Any]:
    try:
        import mujoco_warp
        import warp
    except ImportError as exc:
        raise HarnessError(
            "the mjwarp engine needs the 'gpu' extra: pip install 'pick-harness[gpu]' "
            f"(mujoco-warp, warp-lang): {exc}"
        ) from None
    return warp, mujoco_warp


def default_devices() -> list[str]:
    """``HARNESS_WARP_DEVICE`` (one device, or several separated by commas: ``cuda:0,cuda:1``),
    else every CUDA device Warp sees, else ``["cpu"]``."""
    wp, _ = _import_warp()
    chosen = os.environ.get("HARNESS_WARP_DEVICE")
    if chosen:
        devices = [name.strip() for name in chosen.split(",") if name.strip()]
        if devices:
            return devices
    wp.config.quiet = True
    wp.init()
    count = wp.get_cuda_device_count()
    return [f"cuda:{k}" for k in range(count)] if count > 0 else ["cpu"]


def default_device() -> str:
    """The first of ``default_devices``: where one engine runs."""
    return default_devices()[0]


class MjwarpEngine:
    """Batched MuJoCo Warp worlds; one ``DeviceModel`` per task model and contact bits (the
    table verdict's replay runs with robot-table contact on), kept between calls."""

    name = "mjwarp"

    def __init__(
        self,
        device: str | None = None,
        buffers: tuple[int, int] | None = None,
        retire: float | None = None,
    ) -> None:
        """``buffers``: (contacts, constraint rows) per world, else ``steps.SMALL``;
        ``retire``: the share of a batch's stepping worlds whose spans end a segment of its
        motion (``harness.engines.mjwarp.retirement``; 0: lockstep), else ``retirement.RETIRE``."""
        _import_warp()
        self.device = device or default_device()
        self.buffers = buffers
        self.retire = retire
        self._models: dict[tuple[int, str, str], Any] = {}
        global _NOTED
        if self.device == "cpu" and not _NOTED:
            import sys

            print(f"mjwarp: {CPU_DEVICE_NOTE}", file=sys.stderr, flush=True)
            _NOTED = True

    def batch(
        self, scene: Scene, task: TaskConfig, slot: Any = None, contact: np.ndarray | None = None
    ) -> Any:
        """A ``WorldBatch`` on the device model of ``scene`` with the contact bits ``contact``
        (default: its model's now; made once per model, target and bits, from a copy of
        the model with those bits: ``harness.engines.mjwarp.contact``), on ``slot`` (a
        ``DeviceSlot``: its stream and its device's lock) when given."""
        from harness.engines.mjwarp.batch import SMALL, Buffers, WorldBatch
        from harness.engines.mjwarp.contact import scene_with_contact
        from harness.engines.mjwarp.model import DeviceModel
        from harness.engines.mjwarp.slot import DeviceSlot

        slot = slot if slot is not None else DeviceSlot(self.device)
        bits = contact_bits(scene.model) if contact is None else contact
        key = self._key(scene, task, bits)
        dm = self._models.get(key)
        if dm is None:
            with slot:  # two streams of the device may ask at once: one makes it
                dm = self._models.get(key)
                if dm is None:
                    variant = scene_with_contact(scene, bits)
                    dm = self._models[key] = DeviceModel(variant, task, self.device)
        buffers = Buffers(*self.buffers) if self.buffers else SMALL
        if self.retire is None:
            return WorldBatch(dm, buffers=buffers, slot=slot)
        return WorldBatch(dm, buffers=buffers, slot=slot, retire=self.retire)

    @staticmethod
    def _key(scene: Scene, task: TaskConfig, bits: np.ndarray) -> tuple[int, str, str]:
        """A device model's key: one serves both arms of a two-arm robot (each world records
        its own job's arm; the target picks the object signals), and each set of contact bits
        is a model of its own."""
        from harness.engines.mjwarp.contact import contact_key

        return (id(scene.model), task.target_object.name, contact_key(bits))

    def slots(self, count: int) -> list[Any]:
        """``count`` ``DeviceSlot``s of this engine's device (one stream each, one lock)."""
        from harness.engines.mjwarp.slot import DeviceSlot

        return DeviceSlot.several(self.device, count)

    def memory_high_gb(self) -> float:
        """The most device memory Warp's pool has held (GB); 0 on the CPU or without a pool."""
        wp, _ = _import_warp()
        device = wp.get_device(self.device)
        if not device.is_cuda or not wp.is_mempool_enabled(device):
            return 0.0
        return wp.get_mempool_used_mem_high(device) / 1e9

    def execute(self, job: ExecutionJob) -> Execution:
        """One job in this process. Its device time is not the episode's wall-clock time on
        Warp's CPU device (a test device: minutes per episode) nor on a task model's first use
        (Warp compiles its kernels then): the budget is paused, so neither ends it as
        ``timeout``."""
        from harness.sim.budget import budget_paused

        packed = device_job(job)
        first = self._key(job.scene, job.task, packed.contact) not in self._models
        paused = budget_paused() if first or self.device == "cpu" else contextlib.nullcontext()
        with paused:
            outcome = self.batch(job.scene, job.task, contact=packed.contact).run([packed])[0]
        return Execution.of_batch(outcome, validity_enabled(job.task.pick))

    def execute_many(
        self, scene: Scene, jobs: list[DeviceJob], slot: Any = None
    ) -> tuple[list[PickOutcome], Any]:
        """Jobs of ``scene``'s task model and of one set of contact bits in one batch (on
        ``slot`` when given); the outcomes and the batch's timings."""
        if len({job.contact_key for job in jobs}) > 1:
            raise ValueError("one batch runs jobs of one set of contact bits")
        batch = self.batch(scene, jobs[0].task, slot, contact=jobs[0].contact)
        return batch.run(jobs), batch.timings
