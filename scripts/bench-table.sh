#!/usr/bin/env bash
# Regenerates the README's performance table: runs `irt bench --markdown` on the default scene
# (cold and warm Mesa shader cache) and the single-feature scenes, and prints a Markdown table
# headed by the machine and the date. Usage: scripts/bench-table.sh > /tmp/table.md
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
irt=target/release/irt
cpu=$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')
echo "Machine: ${cpu}, $(nproc) cores, $(free -g | awk '/Mem:/{print $2}') GiB; $(date -u +%Y-%m-%d); command: \`scripts/bench-table.sh\`"
echo
echo "| scene | size | primitives | grid build ms | first frame ms | frame ms | Mrays/s | device |"
echo "|---|---|---|---|---|---|---|---|"
$irt bench --markdown --cold 2>/dev/null | sed 's/^| default |/| default (cold shader cache) |/'
$irt bench --markdown 2>/dev/null
for s in shadows.toml mesh.toml dielectric.toml textured.toml spd/balls_s4.nff spd/gears_s1.nff; do
    $irt bench "scenes/$s" --markdown 2>/dev/null
done
