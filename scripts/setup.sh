#!/usr/bin/env bash
# Installs what hadou needs on Debian/Ubuntu: Mesa's lavapipe (software Vulkan), the Vulkan
# loader and tools, the Khronos validation layers, shaderc/glslang static libraries, Xvfb for
# window tests, and the X11 libraries winit opens at run time (viewer, game prototype). Only
# missing packages are installed. Needs root or sudo.
set -euo pipefail

packages=(mesa-vulkan-drivers libvulkan1 vulkan-tools vulkan-validationlayers libshaderc-dev glslang-dev
          spirv-tools glslc xvfb xauth pkg-config gcc g++ make
          libx11-6 libx11-xcb1 libxcursor1 libxi6 libxrandr2 libxkbcommon0 libxkbcommon-x11-0)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}"
  sudo=""
  [ "$(id -u)" -eq 0 ] || sudo="sudo"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

if ! command -v cargo >/dev/null 2>&1; then
  echo "setup: cargo not found. hadou needs Rust 1.85 or newer (https://rustup.rs)." >&2
  exit 1
fi
for lib in libshaderc_combined.a libglslang.a libSPIRV-Tools-opt.a; do
  if [ ! -f "/usr/lib/x86_64-linux-gnu/$lib" ]; then
    echo "setup: /usr/lib/x86_64-linux-gnu/$lib is missing (package libshaderc-dev / glslang-dev / spirv-tools)" >&2
    exit 1
  fi
done
