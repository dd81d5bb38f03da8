#!/bin/bash
# The irt / native-peer table of docs/performance.md: each scene at 512² on the primary-shadow
# workload (eye rays + one hard-shadow ray per light, Lambert), irt and the native Rust peer in
# the same process, FRAMES rounds interleaved, medians. About a minute on 2 cores.
#   scripts/peer-table.sh [SCENE...]   (default: the default scene and the small SPD scenes)
set -euo pipefail
source "$(dirname "$0")/bench-lib.sh"
irt="${CARGO_TARGET_DIR:-target}/release/irt"
frames=${FRAMES:-5}
scenes=("$@")
[ ${#scenes[@]} -gt 0 ] || scenes=(default scenes/spd/balls_s2.nff scenes/spd/balls_s4.nff
    scenes/spd/gears_s1.nff scenes/spd/tetra_s4.nff scenes/spd/teapot_s2.nff scenes/spd/mount_s3.nff
    scenes/spd/jacks_s2.nff scenes/spd/rings_s2.nff scenes/spd/tree_s3.nff)
machine_header "scripts/peer-table.sh"
echo "Device: $($irt info 2>/dev/null | grep -m1 -i 'mesa' | sed 's/^ *//')"
echo "Load before: $(uptime | sed 's/.*load average/load average/')"
echo
echo "| scene | size | primitives | irt ms | native ms | irt Mrays/s | native Mrays/s | irt / native | device |"
echo "|---|---|---|---|---|---|---|---|---|"
for s in "${scenes[@]}"; do
    arg=()
    [ "$s" = default ] || arg=("$s")
    "$irt" bench "${arg[@]}" --workload primary-shadow --peer native --frames "$frames" --markdown 2>/dev/null
done
echo
echo "Load after: $(uptime | sed 's/.*load average/load average/')"
