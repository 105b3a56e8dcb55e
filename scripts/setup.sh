#!/usr/bin/env bash
# Installs what the workbench and its tests need on this machine, and nothing when it is all
# there (a second run costs a fraction of a second): Mesa's lavapipe 24.1 or newer, the X11
# libraries and Xvfb the viewer's window tests use, Slurm, munge and GNU parallel for the
# sharded-sweep tests (docs/CLUSTER.md). The README's two commands and CI run it first.
set -euo pipefail

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive

# Mesa's lavapipe, a Vulkan device on the CPU (no machine here has a GPU), 24.1 or newer:
# Mesa 22.3 (Debian 12's own) leaks about 1 MiB per presented frame and has no ray queries
# (docs/DEVICES.md). On Debian 12 it comes from bookworm-backports.
lavapipe() {
  local version
  version=$(dpkg-query -W -f='${Version}' mesa-vulkan-drivers 2>/dev/null || true)
  if [ -n "$version" ] && dpkg --compare-versions "$version" ge 24.1; then
    echo "lavapipe $version"
    return
  fi
  if ! command -v apt-get >/dev/null 2>&1; then
    if ls /usr/share/vulkan/icd.d/lvp_icd*.json >/dev/null 2>&1; then
      echo "not Debian: using the installed lavapipe; it should be Mesa 24.1 or newer"
      return
    fi
    echo "install Mesa's lavapipe 24.1 or newer (the package that provides" \
      "/usr/share/vulkan/icd.d/lvp_icd*.json, e.g. mesa-vulkan-drivers)" >&2
    return 1
  fi
  local codename
  codename=$(. /etc/os-release && echo "${VERSION_CODENAME:-}")
  if [ "$codename" = bookworm ]; then
    if ! grep -rqs '^[^#]*bookworm-backports' /etc/apt/sources.list /etc/apt/sources.list.d/; then
      echo "deb http://deb.debian.org/debian bookworm-backports main" \
        | $SUDO tee /etc/apt/sources.list.d/backports.list >/dev/null
    fi
    $SUDO apt-get update -qq
    $SUDO apt-get install -y -qq -t bookworm-backports mesa-vulkan-drivers
  else
    $SUDO apt-get update -qq
    $SUDO apt-get install -y -qq mesa-vulkan-drivers
  fi
  version=$(dpkg-query -W -f='${Version}' mesa-vulkan-drivers)
  echo "lavapipe $version"
  if ! dpkg --compare-versions "$version" ge 24.1; then
    echo "warning: lavapipe $version is older than Mesa 24.1: the tests still pass, but it leaks" \
      "about 1 MiB per presented frame and lacks ray queries; install Mesa 24.1 or newer" >&2
  fi
}

# The viewer's smoke test opens a real window under Xvfb (winit on X11 loads these libraries at
# run time). grep reads the whole list, so pipefail never sees ldconfig killed by SIGPIPE.
have_lib() { ldconfig -p | grep "$1" >/dev/null; }
window_libraries() {
  if ! command -v Xvfb >/dev/null 2>&1 || ! have_lib libxkbcommon-x11.so.0 || ! have_lib libXcursor.so.1 \
      || ! have_lib libXi.so.6 || ! have_lib libXrandr.so.2 || ! have_lib libX11-xcb.so.1; then
    $SUDO apt-get update -qq
    $SUDO apt-get install -y -qq xvfb libx11-6 libx11-xcb1 libxcursor1 libxi6 libxrandr2 libxkbcommon-x11-0
  fi
}

# The sharded-sweep tests (crates/workbench/tests/slurm.rs) start a one-node Slurm of their own
# and run GNU parallel (docs/CLUSTER.md).
cluster_tools() {
  if ! command -v slurmctld >/dev/null 2>&1 || ! command -v munged >/dev/null 2>&1 \
      || ! command -v parallel >/dev/null 2>&1; then
    $SUDO apt-get update -qq
    $SUDO apt-get install -y -qq slurm-wlm munge parallel
  fi
}


lavapipe
window_libraries
cluster_tools
