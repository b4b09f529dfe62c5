#!/usr/bin/env bash
# Installs the Debian 12 packages lensfarm needs, skipping those already present.
# Idempotent and quiet; works as root (no sudo needed) or as a user with sudo.
#
#   scripts/setup.sh build   what the three binaries build against and `make demo` runs with
#   scripts/setup.sh test    build, plus what the test suite and the benchmarks use
#   scripts/setup.sh fuzz    test, plus clang for the libFuzzer targets
#
# tests/deploy/container_test.cpp checks these lists against every find_package of the CMake files
# (those outside tests/ and bench/ are BUILD_PACKAGES) and against the Dockerfile.
set -euo pipefail

# The libraries find_package and pkg_check_modules look for in the top CMakeLists.txt, and the
# tools that build with them.
BUILD_PACKAGES=(
  cmake make g++ pkg-config
  libglm-dev
  libgrpc++-dev protobuf-compiler-grpc libprotobuf-dev protobuf-compiler
  libopenexr-dev
  libspdlog-dev libfmt-dev
  libembree-dev libtbb-dev
  nlohmann-json3-dev libcli11-dev libtinyobjloader-dev libtinygltf-dev libstb-dev
  libpng-dev zlib1g-dev
  libssl-dev openssl
  libsqlite3-dev
  libcpp-httplib-dev
  libfftw3-dev
  libzstd-dev
)

# tests/ and bench/ (GoogleTest, Google Benchmark, yaml-cpp for the deployment files), and what
# the tests run: ip netns for the multi-host test, gnuplot for `lensfarm study`, systemd-analyze
# for the units, Chromium for the dashboard, a real Slurm (controller, node daemon, munge) for
# deploy/slurm.
TEST_PACKAGES=(
  libgtest-dev libgmock-dev libbenchmark-dev
  libyaml-cpp-dev
  iproute2
  gnuplot-nox
  systemd
  chromium chromium-driver
  slurm-wlm munge
)

# `make fuzz`: libFuzzer with ASan and UBSan.
FUZZ_PACKAGES=(
  clang libclang-rt-14-dev
)

profile=${1:-test}
case "$profile" in
  build) PACKAGES=("${BUILD_PACKAGES[@]}") ;;
  test) PACKAGES=("${BUILD_PACKAGES[@]}" "${TEST_PACKAGES[@]}") ;;
  fuzz) PACKAGES=("${BUILD_PACKAGES[@]}" "${TEST_PACKAGES[@]}" "${FUZZ_PACKAGES[@]}") ;;
  *) echo "setup: unknown profile '$profile' (build, test or fuzz)" >&2; exit 2 ;;
esac

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
echo "setup ($profile): installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq >/dev/null
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "setup: done"
