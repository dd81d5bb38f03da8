#!/bin/bash
# The irt / peer table of docs/performance.md: each scene at 512² on the primary-shadow workload
# (eye rays + one hard-shadow ray per light, Lambert), irt and the peers in the same process,
# FRAMES rounds interleaved (one irt frame, then one frame of each peer), medians. The peers are
# the native Rust one over irt's grid and over irt's BVH and, when this irt was built with
# `--features embree` (`irt info` says so), Embree 3; PEERS overrides the list (e.g.
# PEERS=native,embree,embree-fast). About a minute per peer on 2 cores.
# ACCEL (default auto, irt's default: the BVH unless a scene past 2^21 primitives moves) sets irt's --accel;
# ACCEL=grid compares irt's grid walk with the `native` peer's.
#   scripts/peer-table.sh [SCENE...]   (default: the default scene and the small SPD scenes)
set -euo pipefail
# Build with the Embree peer when libembree3 is installed (scripts/setup.sh --with-embree) and
# IRT_FEATURES does not say otherwise.
if [ -z "${IRT_FEATURES+set}" ] && ldconfig -p 2>/dev/null | grep 'libembree3\.so ' >/dev/null; then
    IRT_FEATURES=embree
fi
source "$(dirname "$0")/bench-lib.sh"
irt="${CARGO_TARGET_DIR:-target}/release/irt"
frames=${FRAMES:-5}
scenes=("$@")
[ ${#scenes[@]} -gt 0 ] || scenes=(default scenes/spd/balls_s2.nff scenes/spd/balls_s4.nff
    scenes/spd/gears_s1.nff scenes/spd/tetra_s4.nff scenes/spd/teapot_s2.nff scenes/spd/mount_s3.nff
    scenes/spd/jacks_s2.nff scenes/spd/rings_s2.nff scenes/spd/tree_s3.nff)
info="$($irt info 2>/dev/null || true)"
embree="$(sed -n 's/.*bench peers:.*embree (Embree \([0-9.]*\)).*/\1/p' <<<"$info")"
if [ -z "${PEERS:-}" ]; then
    PEERS=native,native-bvh
    [ -z "$embree" ] || PEERS=native,native-bvh,embree
fi
IFS=, read -r -a peers <<<"$PEERS"
machine_header "scripts/peer-table.sh"
echo "Device: $(grep -m1 -i 'mesa' <<<"$info" | sed 's/^ *//')"
if [ -n "$embree" ]; then echo "Embree: $embree"; else echo "Embree: not built in (cargo build --release --features embree)"; fi
echo "Peers: ${PEERS}; rounds: $frames"
echo "Load before: $(uptime | sed 's/.*load average/load average/')"
echo
header="| scene | size | primitives | irt ms"
sep="|---|---|---|---"
for p in "${peers[@]}"; do header+=" | $p ms"; sep+="|---"; done
header+=" | irt Mrays/s"; sep+="|---"
for p in "${peers[@]}"; do header+=" | $p Mrays/s"; sep+="|---"; done
for p in "${peers[@]}"; do header+=" | irt / $p"; sep+="|---"; done
echo "$header | device |"
echo "$sep|---|"
for s in "${scenes[@]}"; do
    arg=()
    [ "$s" = default ] || arg=("$s")
    "$irt" bench "${arg[@]}" --workload primary-shadow --accel "${ACCEL:-auto}" --peer "$PEERS" --frames "$frames" --markdown 2>/dev/null
done
echo
echo "Load after: $(uptime | sed 's/.*load average/load average/')"
