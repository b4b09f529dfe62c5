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
  libabsl-dev  # Abseil's thread-safety annotations: coordinator/core/locking.h
  libopenexr-dev
  libspdlog-dev libfmt-dev
  libembree-dev libtbb-dev
  nlohmann-json3-dev libcli11-dev libtinyobjloader-dev libtinygltf-dev libstb-dev
  libpng-dev zlib1g-dev
  libssl-dev openssl
  libsqlite3-dev
  libfftw3-dev
  libzstd-dev
  libzip-dev  # .usdz packages (common/scene/usdz_package.cpp)
  libopenvdb-dev  # OpenVDB grids
  libboost-dev  # Boost.Beast for the coordinator's HTTP servers (OpenVDB's headers include Boost's too)
)

# tests/ and bench/ (GoogleTest, Google Benchmark, yaml-cpp for the deployment files), and what
# the tests run: ip netns for the multi-host test, gnuplot for `lensfarm study`, systemd-analyze
# for the units, Chromium for the dashboard, a real Slurm (controller, node daemon, munge) for
# deploy/slurm, Blender (Cycles and its glTF exporter) for tests/blender, Python's gRPC for
# tests/python (the library's own users install python3-grpcio and python3-protobuf: docs/python.md).
TEST_PACKAGES=(
  libgtest-dev libgmock-dev libbenchmark-dev
  libyaml-cpp-dev
  libcpp-httplib-dev  # the tests' and benchmarks' HTTP client
  nodejs  # runs tests/deploy/kubernetes_schema.js, the Kubernetes schema check (its npm packages: below)
  iproute2
  gnuplot-nox
  systemd
  chromium chromium-driver
  slurm-wlm munge
  blender python3-numpy  # tests/blender: Cycles, and Blender's glTF exporter, which needs numpy
  python3-grpcio python3-protobuf  # the Python library (python/lensfarm) and the Blender add-on run on them
  xvfb xauth  # tests/blender/panel_ui.py: the add-on in Blender's real window (xvfb-run needs xauth)
  clang-format clang  # the style check of .clang-format and the coordinator's thread-safety analysis, tests/CMakeLists.txt
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

if [ "$(id -u)" -eq 0 ]; then SUDO=""; else SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
if [ ${#missing[@]} -ne 0 ]; then
  echo "setup ($profile): installing ${missing[*]}"
  $SUDO apt-get update -qq >/dev/null
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
  echo "setup: done"
fi

# The Kubernetes schema check's npm packages, at the exact versions of tests/deploy/package-lock.json,
# in tests/deploy/node_modules (not in git); again only when the lock file is newer. Debian's nodejs
# comes without npm (NodeSource's has it built in and conflicts with Debian's npm package).
if [ "$profile" != build ]; then
  deploy_tests="$(cd "$(dirname "$0")/../tests/deploy" && pwd)"
  if [ ! "$deploy_tests/node_modules/.package-lock.json" -nt "$deploy_tests/package-lock.json" ]; then
    if ! command -v npm >/dev/null; then
      $SUDO apt-get update -qq >/dev/null
      $SUDO apt-get install -y -qq --no-install-recommends npm >/dev/null
    fi
    echo "setup: npm ci in tests/deploy"
    npm ci --prefix "$deploy_tests" --no-audit --no-fund --loglevel=error >/dev/null
  fi
fi
