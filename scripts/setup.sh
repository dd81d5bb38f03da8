#!/usr/bin/env bash
# Makes sure a Vulkan driver fit for irt is present: Mesa's lavapipe (Vulkan on the CPU), Mesa >= 24.
# Mesa 22.3 (Debian 12's stock package) runs irt's kernels 2-4x slower than 25.0 (../LAVAPIPE notes,
# docs/performance.md), so on Debian 12 the driver comes from the machine's own mirror's
# bookworm-backports suite. Newer is not faster: Debian 13's backports (Mesa 26.1.6, LLVM 19) run irt
# 1.1-1.4x slower than 25.0.7, so elsewhere the distribution's own package is kept (docs/performance.md,
# "A newer lavapipe"). Safe to run again: it changes nothing when a new enough driver is there.
# Also installs what the window tests use (Xvfb, xdotool), the distributed path (Open MPI) and the
# render-farm test (Slurm, munge) when missing.
# Optional: `--with-embree` (or IRT_WITH_EMBREE=1) also installs libembree-dev, for the Embree
# benchmark peer (`cargo build --release --features embree`); not installed by default.
set -euo pipefail

MIN_MESA_MAJOR=24
WITH_EMBREE="${IRT_WITH_EMBREE:-0}"
for arg in "$@"; do
    case "$arg" in
        --with-embree) WITH_EMBREE=1 ;;
        *) echo "setup: unknown option $arg (known: --with-embree)" >&2; exit 2 ;;
    esac
done

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
    SUDO="sudo"
fi
export DEBIAN_FRONTEND=noninteractive
apt_updated=0
apt_update() {
    if [ "$apt_updated" -eq 0 ]; then
        $SUDO apt-get update -qq
        apt_updated=1
    fi
}

have_vulkan() {
    # The loader plus at least one installed driver manifest (ICD).
    # grep reads all of it: with -q it would exit at the first match, and under pipefail
    # ldconfig's SIGPIPE would fail the check now and then (seen in a CI run).
    ldconfig -p 2>/dev/null | grep 'libvulkan\.so\.1' >/dev/null || return 1
    local d
    for d in /usr/share/vulkan/icd.d /etc/vulkan/icd.d /usr/local/share/vulkan/icd.d; do
        compgen -G "$d/*.json" >/dev/null && return 0
    done
    return 1
}

mesa_version() {
    dpkg-query -W -f='${Version}' mesa-vulkan-drivers 2>/dev/null || true
}

mesa_major() {
    local v
    v="$(mesa_version)"
    v="${v#*:}" # drop an epoch
    echo "${v%%.*}"
}

