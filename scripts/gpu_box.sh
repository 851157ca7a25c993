#!/usr/bin/env bash
# The GPU box sitting of issue 24 (docs/engines.md, "Setting up the GPU box"): the box has no
# package index, so the project's missing packages travel as one xz tarball of a `pip install
# --target` tree made here (cp312, manylinux), split into parts carried one per call.
#   scripts/gpu_box.sh stash DIR      copy the carried part(s) in DIR to /tmp/parts
#   scripts/gpu_box.sh setup          unpack /tmp/parts into /tmp/site (once per machine)
#   source scripts/gpu_box.sh env     put /tmp/site and this checkout on PYTHONPATH
set -euo pipefail
SITE=/tmp/site
case "${1:-}" in
  stash)
    mkdir -p /tmp/parts
    shopt -s nullglob
    carried=("$2"/part.* "$2"/warpcache.*)
    [ ${#carried[@]} -gt 0 ] || { echo "nothing to stash in $2" >&2; exit 1; }
    cp "${carried[@]}" /tmp/parts/
    ls -la /tmp/parts
    ;;
  setup)
    if [ ! -f "$SITE/.done" ]; then
      mkdir -p "$SITE"
      cat /tmp/parts/part.* | xz -d -T0 | tar -x -i -C "$SITE"
      touch "$SITE/.done"
    fi
    # kernels compiled by an earlier sitting (scripts/gpu_box_jobs.sh cache), when carried
    # (one file warpcache.tar.xz, or parts warpcache.tar.xz.partNN from scripts/warp_aot.py)
    if compgen -G "/tmp/parts/warpcache.tar.xz*" > /dev/null && [ ! -d /tmp/warpcache ]; then
      mkdir -p /tmp/warpcache
      cat /tmp/parts/warpcache.tar.xz* | xz -d -T0 | tar -x -C /tmp/warpcache
    fi
    ;;
  env)
    export PYTHONPATH="$SITE:$SITE/cmeel.prefix/lib/python3.12/site-packages:$PWD"
    export WARP_CACHE_PATH=/tmp/warpcache MUJOCO_GL=disable PYTHONUNBUFFERED=1  # the box has no EGL
    ;;
  *)
    echo "usage: $0 stash DIR | setup | env" >&2
    exit 2
    ;;
esac
