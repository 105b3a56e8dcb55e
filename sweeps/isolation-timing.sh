#!/bin/bash
# What isolating every run costs, and what each fault costs a sweep (docs/STABILITY.md, "Long
# runs"). Run from the repository root after
#   cargo build --release -p workbench
# 1. sweeps/shards.toml (9 runs at 128², references that dominate) in one process
#    (--no-isolate) and isolated (the default), three times each, alternating: the medians and
#    the cost per run of a process and a device of its own.
# 2. sweeps/faults.toml (6 runs at 64²) clean, then with each fault of SOFTSHADOW_FAULT
#    injected into run 2, isolated (--run-timeout 30) and, for the faults one process survives,
#    in one process: the sweep's wall time, how run 2 ended, its process's wall time, and the
#    other runs that did not end `ok` (runs lost; the goal is none).
set -euo pipefail
WORKBENCH="${WORKBENCH:-./target/release/workbench}"
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
n=0
# timed SWEEP FAULT ARGS...: prints "wall_s status_of_run_2 process_wall_s_of_run_2 lost"
timed() {
    local sweep=$1 fault=$2 start end out
    shift 2
    n=$((n + 1))
    out="$WORK/out-$n"
    start=$(date +%s.%N)
    SOFTSHADOW_FAULT="$fault" "$WORKBENCH" bench --sweep "$sweep" --no-images "$@" \
        --out "$out" >/dev/null 2>&1 || true
    end=$(date +%s.%N)
    printf '%.2f ' "$(echo "$end - $start" | bc)"
    jq -r '[(.runs[2].status), (.runs[2].process.wall_s // "-"),
            ([.runs[] | select(.index != 2 and .status != "ok")] | length)] | @tsv' \
        "$out/results.json"
}
median() { sort -n | sed -n 2p; }
echo "$(nproc) CPUs, load average $(cut -d' ' -f1-3 /proc/loadavg) at the start"
one=() iso=()
for _ in 1 2 3; do
    one+=("$(timed sweeps/shards.toml "" --no-isolate | cut -d' ' -f1)")
    iso+=("$(timed sweeps/shards.toml "" | cut -d' ' -f1)")
done
a=$(printf '%s\n' "${one[@]}" | median)
b=$(printf '%s\n' "${iso[@]}" | median)
echo "shards.toml, 9 runs: one process ${one[*]} s (median $a), isolated ${iso[*]} s (median $b)"
echo "isolation per run: $(echo "scale=3; ($b - $a) / 9" | bc) s"
echo "| sweep | fault in run 2 | sweep wall time (s) | run 2 | run 2's process (s) | other runs lost |"
echo "|---|---|---|---|---|---|"
row() { # LABEL FAULT ARGS...
    local label=$1 fault=$2
    shift 2
    read -r wall status process lost <<<"$(timed sweeps/faults.toml "$fault" "$@")"
    echo "| $label | ${fault:-none} | $wall | $status | $process | $lost |"
}
row isolated "" --run-timeout 30
for kind in lost oom hang crash; do
    row isolated "$kind:2" --run-timeout 30
done
row "one process" "" --no-isolate
row "one process" "lost:2" --no-isolate
row "one process" "oom:2" --no-isolate
echo "load average $(cut -d' ' -f1-3 /proc/loadavg) at the end"
