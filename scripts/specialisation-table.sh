#!/usr/bin/env bash
# The specialisation table of docs/specialisation.md: each scene timed with the pipeline
# specialised to it and with the uber-pipeline, both from an empty Mesa shader cache (so time
# to first frame includes the whole shader compile). Usage: scripts/specialisation-table.sh
set -euo pipefail
# shellcheck source=scripts/bench-lib.sh
source "$(dirname "$0")/bench-lib.sh"
table_header scripts/specialisation-table.sh "first frame ms (cold)"
for s in "" scenes/spd/balls_s2.nff scenes/spd/gears_s1.nff scenes/spd/jacks_s2.nff tests/data/scenes/gltf/Duck.glb; do
    for uber in "" --uber; do
        # shellcheck disable=SC2086
        $irt bench $s --cold --markdown $uber 2>/dev/null
    done
done
