"""Compile MuJoCo Warp's CUDA kernels here, ahead of time, into a Warp kernel cache for the GPU box.

Why: a fresh GPU box spends ~260 s in NVRTC before its first batch. The box (Warp 1.19.0, CUDA
toolkit 13.4, driver 13.0, so Warp picks CUBIN at the device's arch: ``sm90.cubin``) finds a
module in ``$WARP_CACHE_PATH/<warp version>/wp_<module>_<hash7>/`` and loads it "(cached)".

How: run the mjwarp engine once per task model on Warp's CPU device, which creates and registers
every module (MuJoCo Warp builds most kernels lazily, as closures). A module's hash depends on the
``block_dim`` it is launched with, and the CUDA launches use other block dims than the CPU ones
(CPU launches use 1); so each module is hashed at the candidate block dims, and the variants
named in the box's logs (``--box-log``: lines ``Module NAME HASH load on device 'cuda:0' ...``)
are compiled for ``--arch`` with NVRTC (no GPU needed). Without logs, each module is compiled at
its default block_dim. Modules that only a CUDA code path creates (``is_cuda`` branches) are not
made here; they are listed as missing.

    PYTHONPATH=$PWD python scripts/warp_aot.py --out /tmp/warpcache_build \
        --box-log /work/gpu_results/s3/tp_small.log --arms fr3 --objects cube
"""

from __future__ import annotations

import argparse
import os
import re
import time
from pathlib import Path
from typing import Any

BLOCK_DIMS = (256, 128, 64, 32, 512, 1024, 16, 8)
_LOG_LINE = re.compile(r"^Module (\S+) ([0-9a-f]{7}) load on device 'cuda")


def box_modules(logs: list[Path]) -> set[tuple[str, str]]:
    """(module name, hash prefix) pairs that the box loaded, from its logs."""
    out: set[tuple[str, str]] = set()
    for log in logs:
        for line in log.read_text(errors="replace").splitlines():
            match = _LOG_LINE.match(line)
            if match:
                out.add((match.group(1), match.group(2)))
    return out


def create_modules(arms: tuple[str, ...], objects: tuple[str, ...]) -> None:
    """Run one planned job per task model on Warp's CPU device, so every module is registered."""
    from harness.benchmarks import engines as bench
    from harness.engines.mjwarp.engine import MjwarpEngine
    from harness.episode.scene_cache import get_scene

    engine = MjwarpEngine("cpu")
    scenes: dict[Any, Any] = {}
    for task in bench.tasks(arms, objects):
        for spec in bench.specs([task], 4):
            _, job = bench._plan(spec)  # pyright: ignore[reportPrivateUsage]
            if job is not None:
                engine.execute_many(get_scene(job.task, scenes).scene, [job])
                break


def variants(wanted: set[tuple[str, str]]) -> tuple[list[tuple[Any, int]], set[tuple[str, str]]]:
    """(module, block_dim) to compile, and the wanted pairs no registered module hashes to."""
    import warp as wp
    from warp._src import context

    chosen: list[tuple[Any, int]] = []
    found: set[tuple[str, str]] = set()
    for name, module in list(context.user_modules.items()):
        if not module.kernels:
            continue
        if not wanted:
            chosen.append((module, int(module.options["block_dim"])))
            continue
        for block_dim in BLOCK_DIMS:
            digest = module.get_module_hash(block_dim).hex()[:7]
            if (name, digest) in wanted and (name, digest) not in found:
                found.add((name, digest))
                chosen.append((module, block_dim))
        if name.startswith("harness.") and not any(n == name for n, _ in found):
            chosen.append((module, int(module.options["block_dim"])))  # this checkout's own kernels
    del wp
    return chosen, wanted - found


def compile_all(chosen: list[tuple[Any, int]], out: Path, arch: int) -> int:
    """Compile each variant to ``out/<warp version>/wp_<name>_<hash>/``; how many were built."""
    import warp as wp

    root = out / wp.config.version
    built = 0
    for module, block_dim in chosen:
        options = module.resolve_options(wp.config, block_dim=block_dim)
        folder = root / module.get_module_identifier(block_dim=block_dim)
        clock = time.perf_counter()
        module._compile(None, str(folder), output_arch=arch, use_ptx=False, options=options)
        built += 1
        took = time.perf_counter() - clock
        print(f"{folder.name} block_dim={block_dim} {took:.1f} s", flush=True)
    return built


def main() -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    parser.add_argument("--out", type=Path, required=True, help="the cache dir (WARP_CACHE_PATH)")
    parser.add_argument("--arms", nargs="+", default=["fr3"])
    parser.add_argument("--objects", nargs="+", default=["cube"])
    parser.add_argument("--arch", type=int, default=90)
    parser.add_argument("--box-log", nargs="*", type=Path, default=[])
    args = parser.parse_args()
    os.environ.setdefault("HARNESS_WARP_DEVICE", "cpu")
    wanted = box_modules(args.box_log)
    create_modules(tuple(args.arms), tuple(args.objects))
    chosen, missing = variants(wanted)
    print(f"variants: {len(chosen)}; in the logs: {len(wanted)}, not made here: {len(missing)}")
    for name, digest in sorted(missing):
        print(f"  missing {name} {digest}")
    print(f"built {compile_all(chosen, args.out, args.arch)} into {args.out}")


if __name__ == "__main__":
    main()