# The URI of the Debian mirror this machine already uses (deb822 or one-line sources).
debian_mirror() {
    local f uri=""
    for f in /etc/apt/sources.list.d/*.sources; do
        [ -f "$f" ] || continue
        uri="$(awk '/^URIs:/ {print $2; exit}' "$f")"
        case "$uri" in *security*|"") uri="" ;; *) break ;; esac
    done
    if [ -z "$uri" ] && [ -f /etc/apt/sources.list ]; then
        uri="$(awk '$1 == "deb" && $3 !~ /security/ {print $2; exit}' /etc/apt/sources.list)"
    fi
    echo "$uri"
}

codename="$(. /etc/os-release 2>/dev/null && echo "${VERSION_CODENAME:-}")"

install_pkgs() {
    if ! command -v apt-get >/dev/null; then
        echo "setup: apt-get not found. Install your distribution's Mesa Vulkan drivers (lavapipe, Mesa >= $MIN_MESA_MAJOR) and the Vulkan loader, then run again." >&2
        exit 1
    fi
    apt_update
    $SUDO apt-get install -y -qq --no-install-recommends "$@" >/dev/null
}

if [ "$codename" = "bookworm" ] && { ! have_vulkan || [ "$(mesa_major)" -lt "$MIN_MESA_MAJOR" ] 2>/dev/null; }; then
    mirror="$(debian_mirror)"
    if [ -z "$mirror" ]; then
        echo "setup: Debian 12 without a readable mirror in its apt sources; installing the stock Mesa (slower)" >&2
        install_pkgs mesa-vulkan-drivers libvulkan1
    else
        list=/etc/apt/sources.list.d/irt-bookworm-backports.list
        if ! grep -rqs "bookworm-backports" /etc/apt/sources.list /etc/apt/sources.list.d/; then
            echo "deb $mirror bookworm-backports main" | $SUDO tee "$list" >/dev/null
            echo "setup: enabled bookworm-backports from this machine's Debian mirror ($list)"
            apt_updated=0
        fi
        apt_update
        before="$(mesa_version)"
        $SUDO apt-get install -y -qq --no-install-recommends -t bookworm-backports \
            mesa-vulkan-drivers libvulkan1 >/dev/null
        echo "setup: lavapipe ${before:-(none)} -> $(mesa_version) from bookworm-backports"
    fi
elif ! have_vulkan; then
    echo "setup: no Vulkan driver found; installing Mesa's lavapipe (mesa-vulkan-drivers, libvulkan1)"
    install_pkgs mesa-vulkan-drivers libvulkan1
fi

have_vulkan || { echo "setup: lavapipe was installed but no Vulkan driver is visible" >&2; exit 1; }
major="$(mesa_major)"
if [ -n "$major" ] && [ "$major" -lt "$MIN_MESA_MAJOR" ] 2>/dev/null; then
    echo "setup: warning: Mesa $(mesa_version) is older than $MIN_MESA_MAJOR; irt works but traces 2-4x slower" >&2
else
    echo "setup: Vulkan driver ready (mesa-vulkan-drivers ${major:+$(mesa_version)})"
fi

# MPI (`irt render|view --mpi`, the default `mpi` cargo feature): Open MPI to build against and
# run with (rsmpi's build finds it through mpicc and generates its bindings with libclang).
if ! command -v mpicc >/dev/null || ! command -v mpirun >/dev/null \
    || ! ldconfig -p 2>/dev/null | grep 'libclang' >/dev/null; then
    echo "setup: installing Open MPI and libclang for the distributed path (openmpi-bin, libopenmpi-dev, libclang-dev)"
    install_pkgs openmpi-bin libopenmpi-dev libclang-dev
fi

# The render-farm test (tests/it/farm.rs) runs the Slurm job array of examples/slurm on a real
# single-node Slurm that it starts itself (no systemd, nothing left running), with munge for auth.
if ! command -v sbatch >/dev/null || ! command -v slurmctld >/dev/null \
    || ! command -v slurmd >/dev/null || ! command -v munged >/dev/null; then
    echo "setup: installing Slurm and munge for the render-farm test (slurm-wlm, munge)"
    install_pkgs slurm-wlm munge
fi

# The window tests (tests/it/viewer.rs) drive `irt view` under a virtual X server.
if ! command -v Xvfb >/dev/null || ! command -v xdotool >/dev/null; then
    echo "setup: installing Xvfb and xdotool for the window tests"
    install_pkgs xvfb xdotool xauth
fi
# ImageMagick's `import` captures a window as the X server holds it (tests/it/distributed.rs).
if ! command -v import >/dev/null; then
    echo "setup: installing ImageMagick for the window captures"
    install_pkgs imagemagick
fi

# The Embree 3 peer of `irt bench --peer embree` (cargo feature `embree`), only when asked for.
if [ "$WITH_EMBREE" = 1 ]; then
    if ldconfig -p 2>/dev/null | grep 'libembree3\.so ' >/dev/null; then
        echo "setup: Embree 3 already installed (build the peer with cargo build --release --features embree)"
    else
        echo "setup: installing libembree-dev for the Embree peer"
        install_pkgs libembree-dev
    fi
fi
