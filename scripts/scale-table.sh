#!/bin/bash
# The large-model scale table of docs/large-models.md: fractal terrains written as binary PLY
# (`irt-lab ply-speed`, tools/), each loaded, set up and rendered at 512² in a fresh process
# (`irt-lab scale`), plus the wall time of `irt render` itself on the largest. About 3 minutes.
#   scripts/scale-table.sh [TRIANGLES...]   (default: 1M 2M 5M 10M 16M, and 10M with normals)
set -euo pipefail
source "$(dirname "$0")/bench-lib.sh"
lab_sizes 1000000 2000000 5000000 10000000 16000000 10000000:normals -- "$@"
machine_header "scripts/scale-table.sh"
echo "Device: $($irt info 2>/dev/null | grep -m1 -i 'mesa' | sed 's/^ *//')"
echo
echo "| triangles | normals | load ms | grid ms | pack + upload ms | first frame ms | frame ms | load to first frame s | peak after load MiB | scene texture MiB | peak MiB | peak bytes/triangle |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|"
for size in "${sizes[@]}"; do
    n=${size%%:*}
    opt=""; normals="no"
    [[ $size == *:normals ]] && { opt=normals; normals=yes; }
    f="$dir/terrain-$n-$normals.ply"
    "$lab" ply-speed write "$f" "$n" le $opt > /dev/null
    row=$("$lab" scale "$f")
    # The harness's row starts with the triangle count; the normals column goes after it.
    echo "$row" | sed "s/^| \([^|]*\) |/| \1 | $normals |/"
    rm -f "$f"
done
echo
f="$dir/terrain-10M.ply"
"$lab" ply-speed write "$f" 10000000 > /dev/null
/usr/bin/time -f "irt render --accel grid of 10M triangles (640x480): %e s wall, %M KiB peak" \
    $irt render "$f" --accel grid --out "$dir/out.png" 2>&1 | grep -E "loaded|set up|wrote|wall" | sed 's/^/    /'
