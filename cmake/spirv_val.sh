#!/usr/bin/env bash
# The CTest `spirv_val`: every compiled kernel (build/shaders/*.spv) through the Khronos SPIR-V
# validator for Vulkan 1.3 with the scalar block layout the kernels use. Without spirv-val it
# skips (exit 77), unless PENUMBRA_REQUIRE_GPU is set (CI: scripts/test.sh installs spirv-tools):
# then it fails.   cmake/spirv_val.sh build/shaders
set -u
dir=$1
if ! command -v spirv-val >/dev/null; then
  if [ -n "${PENUMBRA_REQUIRE_GPU:-}" ] && [ "${PENUMBRA_REQUIRE_GPU}" != 0 ]; then
    echo "spirv-val is not installed (Debian: spirv-tools) and PENUMBRA_REQUIRE_GPU is set" >&2
    exit 1
  fi
  echo "spirv-val is not installed (Debian: spirv-tools): skipped"
  exit 77
fi
count=0 failed=0
for m in "$dir"/*.spv; do
  [ -e "$m" ] || continue
  count=$((count + 1))
  if ! out=$(spirv-val --target-env vulkan1.3 --scalar-block-layout "$m" 2>&1); then
    echo "$m: $out" >&2
    failed=$((failed + 1))
  fi
done
if [ "$count" -eq 0 ]; then echo "no SPIR-V modules in $dir" >&2; exit 1; fi
if [ "$failed" -gt 0 ]; then echo "$failed of $count SPIR-V modules failed validation" >&2; exit 1; fi
echo "$count SPIR-V modules valid"
