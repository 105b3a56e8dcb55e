#!/bin/bash
# The overview sweep as a Slurm job array of 8 shards (docs/CLUSTER.md):
#   sbatch sweeps/overview-slurm.sh
# then, once every task has finished:
#   ./target/release/workbench report results/overview/shard-* --out report.html
# Submit from the repository root with the workbench built (cargo build --release -p workbench)
# on a file system every node sees. Another sweep, folder or binary, or another shard count:
#   sbatch --array=0-2 --export=ALL,SWEEP=sweeps/pcss.toml,OUT=results/pcss sweeps/overview-slurm.sh
# (the test `crates/workbench/tests/slurm.rs` submits this file so to a local one-node Slurm).
#SBATCH --job-name=softshadow-overview
#SBATCH --array=0-7
#SBATCH --cpus-per-task=2
#SBATCH --mem=4G
#SBATCH --time=01:00:00
#SBATCH --output=results/overview/slurm-%A_%a.log
set -euo pipefail
SWEEP="${SWEEP:-sweeps/overview.toml}"
OUT="${OUT:-results/overview}"
WORKBENCH="${WORKBENCH:-./target/release/workbench}"
REFERENCE_CACHE="${REFERENCE_CACHE:-$OUT/reference-cache}"
mkdir -p "$OUT"
# SLURM_ARRAY_TASK_ID runs 0..N-1 and SLURM_ARRAY_TASK_COUNT is N: shard i of N, round robin.
"$WORKBENCH" bench \
    --sweep "$SWEEP" \
    --shard "${SLURM_ARRAY_TASK_ID}/${SLURM_ARRAY_TASK_COUNT}" \
    --reference-cache "$REFERENCE_CACHE" \
    --out "$OUT/shard-${SLURM_ARRAY_TASK_ID}"
