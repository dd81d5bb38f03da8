#!/usr/bin/env bash
# Regenerates docs/performance.md's "Grid vs BVH" table: `irt bench --accels grid,bvh,bvh-stack`
# on each scene (one frame of each accelerator per round, rounds interleaved, medians), one
# Markdown row per scene: build times, Mrays/s, the ratios to the grid, and what `--accel auto`
# picks. FRAMES (default 7) rounds; SCENES overrides the scene list.
# Usage: scripts/accel-table.sh > /tmp/accel.md
set -euo pipefail
# shellcheck source=scripts/bench-lib.sh
source "$(dirname "$0")/bench-lib.sh"
frames=${FRAMES:-7}
scenes=${SCENES:-"default scenes/mesh.toml scenes/cones.toml scenes/textured.toml scenes/dielectric.toml
    scenes/spd/balls_s2.nff scenes/spd/balls_s4.nff scenes/spd/gears_s1.nff scenes/spd/tetra_s4.nff
    scenes/spd/teapot_s2.nff scenes/spd/mount_s3.nff scenes/spd/jacks_s2.nff scenes/spd/rings_s2.nff
    scenes/spd/tree_s3.nff scenes/spd/sombrero_s1.nff scenes/spd/shells_s1.nff
    scenes/accel/stadium.nff scenes/accel/random_spheres.nff"}
machine_header "FRAMES=$frames scripts/accel-table.sh"
echo "Load average before: $(cut -d' ' -f1-3 /proc/loadavg)."
echo
echo "| scene | size | primitives | rays/frame | grid build ms | BVH build ms | BVH build ms (stack walk) | grid Mrays/s | BVH Mrays/s | BVH, stack walk Mrays/s | BVH / grid | BVH stack / grid | auto picks | device |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
for s in $scenes; do
    if [ "$s" = default ]; then set -- ; else set -- "$s"; fi
    $irt bench "$@" --accels grid,bvh,bvh-stack --frames "$frames" --markdown 2>/dev/null
done
echo
echo "Load average after: $(cut -d' ' -f1-3 /proc/loadavg)."
