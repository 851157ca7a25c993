#!/usr/bin/env bash
# Builds the package pack that a sitting on the lent 16-core box carries (docs/execution.md,
# "Measuring on the 16-core box"): the box has Python 3.12 with numpy, scipy, pandas, pyarrow,
# matplotlib, ... but no package index, so every package it lacks travels as a `pip install
# --target` tree of cp312 manylinux wheels, packed as one xz tarball and split into 45 MB parts,
# one carried per call.
#   scripts/box_pack.sh [OUT_DIR]     (default .box; git-ignored)
# Leaves OUT_DIR/p_aa, p_ab, ... each holding one part.NN; carry them with
# `scripts/box.sh stash .box/p_aa` and so on, then `scripts/box.sh setup`.
set -euo pipefail
OUT="${1:-.box}"
WORK="$(mktemp -d /tmp/gpu_pack.XXXX)"
trap 'rm -rf "$WORK"' EXIT
PINS=(mujoco==4.0.0 placo toppra ruckig pydantic usd-core
  trimesh rtree coacd coal ruamel.yaml omegaconf plotly "rerun-sdk>=0.41,<0.42" imageio-ffmpeg)
# What the box's image already holds (the device library's KINDS.md package list): not carried,
# so the box's own builds (numpy 2.5 and what was compiled against it) stay in use.
ON_BOX='^(numpy|scipy|pandas|pyarrow|matplotlib|pillow|pyyaml|jinja2|markupsafe|rich|pygments|markdown_it_py|mdurl|typing_extensions|packaging|absl_py|etils|fsspec|importlib_resources|zipp|attrs|imageio|contourpy|cycler|fonttools|kiwisolver|pyparsing|python_dateutil|six|pytz|tzdata|narwhals|networkx|sympy|mpmath|psutil|setuptools)-'
BOX=(--only-binary=:all: --python-version 3.12 --implementation cp)  # the box's interpreter
for tag in manylinux1 manylinux2014 manylinux_2_17 manylinux_2_24 manylinux_2_26 manylinux_2_27 \
  manylinux_2_28 manylinux_2_31 manylinux_2_34 manylinux_2_35; do
  BOX+=(--platform "${tag}_x86_64")
done
python3 -m pip download -q "${BOX[@]}" -d "$WORK/whl" "${PINS[@]}"
# Pulled in by placo's meshcat viewer, MuJoCo's GUI and imageio's ffmpeg: the box runs none.
NEVER_RUN='^(mujoco_studio|imageio_ffmpeg|meshcat|ipython|ipython_pygments_lexers|jedi|parso|prompt_toolkit|pexpect|ptyprocess|pure_eval|stack_data|executing|asttokens|traitlets|matplotlib_inline|wcwidth|pyngrok|pyzmq|tornado|u_msgpack_python|websockets|ischedule)-'
mkdir -p "$WORK/keep"
for wheel in "$WORK"/whl/*.whl; do
  name="$(basename "$wheel" | tr 'A-Z' 'a-z')"
  [[ "$name" =~ $ON_BOX || "$name" =~ $NEVER_RUN ]] || cp "$wheel" "$WORK/keep/"
done
ls "$WORK/keep"
python3 -m pip install -q "${BOX[@]}" --no-index --no-deps --no-compile --target "$WORK/site" "$WORK"/keep/*.whl
# What the box never runs: Warp's CPU compiler, rerun's viewer, static libraries, headers.
find "$WORK/site" \( -name '*.a' -o -path '*/include/*' \) -type f -delete 2>/dev/null || true
rm -rf "$WORK"/site/rerun_cli "$WORK"/site/bin/rerun
du -sh "$WORK"/site/* | sort -h | tail -8
tar -C "$WORK/site" -cf - . | xz -T0 -2 > "$WORK/pack.tar.xz"
rm -rf "$OUT"/p_a?
mkdir -p "$OUT"
split -b 45M -d "$WORK/pack.tar.xz" "$WORK/part."
i=0
for part in "$WORK"/part.*; do
  dir="$OUT/p_a$(printf "\\x$(printf %x $((97 + i)))")"
  mkdir -p "$dir" && mv "$part" "$dir/"
  i=$((i + 1))
done
ls -la "$OUT"/p_a?
