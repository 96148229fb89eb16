#!/usr/bin/env bash
# The README's main job on a fresh machine: installs Mesa's software Vulkan (lavapipe) if no
# Vulkan driver is present, builds the `probes` binary in release and runs `probes demo` on the
# built-in Cornell box (no files needed). Output: ./demo-out (images, table.md, results.json).
set -euo pipefail
cd "$(dirname "$0")/.."
if ! ls /usr/share/vulkan/icd.d/*.json >/dev/null 2>&1 && command -v apt-get >/dev/null 2>&1; then
    SUDO=""
    if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq mesa-vulkan-drivers libvulkan1 >/dev/null
fi
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
cargo run --release -p probe-cli --bin probes -- demo --out "${1:-demo-out}"
