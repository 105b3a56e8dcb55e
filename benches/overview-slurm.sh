#!/bin/bash
# The overview sweep as a Slurm job array of 8 shards (docs/CLUSTER.md):
#   sbatch benches/overview-slurm.sh
# then, once every task has finished:
#   ./target/release/workbench report results/overview/shard-* --out report.html
# Submit from the repository root with the workbench built (cargo build --release -p workbench)
# on a file system every node sees.
#SBATCH --job-name=softshadow-overview
#SBATCH --array=0-7
#SBATCH --cpus-per-task=4
#SBATCH --mem=4G
#SBATCH --time=01:00:00
#SBATCH --output=results/overview/slurm-%A_%a.log
set -euo pipefail
mkdir -p results/overview
# SLURM_ARRAY_TASK_ID runs 0..7 and SLURM_ARRAY_TASK_COUNT is 8: shard i of 8, round robin.
./target/release/workbench bench \
    --sweep benches/overview.toml \
    --shard "${SLURM_ARRAY_TASK_ID}/${SLURM_ARRAY_TASK_COUNT}" \
    --out "results/overview/shard-${SLURM_ARRAY_TASK_ID}"
