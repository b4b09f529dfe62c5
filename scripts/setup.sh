#!/usr/bin/env bash
# Installs the Debian 12 packages lensfarm builds against, skipping those already present.
# Idempotent and quiet; works as root (no sudo needed) or as a user with sudo.
set -euo pipefail

PACKAGES=(
  cmake make g++ pkg-config
  libglm-dev
  libgrpc++-dev protobuf-compiler-grpc libprotobuf-dev protobuf-compiler
  libopenexr-dev
  libspdlog-dev libfmt-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libembree-dev libtbb-dev
  nlohmann-json3-dev libcli11-dev libtinyobjloader-dev
  libpng-dev zlib1g-dev
  libssl-dev openssl
  libsqlite3-dev
  libcpp-httplib-dev libyaml-cpp-dev
  iproute2
  gnuplot-nox
  systemd
  chromium chromium-driver
  clang libclang-rt-14-dev
)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi

if [ "$(id -u)" -eq 0 ]; then SUDO=""; else SUDO="sudo"; fi
echo "setup: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq >/dev/null
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "setup: done"
