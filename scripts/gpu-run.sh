#!/bin/bash
# The GPU run of docs/performance.md ("On a GPU"): the peer table (irt on the GPU, the native
# peers and Embree on the host's cores), the default scene with all rays on both device paths,
# grid / stackless BVH / stack BVH by device timestamps at 512² and 2048², the GPU tests against
# the CPU reference, and the criterion `trace` bench; everything on the adapter $IRT_ADAPTER
# names (default `gpu`: the best hardware GPU). About 6 minutes on an H200 with 16 cores.
#   scripts/gpu-run.sh [OUT_DIR]     (default gpu-run/: log.txt, tests.txt, criterion.txt, a PNG)
# BIN=DIR runs prebuilt binaries instead of building (DIR/irt, DIR/trace: the bench,
# DIR/tests/NAME: the test binaries), for a machine without Rust; run from the repository root
# either way (the tests and benches read scenes/).
set -u
cd "$(dirname "$0")/.."
out=${1:-gpu-run}
mkdir -p "$out" /tmp/irt-gpu-run
export IRT_ADAPTER=${IRT_ADAPTER:-gpu}
frames=${FRAMES:-11}
tests=(golden gpu_functions spd soft_shadows native_peer embree_peer bvh textures backends)
peers=native,native-bvh
if [ -n "${BIN:-}" ]; then
    irt=$BIN/irt
    run_test() { "$BIN/tests/$1" --test-threads 8; }
    run_trace() { "$BIN/trace" --bench; }
else
    features=()
    if ldconfig -p 2>/dev/null | grep 'libembree3\.so ' >/dev/null; then features=(--features embree); fi
    cargo build --release --quiet "${features[@]}"
    irt=${CARGO_TARGET_DIR:-target}/release/irt
    run_test() { cargo test --release --quiet "${features[@]}" --test "$1" -- --test-threads 8; }
    run_trace() { cargo bench --quiet "${features[@]}" --bench trace; }
fi
grep -q 'embree (Embree' <<<"$("$irt" info 2>&1)" && peers=$peers,embree
t0=$(date +%s)
step() { echo; echo "=== $* (t=$(($(date +%s) - t0)) s)"; }
arg() { [ "$1" = default ] || echo "$1"; }
exec > >(tee "$out/log.txt") 2>&1

step "machine"
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader 2>/dev/null
echo "cpu: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//'), $(nproc) cores; $(date -u +%Y-%m-%d); command: scripts/gpu-run.sh"
"$irt" info 2>&1

s=/tmp/irt-gpu-run
"$irt" spd tetra --size 8 --out $s/tetra_s8.nff
"$irt" spd tetra --size 10 --out $s/tetra_s10.nff
"$irt" spd balls --size 6 --out $s/balls_s6.nff
big=($s/tetra_s8.nff $s/tetra_s10.nff $s/balls_s6.nff)
small=(default scenes/spd/balls_s2.nff scenes/spd/balls_s4.nff scenes/spd/gears_s1.nff
    scenes/spd/tetra_s4.nff scenes/spd/teapot_s2.nff scenes/spd/mount_s3.nff scenes/spd/jacks_s2.nff
    scenes/spd/rings_s2.nff scenes/spd/tree_s3.nff)

step "peer table: primary-shadow, 512², peers on all of the host's cores, $frames rounds"
echo "columns: scene, size, primitives, irt ms, then ms of each of $peers, irt Mrays/s, Mrays/s of each, irt / each, device"
for sc in "${small[@]}" "${big[@]}"; do
    "$irt" bench $(arg "$sc") --workload primary-shadow --peer "$peers" --frames "$frames" --markdown 2>/dev/null
done

step "default scene, all rays, both device paths, 512² and 2048²"
for b in wgpu ash; do
    for side in 512 2048; do
        "$irt" bench --backend $b --frames 9 --size ${side}x$side 2>&1 | grep -E '^(scene|device|first frame|frame|readback|rays/frame|throughput)'
    done
done

step "grid / stackless BVH / stack BVH: device time of a frame (ash, timestamps), primary-shadow"
for side in 512 2048; do
    for sc in default scenes/spd/balls_s4.nff $s/tetra_s10.nff $s/balls_s6.nff; do
        for a in grid bvh bvh-stack; do
            echo "-- $sc $a ${side}²"
            "$irt" bench $(arg "$sc") --backend ash --profile --workload primary-shadow --accel $a --frames 9 \
                --size ${side}x$side 2>&1 | grep -E '^(frame|readback|rays/frame|throughput)'
        done
    done
done

step "the GPU against the CPU reference (IRT_ADAPTER=$IRT_ADAPTER)"
for t in "${tests[@]}"; do
    echo "--- $t"
    run_test "$t" >>"$out/tests.txt" 2>&1
    echo "rc=$?"
    grep -E '^test result' "$out/tests.txt" | tail -1
done

"$irt" render --out "$out/default.png" 2>&1 | tail -1

step "criterion trace bench (IRT_BENCH_SECS=${IRT_BENCH_SECS:=1})"
export IRT_BENCH_SECS
run_trace >"$out/criterion.txt" 2>&1
echo "rc=$?"
sed -n '/^| bench /,$p' "$out/criterion.txt"
step done
