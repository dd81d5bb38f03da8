#!/bin/bash
# The large-picture table of docs/large-models.md: `irt render` of the default scene at sizes up
# to irt's limit (64 Mpixel), in each mode, each in a fresh process: wall time, the trace time
# irt reports and the peak resident memory (VmHWM); then `irt-lab pieces`, the price of the
# pieces against a whole picture. About 4 minutes.
#   scripts/picture-table.sh [WxH:MODE:EXT...]
set -euo pipefail
source "$(dirname "$0")/bench-lib.sh"
lab_sizes 2896x2896:bands:png 4096x4096:bands:png 4096x4096:conventional:png 4096x4096:frameless:png \
    8192x8192:bands:exr 8192x8192:conventional:png 16384x4096:frameless:png -- "$@"
machine_header "scripts/picture-table.sh"
echo
echo "| size | Mpixel | mode | file | traced in | trace s | wall s | peak MiB | peak bytes/pixel |"
echo "|---|---|---|---|---|---|---|---|---|"
for spec in "${sizes[@]}"; do
    IFS=: read -r size mode ext <<< "$spec"
    args=(render --size "$size" --out "$dir/out.$ext")
    [ "$mode" = bands ] || args+=(--mode "$mode")
    log=$(/usr/bin/time -f "TIME %e %M" "$irt" "${args[@]}" 2>&1)
    read -r wall kib <<< "$(echo "$log" | sed -n 's/^TIME //p')"
    line=$(echo "$log" | grep '^wrote')
    trace=$(echo "$line" | sed -n 's/.*, \([0-9.]*\) s on .*/\1/p')
    pieces=$(echo "$line" | sed -n 's/.*in pieces of at most \([0-9]*\) pixels.*/pieces of \1/p')
    w=${size%x*}; h=${size#*x}
    px=$((w * h))
    echo "| $size | $(awk "BEGIN{printf \"%.1f\", $px/1e6}") | $mode | $ext | ${pieces:-whole} | $trace | $wall | $((kib / 1024)) | $(awk "BEGIN{printf \"%.0f\", $kib*1024/$px}") |"
    rm -f "$dir/out.$ext"
done
echo
"$lab" pieces 2048x2048
