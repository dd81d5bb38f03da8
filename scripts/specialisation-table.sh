#!/usr/bin/env bash
# The specialisation table of docs/specialisation.md: each scene timed with the pipeline
# specialised to it and with the uber-pipeline, both from an empty Mesa shader cache (so time
# to first frame includes the whole shader compile). Usage: scripts/specialisation-table.sh
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
irt=target/release/irt
cpu=$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')
echo "Machine: ${cpu}, $(nproc) cores; $(date -u +%Y-%m-%d); command: \`scripts/specialisation-table.sh\`"
echo
echo "| scene | size | primitives | grid build ms | first frame ms (cold) | frame ms | Mrays/s | device |"
echo "|---|---|---|---|---|---|---|---|"
for s in "" scenes/spd/balls_s2.nff scenes/spd/gears_s1.nff scenes/spd/jacks_s2.nff tests/data/scenes/gltf/Duck.glb; do
    for uber in "" --uber; do
        # shellcheck disable=SC2086
        $irt bench $s --cold --markdown $uber 2>/dev/null
    done
done
