#!/usr/bin/env bash
# Runs the issue-24 GPU measurements one after another on the GPU box (started in the
# background with setsid by the call that unpacks the packages; later calls poll
# /tmp/results/status). Each job logs to /tmp/results/<job>.log; `pack` puts the results in
# one tarball under $1.
#   scripts/gpu_box_jobs.sh agree sweep throughput ...   (jobs in order)
#   scripts/gpu_box_jobs.sh pack OUT_DIR
set -uo pipefail
# Every device call re-syncs the box's copy of the checkout (a poll included): a job whose
# processes import while that happens fails (a sitting lost a run and 57 CPU rows to it). So
# the jobs run from a private copy made at the start.
if [ -z "${GPU_BOX_COPY:-}" ]; then
  copy="/tmp/repo.$$"
  cp -r "$PWD" "$copy" && cd "$copy" && GPU_BOX_COPY="$copy" exec bash scripts/gpu_box_jobs.sh "$@"
fi
source "$(dirname "$0")/gpu_box.sh" env
set +e
R=/tmp/results
mkdir -p "$R"
if [ "${1:-}" = "pack" ]; then
  tar -C "$R" --exclude='*.rrd' --exclude='videos' -cJf "$2/results.tar.xz" . && ls -la "$2"
  exit 0
fi
if [ "${1:-}" = "cache" ]; then  # the compiled kernels (reused by a later sitting's box)
  tar -C "$WARP_CACHE_PATH" -cf - . | xz -T0 -6 > "$2/warpcache.tar.xz" && ls -la "$2"
  exit 0
