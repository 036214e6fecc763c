#!/usr/bin/env bash
# Installs every Debian 12 package Vigil builds or runs with. Idempotent: only missing
# packages are installed. Run as root (or with sudo available).
set -euo pipefail

PKGS=(
  build-essential cmake ninja-build pkg-config git ca-certificates
  libbox2d-dev libopencv-dev libopencv-contrib-dev libeigen3-dev
  libompl-dev libboost-serialization-dev libboost-filesystem-dev libboost-system-dev
  cyclonedds-dev cyclonedds-tools
  liburdfdom-dev liburdfdom-headers-dev
  libosmesa6-dev libgl-dev mesa-common-dev
  libavcodec-dev libavformat-dev libavutil-dev libswscale-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libyaml-cpp-dev nlohmann-json3-dev libcli11-dev libspdlog-dev
  iproute2 nftables
  chromium fonts-dejavu-core python3-venv
)

missing=()
for p in "${PKGS[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "[deps] all ${#PKGS[@]} packages present"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
echo "[deps] installing ${#missing[@]} missing packages: ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "[deps] done"
