#!/usr/bin/env bash
# Installs every Debian 12 package penumbra needs, then configures it and builds the `penumbra`
# tool (with the viewer's page compiled in): README command 1, so only what the main job needs.
# Usage: scripts/setup.sh [--with-test-tools] [--with-python] [--all] [build-dir]   (default: build)
#   --with-python      also builds the Python module (build/python/penumbra: `import penumbra`,
#                      and what `--dask` runs; docs/python.md, docs/distributed.md)
#   --all              builds everything: the tool, the Python module, the test suite and the
#                      benchmarks (scripts/test.sh does this)
#   --with-test-tools  also installs what some tests use but penumbra does not need:
#                      chromium (the comparison page's and the viewer's headless-browser
#                      tests; without it they skip with a message), Node.js and the viewer
#                      test's npm packages (puppeteer-core, pinned in
#                      src/penumbra/viewer/e2e/package-lock.json), clang and its sanitizer and
#                      libFuzzer runtimes (the second build of scripts/test.sh), spirv-tools and
#                      the Vulkan validation layers (the GPU tests, docs/gpu.md)
# Safe to run again: apt-get skips what is installed, CMake rebuilds what changed.
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=build
with_test_tools=0
targets=(--target penumbra_cli)
for arg in "$@"; do
  case "$arg" in
    --with-test-tools) with_test_tools=1 ;;
    --with-python) [ "${targets[*]}" = "--target all" ] || targets+=(penumbra_python) ;;
    --all) targets=(--target all) ;;
    -*) echo "scripts/setup.sh: unknown option $arg (usage: scripts/setup.sh [--with-test-tools] [--with-python] [--all] [build-dir])" >&2; exit 2 ;;
    *) build_dir=$arg ;;
  esac
done

packages=(
  build-essential cmake pkg-config
  libembree-dev libtbb-dev libassimp-dev libopenexr-dev libstb-dev
  libcli11-dev nlohmann-json3-dev libfmt-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libhwy-dev     # Highway: portable SIMD with run-time dispatch (SSE4, AVX2, AVX-512)
  libcpp-httplib-dev   # the HTTP server of `penumbra view`
  glmark2-data   # the full Stanford bunny at /usr/share/glmark2/models/bunny.obj
  pybind11-dev python3-dev python3-numpy   # the Python module (docs/python.md)
  python3-distributed   # Dask: penumbra.distributed and --dask (docs/distributed.md)
  ffmpeg         # `penumbra render -o movie.mp4` encodes the frames with it (docs/scene-format.md)
  # The GPU backend (docs/gpu.md): Vulkan's headers and volk to build, glslc to compile the kernels,
  # the Vulkan loader and Mesa's drivers (lavapipe: Vulkan on the CPU) for --device gpu on a
  # machine without a GPU of its own.
  libvulkan-dev libvulkan-volk-dev glslc libvulkan1 mesa-vulkan-drivers
)
if [ "$with_test_tools" -eq 1 ]; then
  packages+=(chromium)   # headless browser test of the `penumbra compare` page
  packages+=(python3-pytest)   # the Python module's tests
  packages+=(clang-14 libclang-rt-14-dev)   # the sanitizer and libFuzzer build (scripts/test.sh)
  packages+=(spirv-tools vulkan-validationlayers)   # spirv-val on every kernel; the GPU tests run under validation
fi
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
# Node.js for the viewer's browser test: Debian's, unless a node and npm are there already
# (e.g. from another package source, which Debian's npm would conflict with).
if [ "$with_test_tools" -eq 1 ] && ! { command -v node && command -v npm; } >/dev/null; then
  missing+=(nodejs npm)
fi
if [ ${#missing[@]} -gt 0 ]; then
  sudo_cmd=""
  [ "$(id -u)" -ne 0 ] && sudo_cmd="sudo"
  echo "penumbra setup: installing ${missing[*]}" >&2
  $sudo_cmd apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

if [ "$with_test_tools" -eq 1 ]; then
  # Test tools only, never needed at run time: the exact versions of the lock file.
  npm ci --prefix src/penumbra/viewer/e2e --no-audit --no-fund --loglevel=error
fi

# The configuration knows every target (the tests, benchmarks and Python module need only the
# packages above); the build makes the ones asked for. The library compiles in groups of files
# (PENUMBRA_UNITY_BUILD): a first build in about half the time (README, "Set-up").
cmake -S . -B "$build_dir" -DCMAKE_BUILD_TYPE=Release -DPENUMBRA_UNITY_BUILD=ON >/dev/null
cmake --build "$build_dir" -j "$(nproc)" "${targets[@]}"
