#!/usr/bin/env bash
# Fails loudly unless a Vulkan device exists: GPU tests never skip.
set -euo pipefail
if ! out=$(vulkaninfo --summary 2>&1); then
  echo "check-vulkan: vulkaninfo failed; no Vulkan device. GPU tests cannot run." >&2
  echo "$out" | tail -5 >&2
  exit 1
fi
devices=$(echo "$out" | grep -E '^\s*deviceName' || true)
if [ -z "$devices" ]; then
  echo "check-vulkan: no Vulkan device found (install mesa-vulkan-drivers for lavapipe)." >&2
  exit 1
fi
echo "check-vulkan: found $(echo "$devices" | sed 's/.*= //' | paste -sd, -)"
