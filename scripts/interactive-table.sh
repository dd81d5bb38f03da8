#!/usr/bin/env bash
# Regenerates the tables and plots of docs/interactive.md into docs/interactive/ (about 10
# minutes on 2 cores): conventional vs frameless over a camera path at equal rays/s, the
# conventional schedules, the frameless pixel orders, the slice size, progressive refinement.
# Each table is headed by the machine line; load.md records the load average it ran under.
# Usage: scripts/interactive-table.sh [--only PART]... [--quick --out-dir DIR]
set -euo pipefail
# shellcheck source=scripts/bench-lib.sh
source "$(dirname "$0")/bench-lib.sh"
cargo run --release --quiet -p irt-tools -- interactive --out-dir docs/interactive \
    --header "$(machine_header "scripts/interactive-table.sh${*:+ $*}")" "$@"
