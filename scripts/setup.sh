#!/usr/bin/env bash
# Makes sure a Vulkan driver is present; installs Mesa's lavapipe (Vulkan on the CPU) with
# apt-get when none is found. Safe to run again: it changes nothing when Vulkan is already there.
set -euo pipefail

have_vulkan() {
    # The loader plus at least one installed driver manifest (ICD).
    ldconfig -p 2>/dev/null | grep -q 'libvulkan\.so\.1' || return 1
    local d
    for d in /usr/share/vulkan/icd.d /etc/vulkan/icd.d /usr/local/share/vulkan/icd.d; do
        compgen -G "$d/*.json" >/dev/null && return 0
    done
    return 1
}

if have_vulkan; then
    echo "setup: a Vulkan driver is installed"
    exit 0
fi

echo "setup: no Vulkan driver found; installing Mesa's lavapipe (mesa-vulkan-drivers, libvulkan1)"
if ! command -v apt-get >/dev/null; then
    echo "setup: apt-get not found. Install your distribution's Mesa Vulkan drivers (lavapipe) and the Vulkan loader, then run again." >&2
    exit 1
fi
SUDO=""
if [ "$(id -u)" -ne 0 ]; then
    SUDO="sudo"
fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends mesa-vulkan-drivers libvulkan1 >/dev/null
have_vulkan || { echo "setup: lavapipe was installed but no Vulkan driver is visible" >&2; exit 1; }
echo "setup: lavapipe installed"
