#!/usr/bin/env bash
# A `lash design map` sharded over a Slurm job array, then merged by a job that waits for
# every part (afterok). From the repository's root, on a cluster (or the one-node cluster of
# scripts/slurm/setup-localhost.sh):
#
#   bash scripts/slurm/run-map.sh 8 --z 0.5 --n 101 --nonlinear-every 10
#
# First argument: number of parts; the rest: `lash design map` options (not --out/--shard).
# Writes out/design-map-parts/part-K-of-N.json, then out/design-map-slurm/ (map.csv,
# heatmaps, map.json): the same as one unsharded run with the same options.
set -euo pipefail
parts=${1:?usage: run-map.sh PARTS [lash design map options]}
shift
cargo build --release --quiet
mkdir -p out/slurm
export LASH=${LASH:-$PWD/target/release/lash}
export PARTS=${PARTS:-$PWD/out/design-map-parts}
out=${OUT:-$PWD/out/design-map-slurm}
rm -rf "$PARTS"
array=$(sbatch --parsable --array=0-$((parts - 1)) --export=ALL scripts/slurm/design-map.sbatch "$@")
echo "submitted job array $array ($parts parts)"
files=$(for k in $(seq 0 $((parts - 1))); do printf '%s ' "$PARTS/part-$k-of-$parts.json"; done)
merge=$(sbatch --parsable --dependency=afterok:"$array" --job-name=lash-merge \
    --output=out/slurm/lash-merge-%j.log \
    --wrap "\"$LASH\" design merge --out \"$out\" $files --json > \"$out.json\"")
echo "submitted merge job $merge (after $array); result in $out and $out.json"
