#!/bin/bash
# The per-frame update cost of docs/dynamic.md: a static fractal terrain of N triangles
# (`irt-lab ply-speed`, tools/) under one bouncing sphere, rendered as a 12-frame sequence at 512² with
# `irt render --frames`, which reports per frame what moving the sphere cost (its cells in the
# grid updated, or with --full-rebuild the grid rebuilt over every primitive; the scene texture
# repacked and rewritten) next to the frame's trace. Both ways in turn, per size. ~3 minutes.
#   scripts/dynamic-table.sh [TRIANGLES...]   (default: 10k 100k 1M 4M)
set -euo pipefail
source "$(dirname "$0")/bench-lib.sh"
lab_sizes 10000 100000 1000000 4000000 -- "$@"
machine_header "scripts/dynamic-table.sh"
echo "Device: $($irt info 2>/dev/null | grep -m1 -i 'mesa' | sed 's/^ *//')"
echo
echo "| primitives | grid | update ms / frame | grid ms | pack ms | upload ms | trace ms / frame | update / trace |"
echo "|---|---|---|---|---|---|---|---|"
for n in "${sizes[@]}"; do
    "$lab" ply-speed write "$dir/terrain.ply" "$n" > /dev/null
    cat > "$dir/scene.toml" <<TOML
[camera]
eye = [0.0, 3.0, 6.5]
look_at = [0.0, 0.2, 0.0]
fov = 40
width = 512
height = 512
[[light]]
position = [4.0, 8.0, 4.0]
[[material]]
name = "ground"
type = "diffuse"
color = [0.6, 0.55, 0.5]
[[material]]
name = "ball"
type = "polished"
color = [0.7, 0.1, 0.1]
[[model]]
file = "terrain.ply"
material = "ground"
scale = 3.0
[[sphere]]
center = [0.0, 1.0, 0.0]
radius = 0.5
material = "ball"
[[sphere.motion]]
translate = { times = [0.0, 0.5, 1.0], values = [[-1.5, 0.0, 0.0], [0.0, 1.0, 0.0], [1.5, 0.0, 0.0]], interpolation = "cubic" }
TOML
  for how in updated rebuilt; do
    flag=""; [ $how = rebuilt ] && flag=--full-rebuild
    line=$($irt render "$dir/scene.toml" --frames 0..12 --fps 12 $flag --out "$dir/f_%02d.png" 2>&1 | grep "per frame")
    # "... per frame: update U ms (grid G, pack P, upload L; ...), trace T ms"
    prims=$(echo "$line" | sed -E 's/.*, ([0-9]+) primitives.*/\1/')
    u=$(echo "$line" | sed -E 's/.*update ([0-9.]+) ms.*/\1/')
    g=$(echo "$line" | sed -E 's/.*\(grid ([0-9.]+),.*/\1/')
    p=$(echo "$line" | sed -E 's/.*pack ([0-9.]+),.*/\1/')
    l=$(echo "$line" | sed -E 's/.*upload ([0-9.]+);.*/\1/')
    t=$(echo "$line" | sed -E 's/.*trace ([0-9.]+) ms.*/\1/')
    echo "| $prims | $how | $u | $g | $p | $l | $t | $(echo "scale=2; $u / $t" | bc) |"
  done
done
