#!/usr/bin/env bash
# ThreadSanitizer over penumbra's multi-threaded paths (issue 17; docs/reliability.md): a
# clang build with -fsanitize=thread in build-tsan/, then the tests that run parallel loops
# on 2 threads (every method's determinism test, the renderer, the comparison and its shared
# cache, sweeps, the interrupt watchdog). Any report fails the test that caused it; the
# reports also go to build-tsan/tsan-reports/. Not part of CI (about 15 minutes on 2 cores).
# Usage: scripts/tsan.sh [ctest -R regex]
set -euo pipefail
cd "$(dirname "$0")/.."
tests=${1:-"Determinism|Parallel|Renderer|Comparison|CliCompare|Sweep|ReferenceCache|Interrupt|Progress|Cli\\.CtrlC|Viewer"}
CXX=clang++-14 cmake -S . -B build-tsan -DCMAKE_BUILD_TYPE=Release -DPENUMBRA_TSAN=ON -DPENUMBRA_BUILD_BENCH=OFF >/dev/null
cmake --build build-tsan -j "$(nproc)"
rm -rf build-tsan/tsan-reports && mkdir -p build-tsan/tsan-reports
TSAN_OPTIONS="suppressions=$PWD/scripts/tsan.supp log_path=$PWD/build-tsan/tsan-reports/report second_deadlock_stack=1" \
  ctest --test-dir build-tsan --output-on-failure -j 2 -R "$tests"
