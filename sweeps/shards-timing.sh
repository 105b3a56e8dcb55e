#!/bin/bash
# Wall time of sweeps/shards.toml run whole and as 2 and 3 shards at once (GNU parallel), each
# without and with a shared reference cache (empty at the start, so the shards fill it), and a
# whole run with the cache already full (docs/CLUSTER.md, "What sharding and the cache save").
# Run it on an otherwise idle machine, from the repository root, after
#   cargo build --release -p workbench
set -euo pipefail
WORKBENCH="${WORKBENCH:-./target/release/workbench}"
SWEEP="${SWEEP:-sweeps/shards.toml}"
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
runs=0
run() { # NAME SHARDS CACHE(yes|no|full)
    local name=$1 shards=$2 cache=$3 start end out
    runs=$((runs + 1))
    out="$WORK/run-$runs"  # parallel splits its command on spaces: no spaces in paths
    local args=()
    case $cache in
        yes) rm -rf "$WORK/cache"; args=(--reference-cache "$WORK/cache") ;;
        full) args=(--reference-cache "$WORK/cache") ;;
    esac
    start=$(date +%s.%N)
    seq 0 $((shards - 1)) | parallel --will-cite --halt now,fail=1 -j "$shards" \
        "$WORKBENCH" bench --sweep "$SWEEP" --shard "{}/$shards" --no-isolate --no-images "${args[@]}" \
        --out "$out/shard-{}" >/dev/null 2>&1
    end=$(date +%s.%N)
    printf '%-28s %7.1f s\n' "$name" "$(echo "$end - $start" | bc)"
}
echo "$(nproc) CPUs, load average $(cut -d' ' -f1-3 /proc/loadavg) at the start"
run "1 shard, no cache" 1 no
run "2 shards, no cache" 2 no
run "3 shards, no cache" 3 no
run "1 shard, cache filled" 1 yes
run "1 shard, cache full" 1 full
run "2 shards, shared cache" 2 yes
run "3 shards, shared cache" 3 yes
echo "load average $(cut -d' ' -f1-3 /proc/loadavg) at the end"
