#!/usr/bin/env bash
# What sampling textures costs: Duck.glb (every hit textured, bilinear) against the same scene
# with the texture taken off its material (converted to TOML, the `texture =` line removed),
# alternating three times in one run. Usage: scripts/texture-cost.sh
set -euo pipefail
# shellcheck source=scripts/bench-lib.sh
source "$(dirname "$0")/bench-lib.sh"
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
$irt convert tests/data/scenes/gltf/Duck.glb "$dir/duck.toml" >/dev/null 2>&1
grep -v '^texture = ' "$dir/duck.toml" >"$dir/duck-untextured.toml"
table_header scripts/texture-cost.sh "first frame ms"
for _ in 1 2 3; do
    for s in duck duck-untextured; do
        $irt bench "$dir/$s.toml" --size 512x512 --frames 21 --markdown 2>/dev/null |
            sed "s#$dir/##"
    done
done
