#!/usr/bin/env bash
# The CTest `bundle` (issue 28 part 6): scripts/bundle.sh's folder, copied outside the tree,
# renders a scene from its own folder on the CPU and on the GPU, and LD_DEBUG shows every shared
# object it loads coming from the bundle, apart from glibc's and the Vulkan driver's (what the
# Vulkan loader opens, and what those need).
#   scripts/bundle_test.sh BUILD_DIR
set -euo pipefail
src=$(cd "$(dirname "$0")/.." && pwd)
build=$(cd "$1" && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$src/scripts/bundle.sh" "$build" "$work/made" >/dev/null
cp -a "$work/made" "$work/elsewhere"  # a copy that never saw the tree
rm -rf "$work/made"
cd "$work/elsewhere"
./penumbra render scenes/demo.json -m hard --resolution 48 -o "$work/cpu.png" -q
LD_DEBUG=libs,files ./penumbra render scenes/bunny.json --device gpu -m reference --spp 4 --resolution 32 \
  -o "$work/gpu.png" -q 2> "$work/ld.log"
[ -s "$work/cpu.png" ] && [ -s "$work/gpu.png" ] || { echo "bundle: no image written" >&2; exit 1; }
python3 - "$work/ld.log" "$work/elsewhere" <<'PY'
import os, re, sys
log, bundle = open(sys.argv[1], errors="replace").read().splitlines(), os.path.realpath(sys.argv[2])
glibc = re.compile(r"^(linux-vdso|libc\.so|libm\.so|libdl\.so|libpthread\.so|librt\.so|ld-linux|libresolv\.so|libutil\.so|libmvec\.so)")
# What the Vulkan loader opens (drivers, their layers) and everything they need: the driver's.
driver, children = set(), {}
for line in log:
    m = re.search(r"file=(\S+) \[\d+\];\s+(needed by|dynamically loaded by) (\S+)", line)
    if m:
        children.setdefault(os.path.basename(m.group(3)), set()).add(os.path.basename(m.group(1)))
roots = children.get("libvulkan.so.1", set())
stack = list(roots)
while stack:
    name = stack.pop()
    if name in driver: continue
    driver.add(name)
    stack.extend(children.get(name, ()))
loaded = sorted({m.group(1) for line in log for m in [re.search(r"calling init: (\S+)", line)] if m})
bad = []
vulkan_loader = False
for path in loaded:
    name = os.path.basename(path)
    if os.path.realpath(path).startswith(bundle + "/"):
        vulkan_loader |= name == "libvulkan.so.1"
        continue
    if glibc.match(name) or name in driver: continue
    bad.append(path)
if not vulkan_loader:
    print("bundle: the Vulkan loader was not loaded from the bundle", file=sys.stderr); sys.exit(1)
if bad:
    print("bundle: loaded from outside the bundle: " + ", ".join(bad), file=sys.stderr); sys.exit(1)
print(f"bundle: {len(loaded)} shared objects, all from the bundle but glibc's and the Vulkan driver's ({len(driver)})")
PY
