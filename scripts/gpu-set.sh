#!/usr/bin/env bash
# The GPU set (docs/BENCHMARKS.md, "On a GPU"): from an already built release binary and no
# network, the stiff suite, the overview at 256x256, a resolution series (256x256 to 3840x2160),
# the motion sweep and the overview at 1920x1080 (on three of its scenes, the exact answer at
# 8 x 8 light samples), each stage under a time limit, in that order
# (the most needed first), at most seven minutes (317 s on an H200).
#
#   scripts/gpu-set.sh [--reduced] [--bin PATH] [--out DIR]
#
# --bin   the workbench binary (default target/release/workbench)
# --out   where each stage writes DIR/<stage>/results.json (default /tmp/gpu-set); the compact
#         results (no images) are also copied to DIR/<stage>.json, with DIR/adapter.txt
# --reduced  the same stages at tiny sizes with `hard` and `pcss` only (the stiff suite on two
#         cases, the motion sweep on one scene), a few frames each: what CI runs on lavapipe to
#         prove the set works end to end (crates/workbench/tests/gpu_set.rs)
#
# A stage over its limit is interrupted like Ctrl-C: its results.json keeps the runs it finished
# and the set goes on. Runs share one process per stage (`--no-isolate`): a process per run
# costs about half a second, a minute and a half on the overview, and the stage's own limit
# already ends a hang. Exit 0 when every stage ran (runs that failed are recorded in their
# results), 1 when a stage could not start. Copy DIR/*.json to docs/results/gpu/ and run
# `workbench docs` to regenerate the tables (docs/DEVICES.md, "The H200's figures").
set -uo pipefail
cd "$(dirname "$0")/.."

bin=target/release/workbench
out=/tmp/gpu-set
reduced=0
while [ $# -gt 0 ]; do
  case "$1" in
    --bin) bin=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    --reduced) reduced=1; shift ;;
    *) echo "gpu-set: unknown argument $1: use --bin PATH, --out DIR or --reduced" >&2; exit 2 ;;
  esac
done
if [ ! -x "$bin" ]; then
  echo "gpu-set: no workbench binary at $bin: build it with cargo build --release -p workbench, or give --bin" >&2
  exit 2
fi
mkdir -p "$out" || { echo "gpu-set: cannot create $out" >&2; exit 2; }

if [ "$reduced" = 1 ]; then
  # The resolution sweep at three tiny sizes (a sweep file of its own, written here).
  resolution="$out/resolution-reduced.toml"
  sed 's/^sizes = .*/sizes = ["16x16", "32x18", "48x27"]/' sweeps/resolution.toml > "$resolution"
  overview_size=32x32
  overview_hd=48x27
  only=(--techniques hard,pcss)
  stiff_only=(--techniques hard --scenes stiff-no-occluder,stiff-receiver-behind-light)
  refs=(--reference-param samples_per_axis=4 --reference-param shadow_map_size=256)
  small=(--frames 1 --warmup 1 "${refs[@]}")
  motion=(--techniques hard,pcss --scenes atty-square --frames 3 --path orbit "${refs[@]}")
  limit_scale=4 # lavapipe in a debug build
else
  resolution=sweeps/resolution.toml
  overview_size=256x256
  overview_hd=1920x1080
  only=()
  stiff_only=()
  small=()
  motion=()
  limit_scale=1
fi

failed=0
# stage NAME SECONDS ARGS...: one `workbench bench` under a time limit (SIGINT, then SIGKILL
# 20 s later), its compact results copied to $out/NAME.json.
stage() {
  local name=$1 seconds=$(($2 * limit_scale)) start=$SECONDS
  shift 2
  echo "== $name (limit ${seconds} s): workbench bench $*"
  timeout -s INT -k 20 "$seconds" "$bin" bench "$@" --no-images --no-isolate --out "$out/$name" \
    > "$out/$name.log" 2>&1
  local code=$?
  echo "== $name: exit $code after $((SECONDS - start)) s ($(tail -n 1 "$out/$name.log"))"
  if [ -f "$out/$name/results.json" ]; then
    cp "$out/$name/results.json" "$out/$name.json"
  else
    echo "== $name: no results.json" && failed=1
  fi
}

# The GPU's clocks and power state once a second (NVIDIA): short frames with waits between them
# may leave it at idle clocks, which the timings would then include (docs/DEVICES.md, "The
# H200's clocks").
if command -v nvidia-smi > /dev/null; then
  nvidia-smi --query-gpu=timestamp,clocks.sm,clocks.mem,pstate,power.draw,utilization.gpu \
    --format=csv -lms 1000 > "$out/clocks.csv" 2>&1 &
  clocks=$!
  trap 'kill $clocks 2> /dev/null' EXIT
fi

"$bin" list > "$out/list.txt" 2>&1 || { echo "gpu-set: workbench list failed:"; cat "$out/list.txt"; exit 1; }
grep -i "unavailable" "$out/list.txt" || true

stage stiff 80 --suite stiff "${stiff_only[@]}"
stage overview-256 70 --sweep sweeps/overview.toml --size "$overview_size" "${only[@]}" "${small[@]}"
stage resolution 35 --sweep "$resolution" --no-error "${only[@]}" "${small[@]}"
stage motion 85 --sweep sweeps/motion.toml "${motion[@]}"
stage overview-1080 150 --sweep sweeps/overview.toml --size "$overview_hd" --exact-samples 8 \
  --scenes atty-square,balls-3x3x3,pdsm-quads --no-camera-only "${only[@]}" "${small[@]}"

sed -n '/"adapter"/,/}/p' "$out/stiff.json" > "$out/adapter.txt" 2>/dev/null
echo "== adapter:" && cat "$out/adapter.txt"
exit $failed
