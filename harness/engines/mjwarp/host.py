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
