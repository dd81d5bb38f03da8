#!/usr/bin/env bash
# Regenerates the README's performance table: runs `irt bench --markdown` on the default scene
# (cold and warm Mesa shader cache) and the single-feature scenes, and prints a Markdown table
# headed by the machine, the driver and the date; `frame` is the median of FRAMES (default 15)
# frames after the first. Usage: scripts/bench-table.sh > /tmp/table.md
set -euo pipefail
# shellcheck source=scripts/bench-lib.sh
source "$(dirname "$0")/bench-lib.sh"
frames=${FRAMES:-15}
table_header scripts/bench-table.sh "first frame ms"
$irt bench --markdown --cold --frames "$frames" 2>/dev/null | sed 's/^| default |/| default (cold shader cache) |/'
$irt bench --markdown --frames "$frames" 2>/dev/null
for s in shadows.toml mesh.toml dielectric.toml textured.toml spd/balls_s4.nff spd/gears_s1.nff; do
    $irt bench "scenes/$s" --markdown --frames "$frames" 2>/dev/null
done
