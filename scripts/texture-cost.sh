#!/usr/bin/env bash
# What sampling textures costs: Duck.glb (every hit textured, bilinear) against the same scene
# with the texture taken off its material (converted to TOML, the `texture =` line removed),
# alternating three times in one run. Usage: scripts/texture-cost.sh
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
irt=target/release/irt
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
$irt convert tests/data/scenes/gltf/Duck.glb "$dir/duck.toml" >/dev/null 2>&1
grep -v '^texture = ' "$dir/duck.toml" >"$dir/duck-untextured.toml"
cpu=$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')
echo "Machine: ${cpu}, $(nproc) cores; $(date -u +%Y-%m-%d); command: \`scripts/texture-cost.sh\`"
echo
echo "| scene | size | primitives | grid build ms | first frame ms | frame ms | Mrays/s | device |"
echo "|---|---|---|---|---|---|---|---|"
for _ in 1 2 3; do
    for s in duck duck-untextured; do
        $irt bench "$dir/$s.toml" --width 512 --height 512 --frames 21 --markdown 2>/dev/null |
            sed "s#$dir/##"
    done
done
