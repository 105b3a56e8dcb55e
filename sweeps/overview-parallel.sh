#!/bin/bash
# The overview sweep as shards run side by side on one machine with GNU parallel
# (docs/CLUSTER.md):
#   sweeps/overview-parallel.sh
# then:
#   ./target/release/workbench report results/overview/shard-* --out report.html
# Another sweep, folder, binary, shard count or number of jobs at once:
#   SWEEP=sweeps/pcss.toml OUT=results/pcss SHARDS=3 JOBS=3 sweeps/overview-parallel.sh
# (the test `crates/workbench/tests/slurm.rs` runs this file over a small sweep).
set -euo pipefail
SWEEP="${SWEEP:-sweeps/overview.toml}"
OUT="${OUT:-results/overview}"
WORKBENCH="${WORKBENCH:-./target/release/workbench}"
SHARDS="${SHARDS:-4}"
JOBS="${JOBS:-2}"
# One reference cache for every shard: a scene's references are rendered once.
REFERENCE_CACHE="${REFERENCE_CACHE:-$OUT/reference-cache}"
mkdir -p "$OUT"
seq 0 $((SHARDS - 1)) | parallel --will-cite --halt now,fail=1 -j "$JOBS" \
    "$WORKBENCH" bench --sweep "$SWEEP" --shard "{}/$SHARDS" \
    --reference-cache "$REFERENCE_CACHE" --out "$OUT/shard-{}"
