"""Device arrays to the host on the calling stream, not on the CUDA default stream.

Warp's ``array.numpy()`` copies on the device's *default* stream "for synchronous behaviour
with other streams" (``warp/_src/types.py``, ``array.numpy``): that copy waits for the work
queued on every stream of the device. With several lane streams per device
(``HARNESS_STREAMS_PER_DEVICE``), each stream's download after its replay therefore waited
for every other stream's replay, while it held the host lock (``slot.HOST_LOCK``), so the
streams stepped one after another: a demo sweep's first outcomes came after 63-80 s on an H200
where graphs of the same steps on eight streams overlap 4.5x (``harness.benchmarks.
stream_overlap``). ``to_host`` copies on the current stream (the slot's) and waits for it alone.
"""

from __future__ import annotations

from typing import cast

import numpy as np
import warp as wp


def to_host(array: wp.array) -> np.ndarray:
    """A host copy of ``array``, made on the current stream of its device (which it waits for);
    on the CPU device, ``array.numpy()``."""
    return to_host_all([array])[0]


def to_host_all(arrays: list[wp.array]) -> list[np.ndarray]:
    """Host copies of ``arrays`` (of one device), made on its current stream, then one wait for
    it: each driver call lets go of the GIL and must win it back, which with a dozen busy
    threads in the process can take up to a switch interval (``harness.engines.mjwarp.
    switch``)."""
    if not arrays:
        return []
    device = wp.get_device(arrays[0].device)
    if not device.is_cuda:
        return [array.numpy() for array in arrays]
    stream = wp.get_stream(device)
    hosts = []
    for array in arrays:
        host = wp.empty(array.shape, dtype=array.dtype, device="cpu")
        wp.copy(host, array, stream=stream)
        hosts.append(host)
    wp.synchronize_stream(stream)
    return [np.array(host.numpy(), copy=True) for host in hosts]


class Downloads:
    """Host copies queued on the current stream without waiting (read after the caller waited
    for the stream past them): into page-locked host buffers, kept per ``key`` and grown as
    needed (a copy into pageable memory would wait for the stream). On the CPU device the
    copies are made at once."""

    def __init__(self) -> None:
        self._buffers: dict[tuple[object, int], wp.array] = {}

    def queue(self, key: object, arrays: list[wp.array]) -> list[wp.array | np.ndarray]:
        """Start copying ``arrays``; the returned handles are read with ``read`` once the
        stream is past the copies."""
        out: list[wp.array | np.ndarray] = []
        for k, array in enumerate(arrays):
            device = wp.get_device(array.device)
            if not device.is_cuda or array.size == 0:
                out.append(np.array(array.numpy(), copy=True))
                continue
            host = self._buffers.get((key, k))
            if host is None or host.shape[0] < array.shape[0] or host.shape[1:] != array.shape[1:]:
                rows = max(array.shape[0], 2 * (host.shape[0] if host is not None else 0), 1)
                shape = (rows, *array.shape[1:])
                host = wp.empty(shape, dtype=array.dtype, device="cpu", pinned=True)
                self._buffers[(key, k)] = host
            view = cast(wp.array, host[: array.shape[0]])  # a contiguous view: rows first
            wp.copy(view, array, stream=wp.get_stream(device))
            out.append(view)
        return out

    @staticmethod
    def read(handle: wp.array | np.ndarray) -> np.ndarray:
        """A copy of a queued download (after the stream is past it)."""
        if isinstance(handle, np.ndarray):
            return handle
        return np.array(handle.numpy(), copy=True)