fi
for job in "$@"; do
  echo "$job started $(date -u +%T)" >> "$R/status"
  case "$job" in
    info)
      { nvidia-smi; nproc; free -g; python3 -c "import numpy, pandas, scipy, mujoco, mujoco_warp, warp; print(numpy.__version__, pandas.__version__, scipy.__version__, mujoco.__version__, mujoco_warp.__version__ if hasattr(mujoco_warp, '__version__') else '', warp.__version__)"; git log --oneline -1; cat /proc/sys/kernel/pid_max /proc/sys/kernel/threads-max /sys/fs/cgroup/pids.max; ulimit -u; } ;;
    agree)  # five arms x cube, banana x 32 seeds on both engines
      python3 -m harness.benchmarks.engines 32 "$R/agree" ;;
    sweep_cpu)
      python3 -m harness.cli sweep tasks/sweeps/demo.yaml --out "$R/sweep_mujoco" --no-progress ;;
    sweep_gpu)
      python3 -m harness.cli sweep tasks/sweeps/demo.yaml --engine mjwarp --workers 32 --out "$R/sweep_mjwarp" --no-progress ;;
    throughput)  # FR3 cube, 2048 episodes in one batch
      BENCH_BATCH=2048 BENCH_OBJECTS=cube python3 -m harness.benchmarks.engines 2048 "$R/throughput" fr3 ;;
    throughput_large)  # FR3 cube, 16384 episodes in batches of 4096; CPU-only rate from 2048
      BENCH_BATCH=4096 BENCH_CPU_EPISODES=2048 BENCH_OBJECTS=cube \
        python3 -m harness.benchmarks.engines 16384 "$R/throughput_large" fr3 ;;
    throughput_bucket)  # the same 16384 in batches of 4096 of similar schedule lengths
      BENCH_BATCH=4096 BENCH_BUCKET=2 BENCH_CPU_EPISODES=2048 BENCH_OBJECTS=cube \
        python3 -m harness.benchmarks.engines 16384 "$R/throughput_bucket" fr3 ;;
    tp_small)  # bucketed 16384 in batches of 4096 on the default (small) per-world buffers
      BENCH_BATCH=4096 BENCH_BUCKET=2 BENCH_CPU_EPISODES=2048 BENCH_OBJECTS=cube \
        python3 -m harness.benchmarks.engines 16384 "$R/tp_small" fr3 ;;
    tp_large)  # the same on the buffers used before (128 contacts, 768 rows per world)
      BENCH_BUFFERS=128,768 BENCH_BATCH=4096 BENCH_BUCKET=2 BENCH_CPU_EPISODES=2048 \
        BENCH_OBJECTS=cube python3 -m harness.benchmarks.engines 16384 "$R/tp_large" fr3 ;;
    tp_small_8192)  # 16384 in batches of 8192 on the small buffers
      BENCH_BATCH=8192 BENCH_CPU_EPISODES=2048 BENCH_OBJECTS=cube \
        python3 -m harness.benchmarks.engines 16384 "$R/tp_small_8192" fr3 ;;
    tp_small_32k)  # 32768 in bucketed batches of 8192 on the small buffers
      BENCH_BATCH=8192 BENCH_BUCKET=2 BENCH_CPU_EPISODES=2048 BENCH_OBJECTS=cube \
        python3 -m harness.benchmarks.engines 32768 "$R/tp_small_32k" fr3 ;;
    tp_slot1)  # bucketed 16384 in batches of 4096, one batch on the device at a time
      BENCH_SLOTS=1 BENCH_BATCH=4096 BENCH_BUCKET=2 BENCH_CPU_EPISODES=2048 BENCH_OBJECTS=cube \
        python3 -m harness.benchmarks.engines 16384 "$R/tp_slot1" fr3 ;;
    tp_slot2)  # the same with two batches in flight (two streams)
      BENCH_SLOTS=2 BENCH_BATCH=4096 BENCH_BUCKET=2 BENCH_CPU_EPISODES=2048 BENCH_OBJECTS=cube \
        python3 -m harness.benchmarks.engines 16384 "$R/tp_slot2" fr3 ;;
    tp_slot2_p16)  # two batches in flight, 16 planning processes (the device thread polls)
      BENCH_PLANNERS=16 BENCH_SLOTS=2 BENCH_BATCH=4096 BENCH_BUCKET=2 BENCH_CPU_EPISODES=2048 \
        BENCH_OBJECTS=cube python3 -m harness.benchmarks.engines 16384 "$R/tp_slot2_p16" fr3 ;;
    tp_slot2_8192)  # two batches of 8192 in flight
      BENCH_SLOTS=2 BENCH_BATCH=8192 BENCH_CPU_EPISODES=2048 BENCH_OBJECTS=cube \
        python3 -m harness.benchmarks.engines 16384 "$R/tp_slot2_8192" fr3 ;;
    profile)  # device time by kernel and solver iterations, 512 FR3 cube plans tiled
      python3 -m harness.benchmarks.device_profile "$R/profile" --worlds 8192 16384 32768 ;;
    profile_solver)  # the same at 4096 worlds with solver settings: cost and outcomes changed
      # (MJWarp's float32 tolerance is already 1e-6; the batch's slowest world takes 5-8
      # iterations a step, its mean world 1.4)
      python3 -m harness.benchmarks.device_profile "$R/profile_solver" --worlds 4096 \
        --iterations 3 5 --tolerance 1e-5 1e-4 ;;
    tp_16k)  # 32768 in bucketed batches of 16384, two slots
      BENCH_BATCH=16384 BENCH_BUCKET=2 BENCH_CPU_EPISODES=2048 BENCH_OBJECTS=cube \
        python3 -m harness.benchmarks.engines 32768 "$R/tp_16k" fr3 ;;
    tp_8k)  # 32768 in bucketed batches of 8192, two slots
      BENCH_BATCH=8192 BENCH_BUCKET=2 BENCH_CPU_EPISODES=2048 BENCH_OBJECTS=cube \
        python3 -m harness.benchmarks.engines 32768 "$R/tp_8k" fr3 ;;
    tp_8k_feed)  # 32768; a free slot takes up to 8192 of the shortest waiting, from 4096 up
      BENCH_BATCH=8192 BENCH_MIN_BATCH=4096 BENCH_CPU_EPISODES=2048 BENCH_OBJECTS=cube \
        python3 -m harness.benchmarks.engines 32768 "$R/tp_8k_feed" fr3 ;;
    tp_16k_feed)  # the same with batches of up to 16384
      BENCH_BATCH=16384 BENCH_MIN_BATCH=4096 BENCH_CPU_EPISODES=2048 BENCH_OBJECTS=cube \
        python3 -m harness.benchmarks.engines 32768 "$R/tp_16k_feed" fr3 ;;
    tp_8k_lock)  # the bucketed 8192 batches again (lockstep, the default) beside tp_8k_retire
      BENCH_BATCH=8192 BENCH_BUCKET=2 BENCH_CPU_EPISODES=2048 BENCH_OBJECTS=cube \
        python3 -m harness.benchmarks.engines 32768 "$R/tp_8k_lock" fr3 ;;
    tp_8k_retire)  # the same with finished worlds retired (a quarter per segment)
      BENCH_RETIRE=0.25 BENCH_BATCH=8192 BENCH_BUCKET=2 BENCH_CPU_EPISODES=2048 \
        BENCH_OBJECTS=cube python3 -m harness.benchmarks.engines 32768 "$R/tp_8k_retire" fr3 ;;
    tp_8k_warm)  # bucketed 8192 batches; the idle device starts from 4096 planned (warm start)
      BENCH_BATCH=8192 BENCH_BUCKET=2 BENCH_MIN_BATCH=4096 BENCH_CPU_EPISODES=2048 \
        BENCH_OBJECTS=cube python3 -m harness.benchmarks.engines 32768 "$R/tp_8k_warm" fr3 ;;
    tp_16k_warm)  # 65536 in bucketed batches of 16384 with the warm start
      BENCH_BATCH=16384 BENCH_BUCKET=2 BENCH_MIN_BATCH=4096 BENCH_CPU_EPISODES=2048 \
        BENCH_OBJECTS=cube python3 -m harness.benchmarks.engines 65536 "$R/tp_16k_warm" fr3 ;;
    tp_16k_warm_32k)  # 32768 in bucketed batches of 16384 with the warm start
      BENCH_BATCH=16384 BENCH_BUCKET=2 BENCH_MIN_BATCH=4096 BENCH_CPU_EPISODES=2048 \
        BENCH_OBJECTS=cube python3 -m harness.benchmarks.engines 32768 "$R/tp_16k_warm_32k" fr3 ;;
    tp_lanes_16k)  # 65536 streamed through 16384 lanes (no batches, no padding); CPU rate 2048
      BENCH_LANES=16384 BENCH_CPU_EPISODES=2048 BENCH_OBJECTS=cube \
        python3 -m harness.benchmarks.engines 65536 "$R/tp_lanes_16k" fr3 ;;
    tp_lanes_32k)  # the same through 32768 lanes
      BENCH_LANES=32768 BENCH_CPU_EPISODES=512 BENCH_OBJECTS=cube \
        python3 -m harness.benchmarks.engines 65536 "$R/tp_lanes_32k" fr3 ;;
    tp_lanes_8k)  # the same through 8192 lanes
      BENCH_LANES=8192 BENCH_CPU_EPISODES=512 BENCH_OBJECTS=cube \
        python3 -m harness.benchmarks.engines 65536 "$R/tp_lanes_8k" fr3 ;;
    tp_8k_warm_65k)  # the lockstep baseline: 65536 in bucketed batches of 8192, warm start
      BENCH_BATCH=8192 BENCH_BUCKET=2 BENCH_MIN_BATCH=4096 BENCH_CPU_EPISODES=512 \
        BENCH_OBJECTS=cube python3 -m harness.benchmarks.engines 65536 "$R/tp_8k_warm_65k" fr3 ;;
    fr3_sweep_yaml)  # issue 34's FR3 cube sweep: 3 approach cones x 1,000 seeds (3,000 rows)
      printf '%s\n' 'name: fr3_cube_cones' 'tasks:' "  - $PWD/tasks/pick/fr3.yaml" 'axes:' \
        '  pick.approach_filter: [[downward, 120], [downward, 140], [downward, 160]]' \
        '  object.mesh: [cube]' 'episodes_per_point: 1000' 'seed: 0' 'record: none' \
        > /tmp/fr3_cube_cones.yaml; cat /tmp/fr3_cube_cones.yaml ;;
    fr3_big_yaml)  # the same cones x 15,000 seeds (45,000 rows): a throughput sweep for two GPUs
      sed 's/episodes_per_point: 1000/episodes_per_point: 15000/; s/fr3_cube_cones/fr3_big/' \
        /tmp/fr3_cube_cones.yaml > /tmp/fr3_big.yaml; cat /tmp/fr3_big.yaml ;;
    fr3_mid_yaml)  # the cones x 5,000 seeds (15,000 rows): the two-GPU ratio within a short sitting
      sed 's/episodes_per_point: 1000/episodes_per_point: 5000/; s/fr3_cube_cones/fr3_mid/' \
        /tmp/fr3_cube_cones.yaml > /tmp/fr3_mid.yaml; cat /tmp/fr3_mid.yaml ;;
    fr3_mid_all)  # every GPU, a process per GPU
      timeout 240 python3 -m harness.cli sweep /tmp/fr3_mid.yaml --engine mjwarp \
        --workers "$(( $(nproc) - 1 ))" --out "$R/fr3_mid_all" --no-progress --record none ;;
    fr3_mid_one)  # the first GPU alone, planning on the same cores
      HARNESS_WARP_DEVICE=cuda:0 timeout 240 python3 -m harness.cli sweep /tmp/fr3_mid.yaml \
        --engine mjwarp --workers "$(( $(nproc) - 1 ))" --out "$R/fr3_mid_one" --no-progress \
        --record none ;;
    fr3_big_all)  # every GPU, a process per GPU (the default with several devices)
      timeout 360 python3 -m harness.cli sweep /tmp/fr3_big.yaml --engine mjwarp \
        --workers "$(( $(nproc) - 1 ))" --out "$R/fr3_big_all" --no-progress --record none ;;
    fr3_big_all_flight2)  # fr3_big_all with 2 episodes a lane in flight (the rule before 2026-11-28 evening)
      HARNESS_IN_FLIGHT_PER_LANE=2 timeout 360 python3 -m harness.cli sweep /tmp/fr3_big.yaml \
        --engine mjwarp --workers "$(( $(nproc) - 1 ))" --out "$R/fr3_big_all_flight2" \
        --no-progress --record none ;;
    fr3_big_one_flight2)  # fr3_big_one with 2 episodes a lane in flight
      HARNESS_IN_FLIGHT_PER_LANE=2 HARNESS_WARP_DEVICE=cuda:0 timeout 360 python3 -m harness.cli \
        sweep /tmp/fr3_big.yaml --engine mjwarp --workers "$(( $(nproc) - 1 ))" \
        --out "$R/fr3_big_one_flight2" --no-progress --record none ;;
    fr3_big_oneproc)  # every GPU from one process (HARNESS_PROCESS_PER_DEVICE=0, as before)
      HARNESS_PROCESS_PER_DEVICE=0 timeout 360 python3 -m harness.cli sweep /tmp/fr3_big.yaml \
        --engine mjwarp --workers "$(( $(nproc) - 1 ))" --out "$R/fr3_big_oneproc" \
        --no-progress --record none ;;
    fr3_big_one)  # the first GPU alone, planning on the same cores
      HARNESS_WARP_DEVICE=cuda:0 timeout 360 python3 -m harness.cli sweep /tmp/fr3_big.yaml \
        --engine mjwarp --workers "$(( $(nproc) - 1 ))" --out "$R/fr3_big_one" --no-progress \
        --record none ;;
    fr3_big_all_tug8)  # fr3_big_all with tug rounds of 8 physics steps a CUDA graph
      HARNESS_TUG_STEPS_PER_GRAPH=8 timeout 360 python3 -m harness.cli sweep /tmp/fr3_big.yaml \
        --engine mjwarp --workers "$(( $(nproc) - 1 ))" --out "$R/fr3_big_all_tug8" \
        --no-progress --record none ;;
    raise_pid_max)  # 4,194,304: the kernel's PID_MAX_LIMIT on 64-bit, what systemd >= 243 sets
      # (the box boots with 32,768; a thread takes a PID, harness.runs.thread_budget)
      echo 4194304 > /proc/sys/kernel/pid_max; cat /proc/sys/kernel/pid_max ;;
    demo_gpu_streams8)  # the demo with 8 streams a device (the default before 2026-11-28 evening)
      HARNESS_STREAMS_PER_DEVICE=8 python3 -m harness.cli sweep tasks/sweeps/demo.yaml \
        --engine mjwarp --workers "$(( $(nproc) - 1 ))" --out "$R/demo_gpu_streams8" \
        --no-progress --record none ;;
    demo_gpu_streams16)  # the demo with every task model's stream at once (16 slots for 10 keys)
      HARNESS_STREAMS_PER_DEVICE=16 python3 -m harness.cli sweep tasks/sweeps/demo.yaml \
        --engine mjwarp --workers "$(( $(nproc) - 1 ))" --out "$R/demo_gpu_streams16" \
        --no-progress --record none ;;
    fr3_big_all_2048)  # fr3_big_all at 2,048 lanes a GPU (today's default there: 8,192)
      HARNESS_LANES=2048 timeout 360 python3 -m harness.cli sweep /tmp/fr3_big.yaml \
        --engine mjwarp --workers "$(( $(nproc) - 1 ))" --out "$R/fr3_big_all_2048" \
        --no-progress --record none ;;
    fr3_big_one_2048)  # fr3_big_one at 2,048 lanes
      HARNESS_LANES=2048 HARNESS_WARP_DEVICE=cuda:0 timeout 360 python3 -m harness.cli sweep \
        /tmp/fr3_big.yaml --engine mjwarp --workers "$(( $(nproc) - 1 ))" \
        --out "$R/fr3_big_one_2048" --no-progress --record none ;;
    fr3_big_one_tug8)  # fr3_big_one with tug rounds of 8 physics steps a CUDA graph
      HARNESS_TUG_STEPS_PER_GRAPH=8 HARNESS_WARP_DEVICE=cuda:0 timeout 360 python3 -m \
        harness.cli sweep /tmp/fr3_big.yaml --engine mjwarp --workers "$(( $(nproc) - 1 ))" \
        --out "$R/fr3_big_one_tug8" --no-progress --record none ;;
    stream_overlap_loop)  # demo-sized streams, a visit's 136 steps unrolled against looped, one run
      python3 -m harness.benchmarks.stream_overlap "$R/stream_overlap_loop" --worlds 128 \
        --streams 1 4 10 --steps 136 --rounds 5 --graphs unrolled loop --noslip on ;;
    demo_gpu_per_arm)  # the demo with a stream per arm (before 2026-11-28 noon: ten streams)
      HARNESS_STREAM_PER_ARM=1 python3 -m harness.cli sweep tasks/sweeps/demo.yaml \
        --engine mjwarp --workers "$(( $(nproc) - 1 ))" --out "$R/demo_gpu_per_arm" \
        --no-progress --record none ;;
    demo_gpu_loop)  # the demo with each visit's and tug round's steps in a device-side loop
      HARNESS_GRAPH_LOOP=1 python3 -m harness.cli sweep tasks/sweeps/demo.yaml \
        --engine mjwarp --workers "$(( $(nproc) - 1 ))" --out "$R/demo_gpu_loop" \
        --no-progress --record none ;;
    fr3_gpu_loop)  # issue 34's 3,000-row FR3 sweep with the device-side loops
      HARNESS_GRAPH_LOOP=1 python3 -m harness.cli sweep /tmp/fr3_cube_cones.yaml \
        --engine mjwarp --workers "$(( $(nproc) - 1 ))" --out "$R/fr3_gpu_loop" \
        --no-progress --record none ;;
    demo_gpu_tug8)  # the demo with tug rounds of 8 physics steps a CUDA graph
      HARNESS_TUG_STEPS_PER_GRAPH=8 python3 -m harness.cli sweep tasks/sweeps/demo.yaml \
        --engine mjwarp --workers "$(( $(nproc) - 1 ))" --out "$R/demo_gpu_tug8" \
        --no-progress --record none ;;
    compile_fr3)  # the sweep's kernels into Warp's cache, one progress line per model
      python3 -m harness.cli compile /tmp/fr3_cube_cones.yaml ;;
    compile_demo)
      python3 -m harness.cli compile tasks/sweeps/demo.yaml ;;
    fr3_cpu)  # the CPU engine on every core
      python3 -m harness.cli sweep /tmp/fr3_cube_cones.yaml --workers "$(nproc)" \
        --out "$R/fr3_cpu" --no-progress --record none ;;
    fr3_gpu)  # the product path: planning on every core but one, lanes on the GPU(s)
      python3 -m harness.cli sweep /tmp/fr3_cube_cones.yaml --engine mjwarp \
        --workers "$(( $(nproc) - 1 ))" --out "$R/fr3_gpu" --no-progress --record none ;;
    fr3_gpu_4096)  # the same with 4,096 lanes: one wave for every job (groups pipelined)
      HARNESS_LANES=4096 python3 -m harness.cli sweep /tmp/fr3_cube_cones.yaml --engine mjwarp \
        --workers "$(( $(nproc) - 1 ))" --out "$R/fr3_gpu_4096" --no-progress --record none ;;
    demo_gpu_256)  # the demo with 256 lanes per stream (one wave per task model's jobs)
      HARNESS_LANES=256 python3 -m harness.cli sweep tasks/sweeps/demo.yaml --engine mjwarp \
        --workers "$(( $(nproc) - 1 ))" --out "$R/demo_gpu_256" --no-progress --record none ;;
    demo_gpu_interval32)  # the demo with host visits every 32 control steps instead of 8
      HARNESS_LANE_INTERVAL=32 python3 -m harness.cli sweep tasks/sweeps/demo.yaml \
        --engine mjwarp --workers "$(( $(nproc) - 1 ))" --out "$R/demo_gpu_interval32" \
        --no-progress --record none ;;
    demo_gpu_block)  # the demo with the slots waiting in the driver (now the default)
      HARNESS_DEVICE_WAIT=block python3 -m harness.cli sweep tasks/sweeps/demo.yaml \
        --engine mjwarp --workers "$(( $(nproc) - 1 ))" --out "$R/demo_gpu_block" \
        --no-progress --record none ;;
    demo_gpu_poll)  # the demo with the slots polling their streams (the default before)
      HARNESS_DEVICE_WAIT=poll python3 -m harness.cli sweep tasks/sweeps/demo.yaml \
        --engine mjwarp --workers "$(( $(nproc) - 1 ))" --out "$R/demo_gpu_poll" \
        --no-progress --record none ;;
    demo_gpu_switch)  # the demo with the interpreter switching threads every 0.5 ms
      HARNESS_SWITCH_INTERVAL_MS=0.5 python3 -m harness.cli sweep tasks/sweeps/demo.yaml \
        --engine mjwarp --workers "$(( $(nproc) - 1 ))" --out "$R/demo_gpu_switch" \
        --no-progress --record none ;;
    fr3_gpu_one)  # fr3_gpu on the first GPU alone (the two-GPU kind's one-GPU figure)
      HARNESS_WARP_DEVICE=cuda:0 timeout 300 python3 -m harness.cli sweep /tmp/fr3_cube_cones.yaml \
        --engine mjwarp --workers "$(( $(nproc) - 1 ))" --out "$R/fr3_gpu_one" --no-progress \
        --record none ;;
    fr3_gpu_all)  # fr3_gpu on every GPU of the box
      timeout 300 python3 -m harness.cli sweep /tmp/fr3_cube_cones.yaml --engine mjwarp \
        --workers "$(( $(nproc) - 1 ))" --out "$R/fr3_gpu_all" --no-progress --record none ;;
    bench_all)  # issue 34's M episodes/h: 65,536 FR3 cube episodes through 8,192 lanes, every GPU
      BENCH_LANES=8192 BENCH_CPU_EPISODES=512 BENCH_OBJECTS=cube timeout 420 \
        python3 -m harness.benchmarks.engines 65536 "$R/bench_all" fr3 ;;
    bench_one)  # the same on the first GPU alone
      HARNESS_WARP_DEVICE=cuda:0 BENCH_LANES=8192 BENCH_CPU_EPISODES=512 BENCH_OBJECTS=cube \
        timeout 420 python3 -m harness.benchmarks.engines 65536 "$R/bench_one" fr3 ;;
    demo_gpu_conn32)  # the demo with 32 hardware work queues per device (CUDA's default: 8)
      # for 8 lane streams and 8 tug streams (NVIDIA's CUDA_DEVICE_MAX_CONNECTIONS)
      CUDA_DEVICE_MAX_CONNECTIONS=32 python3 -m harness.cli sweep tasks/sweeps/demo.yaml \
        --engine mjwarp --workers "$(( $(nproc) - 1 ))" --out "$R/demo_gpu_conn32" \
        --no-progress --record none ;;
    demo_gpu_ahead)  # the demo with each lane replay queued before the last is collected
      HARNESS_LANE_AHEAD=1 python3 -m harness.cli sweep tasks/sweeps/demo.yaml \
        --engine mjwarp --workers "$(( $(nproc) - 1 ))" --out "$R/demo_gpu_ahead" \
        --no-progress --record none ;;
    fr3_gpu_ahead)  # fr3_gpu with each lane replay queued before the last is collected
      HARNESS_LANE_AHEAD=1 python3 -m harness.cli sweep /tmp/fr3_cube_cones.yaml --engine mjwarp \
        --workers "$(( $(nproc) - 1 ))" --out "$R/fr3_gpu_ahead" --no-progress --record none ;;
    demo_gpu_interval4)  # the demo with host visits every 4 control steps instead of 8
      HARNESS_LANE_INTERVAL=4 python3 -m harness.cli sweep tasks/sweeps/demo.yaml \
        --engine mjwarp --workers "$(( $(nproc) - 1 ))" --out "$R/demo_gpu_interval4" \
        --no-progress --record none ;;
    check_unit_gpu)  # issue 35: the unit the first check left unconfirmed, 800 seeds of its own
      # (the tune of an earlier sitting, carried in .gpu/tune_canon)
      [ -d "$R/tune_canon" ] || cp -r .gpu/tune_canon "$R/tune_canon"
      python3 -m harness.cli tune --check "$R/tune_canon" --unit "lift2 left banana" \
        --seed 888888 --episodes 800 --engine mjwarp --workers "$(( $(nproc) - 1 ))" \
        --out "$R/tune_canon/check_lift2_left_banana" ;;
    demo_cpu)
      python3 -m harness.cli sweep tasks/sweeps/demo.yaml --workers "$(nproc)" \
        --out "$R/demo_cpu" --no-progress --record none ;;
    demo_gpu)
      python3 -m harness.cli sweep tasks/sweeps/demo.yaml --engine mjwarp \
        --workers "$(( $(nproc) - 1 ))" --out "$R/demo_gpu" --no-progress --record none ;;
    demo_gpu_beside)  # the demo with the tug in rounds beside the lanes (before 2026-11-28 noon)
      HARNESS_TUG_LANES=0 python3 -m harness.cli sweep tasks/sweeps/demo.yaml --engine mjwarp \
        --workers "$(( $(nproc) - 1 ))" --out "$R/demo_gpu_beside" --no-progress --record none ;;
    fr3_gpu_beside)  # fr3_gpu with the tug in rounds beside the lanes
      HARNESS_TUG_LANES=0 python3 -m harness.cli sweep /tmp/fr3_cube_cones.yaml --engine mjwarp \
        --workers "$(( $(nproc) - 1 ))" --out "$R/fr3_gpu_beside" --no-progress --record none ;;
    fr3_big_one_beside)  # fr3_big_one with the tug in rounds beside the lanes
      HARNESS_TUG_LANES=0 HARNESS_WARP_DEVICE=cuda:0 timeout 360 python3 -m harness.cli sweep \
        /tmp/fr3_big.yaml --engine mjwarp --workers "$(( $(nproc) - 1 ))" \
        --out "$R/fr3_big_one_beside" --no-progress --record none ;;
    tune_canon_gpu)  # issue 35: the default (power-sized) tune of the canonical tasks
      python3 -m harness.cli tune tasks/sweeps/canonical.yaml --engine mjwarp \
        --workers "$(( $(nproc) - 1 ))" --out "$R/tune_canon" --write "$R/tune_canon/written" ;;
    check_canon_gpu)  # its decisions on 200 fresh paired seeds (sweep seed 777777)
      python3 -m harness.cli tune --check "$R/tune_canon" --seed 777777 --episodes 200 \
        --engine mjwarp --workers "$(( $(nproc) - 1 ))" ;;
    tune_canon_cpu_capped)  # the CPU engine, a small grid and a race capped by --budget
      # (800 screening + at most 1600 race episodes: about 4 minutes on 16 cores, estimated)
      python3 -m harness.cli tune tasks/sweeps/canonical.yaml --directions canonical \
        --step 30 --bands 0 --episodes 5 --budget 1600 --workers "$(nproc)" \
        --out "$R/tune_canon_cpu" --write "$R/tune_canon_cpu/written" ;;
    check_canon_cpu)  # its decisions on 40 fresh paired seeds
      python3 -m harness.cli tune --check "$R/tune_canon_cpu" --seed 777777 --episodes 40 \
        --workers "$(nproc)" ;;
    demo_gpu_streams)  # demo_gpu again in a directory of its own (a per-stream line each)
      python3 -m harness.cli sweep tasks/sweeps/demo.yaml --engine mjwarp \
        --workers "$(( $(nproc) - 1 ))" --out "$R/demo_gpu_streams" --no-progress --record none ;;
    demo_gpu_one_stream)  # the same, one lane stream per device at a time (before issue 34's streams)
      HARNESS_STREAMS_PER_DEVICE=1 python3 -m harness.cli sweep tasks/sweeps/demo.yaml \
        --engine mjwarp --workers "$(( $(nproc) - 1 ))" --out "$R/demo_gpu_one_stream" \
        --no-progress --record none ;;
    compile_canon)
      python3 -m harness.cli compile tasks/sweeps/canonical.yaml ;;
    canon_cpu)
      python3 -m harness.cli sweep tasks/sweeps/canonical.yaml --workers "$(nproc)" \
        --out "$R/canon_cpu" --no-progress --record none ;;
    canon_gpu)
      python3 -m harness.cli sweep tasks/sweeps/canonical.yaml --engine mjwarp \
        --workers "$(( $(nproc) - 1 ))" --out "$R/canon_gpu" --no-progress --record none ;;
    fr3_objects_yaml)  # issue 34's tune target: one arm (FR3) x every object of tasks/objects
      printf '%s\n' 'name: fr3_objects' 'tasks:' "  - $PWD/tasks/pick/fr3.yaml" 'axes:' \
        '  object.mesh: [ball, banana, book, bottle, box, can, cube, mug, plate]' \
        'episodes_per_point: 40' 'seed: 0' 'record: none' > /tmp/fr3_objects.yaml
      cat /tmp/fr3_objects.yaml ;;
    compile_fr3_objects)
      python3 -m harness.cli compile /tmp/fr3_objects.yaml ;;
    tune_fr3_objects_gpu)  # a race of up to 1,000 seeds per contender (looks of 125 on the GPU)
      python3 -m harness.cli tune /tmp/fr3_objects.yaml --engine mjwarp --directions canonical \
        --step 15 --bands 1 --max-seeds 1000 --workers "$(( $(nproc) - 1 ))" \
        --out "$R/tune_fr3_objects" ;;
    demo100_cpu)  # the five-arm agreement set: the demo sweep at 100 seeds a point (3,000 rows)
      python3 -m harness.cli sweep tasks/sweeps/demo.yaml --episodes-per-point 100 \
        --workers "$(nproc)" --out "$R/demo100_cpu" --no-progress --record none ;;
    demo100_gpu)
      python3 -m harness.cli sweep tasks/sweeps/demo.yaml --episodes-per-point 100 --engine mjwarp \
        --workers "$(( $(nproc) - 1 ))" --out "$R/demo100_gpu" --no-progress --record none ;;
    noslip_kernels)  # the noslip pass: off, MuJoCo Warp's kernel, the block kernel (5 models)
      python3 -m harness.benchmarks.noslip_kernels "$R/noslip_kernels" --worlds 1024 --steps 200 ;;
    demo_gpu_profiled)  # demo_gpu with every thread of the parent sampled (harness.runs.sampler)
      HARNESS_SAMPLE_PROFILE="$R/demo_gpu_profile.txt" python3 -c \
        'from harness.runs.sampler import start_from_env; start_from_env(); from harness.cli import main; raise SystemExit(main())' \
        sweep tasks/sweeps/demo.yaml --engine mjwarp --workers "$(( $(nproc) - 1 ))" \
        --out "$R/demo_gpu_profiled" --no-progress --record none ;;
    stream_overlap)  # do lane streams on one device step side by side? (graphs on K streams)
      python3 -m harness.benchmarks.stream_overlap "$R/stream_overlap" --worlds 64 512 \
        --streams 1 2 4 8 ;;
    demo_gpu_s2)  # the demo sweep with two lane streams per device at a time
      HARNESS_STREAMS_PER_DEVICE=2 python3 -m harness.cli sweep tasks/sweeps/demo.yaml \
        --engine mjwarp --workers "$(( $(nproc) - 1 ))" --out "$R/demo_gpu_s2" \
        --no-progress --record none ;;
    banana_yaml)  # FR3 banana, the demo's seeds: where the table replays disagree
      printf '%s\n' 'name: fr3_banana' 'tasks:' "  - $PWD/tasks/pick/fr3.yaml" 'axes:' \
        '  pick.approach_filter: [[downward, 120], [downward, 140], [downward, 160]]' \
        '  object.mesh: [banana]' 'episodes_per_point: 40' 'seed: 0' 'record: none' \
        > /tmp/fr3_banana.yaml ;;
    banana_cpu)
      python3 -m harness.cli sweep /tmp/fr3_banana.yaml --workers "$(nproc)" \
        --out "$R/banana_cpu" --no-progress --record none ;;
    banana_gpu_block)  # the block noslip kernel (the default)
      python3 -m harness.cli sweep /tmp/fr3_banana.yaml --engine mjwarp \
        --workers "$(( $(nproc) - 1 ))" --out "$R/banana_gpu_block" --no-progress --record none ;;
    banana_gpu_mjwarp)  # MuJoCo Warp's own noslip kernel
      HARNESS_NOSLIP_KERNEL=mjwarp python3 -m harness.cli sweep /tmp/fr3_banana.yaml \
        --engine mjwarp --workers "$(( $(nproc) - 1 ))" --out "$R/banana_gpu_mjwarp" \
        --no-progress --record none ;;
    *) echo "unknown job $job" ;;
  esac > "$R/$job.log" 2>&1
  echo "$job ended $(date -u +%T) rc=$?" >> "$R/status"
done
echo "all done" >> "$R/status"
