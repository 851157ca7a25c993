#!/usr/bin/env bash
# A sitting on the lent 16-core box (docs/execution.md, "Measuring on the 16-core box"): the box
# has no package index, so the project's missing packages travel as one xz tarball of a `pip
# install --target` tree made here (scripts/box_pack.sh: cp312, manylinux), split into parts
# carried one per call.
#   scripts/box.sh stash DIR      copy the carried part(s) in DIR to /tmp/parts
#   scripts/box.sh setup          unpack /tmp/parts into /tmp/site (once per machine)
#   source scripts/box.sh env     put /tmp/site and this checkout on PYTHONPATH
set -euo pipefail
SITE=/tmp/site
case "${1:-}" in
  stash)
    mkdir -p /tmp/parts
    shopt -s nullglob
    carried=("$2"/part.*)
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
    ;;
  env)
    export PYTHONPATH="$SITE:$SITE/cmeel.prefix/lib/python3.12/site-packages:$PWD"
    export MUJOCO_GL=disable PYTHONUNBUFFERED=1  # no rendering on the box
    ;;
  *)
    echo "usage: $0 stash DIR | setup | env" >&2
    exit 2
    ;;
esac
