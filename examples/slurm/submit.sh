#!/bin/bash
# Renders a still on a Slurm cluster as N tiles and merges them: queues the tile array and a merge
# job that starts when every tile task succeeded (and is cancelled, not left pending, if one fails).
#
#   examples/slurm/submit.sh SCENE OUT N [irt render options...]
#   e.g. examples/slurm/submit.sh scenes/spd/balls_s4.nff balls.exr 16 --size 3840x2160 --samples 16 --mode conventional
#
# SCENE "" is the built-in default scene. DIR (the tiles) is OUT.tiles beside OUT; it must be on a file system every node sees. Prints
# the two job ids. Set IRT to the irt binary if it is not on PATH; extra sbatch options (account,
# partition, CPUs per task) go in SBATCH_* variables, e.g. SBATCH_PARTITION=render.
set -euo pipefail
if [ $# -lt 3 ]; then
    echo "usage: $0 SCENE OUT N [irt render options...]" >&2
    exit 2
fi
scene=$1 out=$2 n=$3
shift 3
here=$(cd "$(dirname "$0")" && pwd)
dir=$out.tiles
mkdir -p "$dir"
tiles=$(sbatch --parsable --array="0-$((n - 1))" --chdir="$PWD" "$here/tiles.sbatch" "$scene" "$dir" "$@")
merge=$(sbatch --parsable --dependency="afterok:$tiles" --kill-on-invalid-dep=yes --chdir="$PWD" \
    "$here/merge.sbatch" "$dir" "$out")
echo "tiles: job $tiles (array 0-$((n - 1))), merge: job $merge -> $out"
