# Shared by the table scripts (sourced, not run): build irt, and print the header line every
# table starts with (machine, date, the command that regenerates it) and the table's head.
cd "$(dirname "$0")/.."
# IRT_FEATURES: cargo features for the build (scripts/peer-table.sh sets embree when it can).
cargo build --release --quiet ${IRT_FEATURES:+--features "$IRT_FEATURES"}
irt=${CARGO_TARGET_DIR:-target}/release/irt

# lab_sizes DEFAULT... -- ARGS...: builds the lab harnesses (`irt-lab`, tools/), makes a scratch
# directory $dir removed at exit, and sets `sizes` to ARGS, or DEFAULT when none are given.
lab_sizes() {
    cargo build --release --quiet -p irt-tools
    lab=${CARGO_TARGET_DIR:-target}/release/irt-lab
    dir=$(mktemp -d)
    trap 'rm -rf "$dir"' EXIT
    local defaults=()
    while [ $# -gt 0 ] && [ "$1" != "--" ]; do defaults+=("$1"); shift; done
    [ $# -gt 0 ] && shift
    sizes=("$@")
    [ ${#sizes[@]} -gt 0 ] || sizes=("${defaults[@]}")
}

# machine_header SCRIPT: the machine, the date and the command, on one line
machine_header() {
    local cpu
    cpu=$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')
    local driver
    driver=$("$irt" info 2>/dev/null | sed -n 's/^irt uses: .* — driver //p')
    echo "Machine: ${cpu}, $(nproc) cores, $(free -g | awk '/Mem:/{print $2}') GiB; driver: ${driver:-unknown}; $(date -u +%Y-%m-%d); command: \`$1\`"
}

# table_header SCRIPT FIRST_FRAME_COLUMN
table_header() {
    machine_header "$1"
    echo
    echo "| scene | size | primitives | accelerator build ms | $2 | frame ms | Mrays/s | device |"
    echo "|---|---|---|---|---|---|---|---|"
}
