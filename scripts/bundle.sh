#!/usr/bin/env bash
# A self-contained penumbra for another Linux x86-64 machine with glibc 2.36 or newer (a GPU
# machine without Debian's packages; docs/gpu.md, "The bundle"):
#   scripts/bundle.sh [--archive] [build-dir] [out-dir]     (defaults: build, dist/penumbra)
# writes out-dir/ (and with --archive also out-dir.tar.gz: about 30 MB, what travels to a lent GPU
# machine, whose working-tree copy is limited to 64 MiB) with
#   penumbra            the tool (its RPATH is $ORIGIN/lib: CMakeLists.txt), without debug info
#   lib/                every shared library it loads except glibc's own (libc, libm, libdl,
#                       libpthread, librt, the dynamic loader): libstdc++ and libgcc_s, Embree, TBB
#                       (and tbbmalloc, which TBB opens at run time), Assimp, OpenEXR, ..., and the
#                       Vulkan loader libvulkan.so.1 that volk opens at run time. The Vulkan driver
#                       is the machine's own (NVIDIA's, or Mesa's).
#   scenes/             the demo and benchmark scenes with the meshes they read (the bunny from
#                       glmark2-data as scenes/assets/bunny.obj)
#   gpu-bench.sh        the timing run of issue 31: `penumbra devices`, then `bench --suite gpu`
# scripts/bundle_test.sh checks it (CTest `bundle`).
set -euo pipefail
cd "$(dirname "$0")/.."
archive=0
if [ "${1:-}" = "--archive" ]; then archive=1; shift; fi
build=${1:-build}
out=${2:-dist/penumbra}
if [ ! -x "$build/penumbra" ]; then
  echo "scripts/bundle.sh: $build/penumbra does not exist: build it first (scripts/setup.sh)" >&2
  exit 1
fi
# Written beside the target and renamed, so a failed run leaves no half-written bundle.
tmp="$out.tmp.$$"
trap 'rm -rf "$tmp"' EXIT
rm -rf "$tmp"
mkdir -p "$tmp/lib" "$tmp/scenes/assets"
cp "$build/penumbra" "$tmp/penumbra"
strip --strip-debug "$tmp/penumbra"  # its symbols stay (profiles name functions)

# glibc's own libraries stay the machine's (the bundle needs glibc 2.36 or newer).
is_glibc() {
  case "$1" in
    linux-vdso.so.*|libc.so.*|libm.so.*|libdl.so.*|libpthread.so.*|librt.so.*|ld-linux*.so.*|libresolv.so.*|libutil.so.*|libmvec.so.*) return 0 ;;
  esac
  return 1
}
# The library a soname resolves to on this machine.
# (awk reads to the end: an early exit would end ldconfig with SIGPIPE, a failure under pipefail.)
resolve() { ldconfig -p | awk -v n="$1" '!found && $1 == n && /x86-64/ {print $NF; found = 1}'; }
copy_with_deps() {
  local file=$1
  while read -r name path; do
    [ -n "$path" ] || continue
    is_glibc "$name" && continue
    if [ ! -e "$tmp/lib/$name" ]; then
      cp -L "$path" "$tmp/lib/$name"
      copy_with_deps "$path"
    fi
  done < <(ldd "$file" | awk '/=>/ && $3 ~ /^\// {print $1, $3}')
}
copy_with_deps "$tmp/penumbra"
# Opened at run time (dlopen), so ldd does not list them: the Vulkan loader (volk) and TBB's
# scalable allocator.
for soname in libvulkan.so.1 libtbbmalloc.so.2; do
  path=$(resolve "$soname")
  if [ -z "$path" ]; then
    echo "scripts/bundle.sh: $soname is not installed (Debian: libvulkan1, libtbbmalloc2)" >&2
    exit 1
  fi
  cp -L "$path" "$tmp/lib/$soname"
  copy_with_deps "$path"
done

# The scenes, their assets and the bunny they read from glmark2-data, found beside them.
bunny=/usr/share/glmark2/models/bunny.obj
[ -f "$bunny" ] || { echo "scripts/bundle.sh: $bunny is missing (Debian: glmark2-data)" >&2; exit 1; }
cp scenes/assets/* "$tmp/scenes/assets/"
cp "$bunny" "$tmp/scenes/assets/bunny.obj"
for f in scenes/*.json; do
  sed "s#$bunny#assets/bunny.obj#g" "$f" > "$tmp/scenes/$(basename "$f")"
done

cat > "$tmp/gpu-bench.sh" <<'RUN'
#!/usr/bin/env bash
# The GPU timing run (issue 31; docs/gpu.md, "Timing on a GPU"): the devices, then every GPU
# method against its CPU version on this machine. Results in the folder given (default: .).
#   ./gpu-bench.sh [out-dir] [bench options...]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
out=${1:-.}
shift || true
mkdir -p "$out"
# NVIDIA's driver installed outside the loader's search path (some containers): point at it.
if [ -z "${VK_DRIVER_FILES:-}${VK_ICD_FILENAMES:-}" ]; then
  for icd in /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json /etc/vulkan/icd.d/nvidia_icd.json \
             /usr/share/vulkan/icd.d/nvidia_icd.json; do
    if [ -f "$icd" ]; then export VK_DRIVER_FILES=$icd; break; fi
  done
fi
"$here/penumbra" devices | tee "$out/devices.txt"
"$here/penumbra" devices --json > "$out/devices.json"
cd "$here"
./penumbra bench --suite gpu --scenes-dir scenes -o "$out" "$@"
RUN
chmod +x "$tmp/gpu-bench.sh"
rm -rf "$out"
mkdir -p "$(dirname "$out")"
mv "$tmp" "$out"
trap - EXIT
if [ "$archive" -eq 1 ]; then
  tar -czf "$out.tar.gz.tmp" -C "$(dirname "$out")" "$(basename "$out")"
  mv "$out.tar.gz.tmp" "$out.tar.gz"
fi
echo "scripts/bundle.sh: $out ($(du -sh "$out" | cut -f1)): $(ls "$out/lib" | wc -l) libraries, $(ls "$out/scenes"/*.json | wc -l) scenes"
