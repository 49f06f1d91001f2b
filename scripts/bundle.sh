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
# The GPU timing run of issue 31 (docs/gpu.md, "Timing on a GPU"), written to finish inside one
# lease of a lent GPU machine: every step has a time limit taken from one deadline, and a step
# that fails or hangs costs only itself. Results in the folder given (default: .):
#   devices.txt, devices.json   `penumbra devices`
#   compile.log                 `penumbra devices --compile`: every kernel's pipeline built and
#                               timed (a kernel the driver is slow to compile is named here; the
#                               driver's shader cache then spares the renders that cost)
#   smoke-M.log/.json/.png      each GPU method once on the bunny at 480x270 and 64 light samples
#                               (its stages in the JSON): one that fails is left out of the suite
#   suite-bunny/, suite-plant/  `bench --suite gpu`: every GPU method against its CPU version
#   slow-960x540/               the methods whose smoke frame took over 2 s, at 960x540, once
#   profile/                    the same GPU side once more with kernel profiling
#                               (PENUMBRA_GPU_PROFILE=1): each frame's GPU time kernel by kernel
#   afsm-128/, afsm-1024/       afsm and reference on the bunny at 128 and 1024 light samples, the
#                               GPU side alone (sintorn2008's cost from 128 to 1024 samples)
#   crt-tile-8/                 coherent-rt with 8-pixel tiles (16 times the threads), GPU side alone
#   lam-paper-display/          lam with the paper's display (unresolved=umbra: no point traced),
#                               GPU side alone: what its display target (<= 1 ms) times
#   ot-light-S/                 occlusion-textures at light size S x (0.25 to 4), GPU side alone
#   wide/                       the bunny, the 25-tree forest and the street, GPU side alone
#                               (issue 34: what the wide scenes cost on a GPU)
#   probe-M.log/.json           a method that failed the smoke test, once more at 128x72 and 16
#                               light samples: slow (its time) or stuck (stopped again)
#   steps.txt                   each step's exit status and seconds
#   ./gpu-bench.sh [out-dir] [bench options for every bench run, e.g. --resolution 320 --runs 1]
# PENUMBRA_BENCH_BUDGET_S (default 500) is the whole run's deadline in seconds;
# PENUMBRA_SMOKE_RESOLUTION (default 480x270) the smoke renders' size.
set -uo pipefail
here=$(cd "$(dirname "$0")" && pwd)
out=${1:-.}
shift || true
mkdir -p "$out"
out=$(cd "$out" && pwd)
deadline=$(( $(date +%s) + ${PENUMBRA_BENCH_BUDGET_S:-500} ))
# NVIDIA's driver installed outside the loader's search path (some containers): point at it.
if [ -z "${VK_DRIVER_FILES:-}${VK_ICD_FILENAMES:-}" ]; then
  for icd in /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json /etc/vulkan/icd.d/nvidia_icd.json \
             /usr/share/vulkan/icd.d/nvidia_icd.json; do
    if [ -f "$icd" ]; then export VK_DRIVER_FILES=$icd; break; fi
  done
fi
cd "$here"
pen=./penumbra
# step NAME LIMIT_S COMMAND...: runs it with its output in NAME.log, stopped at LIMIT_S or at the
# deadline, whichever is first; skipped when under 15 s are left.
step() {
  local name=$1 limit=$2 left
  shift 2
  left=$(( deadline - $(date +%s) ))
  if [ "$left" -lt 15 ]; then
    echo "$name skipped (deadline)" | tee -a "$out/steps.txt"
    return 1
  fi
  [ "$limit" -gt "$left" ] && limit=$left
  local t0 rc
  t0=$(date +%s)
  timeout -k 5 "$limit" "$@" > "$out/$name.log" 2>&1
  rc=$?
  echo "$name exit $rc $(( $(date +%s) - t0 )) s (limit $limit s)" | tee -a "$out/steps.txt"
  return $rc
}
"$pen" devices | tee "$out/devices.txt"
"$pen" devices --json > "$out/devices.json"
command -v nvidia-smi > /dev/null && nvidia-smi > "$out/nvidia-smi.txt" 2>&1
step compile 90 "$pen" devices --compile

# Smoke: each GPU method once, small; the suite runs those that passed. One whose smoke frame took
# over 2 s (16 times the pixels and 4 times the light samples in the suite: a minute a frame) is
# timed apart, at 960x540 and once, after the suites (2026-11-28: coherent-rt's 1920x1080 frames
# on the plant ate the suite's limit, and nothing of that suite came back).
methods=()
slow=()
for m in $("$pen" methods | awk 'NR > 1 && $2 == "cpu," && $3 == "gpu" {print $1}'); do
  if step "smoke-$m" 20 "$pen" render scenes/bunny.json -m "$m" --device gpu \
       --resolution "${PENUMBRA_SMOKE_RESOLUTION:-480x270}" --spp 64 -q -o "$out/smoke-$m.png" --stats-json "$out/smoke-$m.json"; then
    ms=$(grep -o '"total_ms": *[0-9.]*' "$out/smoke-$m.json" | tail -1 | sed 's/.*: *//')
    if awk -v t="${ms:-0}" 'BEGIN { exit !(t > 2000) }'; then slow+=("$m"); else methods+=("$m"); fi
  fi
done
for m in $("$pen" methods | awk 'NR > 1 && $2 == "cpu," && $3 == "gpu" {print $1}'); do
  case ",$(IFS=,; echo "${methods[*]},${slow[*]}")," in *",$m,"*) continue ;; esac
  step "probe-$m" 20 "$pen" render scenes/bunny.json -m "$m" --device gpu --resolution 128x72 --spp 16 -q \
    -o "$out/probe-$m.png" --stats-json "$out/probe-$m.json"
done
list=$(IFS=,; echo "${methods[*]}")
slow_list=$(IFS=,; echo "${slow[*]}")
echo "suite methods: $list; slow (timed apart at 960x540): ${slow_list:-none}" | tee -a "$out/steps.txt"
[ -n "$list" ] || exit 1

step suite-bunny 240 "$pen" bench --suite gpu --scenes-dir scenes --scenes bunny --methods "$list" -o "$out/suite-bunny" -q "$@"
step suite-plant 240 "$pen" bench --suite gpu --scenes-dir scenes --scenes plant --methods "$list" -o "$out/suite-plant" -q "$@"
if [ -n "$slow_list" ]; then
  step slow-960x540 120 "$pen" bench --suite gpu --no-cpu --runs 1 --warmup 0 --resolution 960x540 --scenes-dir scenes \
    --scenes bunny,plant --methods "$slow_list" -o "$out/slow-960x540" -q "$@"
fi
step profile 150 env PENUMBRA_GPU_PROFILE=1 "$pen" bench --suite gpu --no-cpu --runs 1 --warmup 1 --scenes-dir scenes \
  --scenes bunny,plant --methods "$list" -o "$out/profile" -q "$@"
for spp in 128 1024; do
  step "afsm-$spp" 90 "$pen" bench --suite gpu --no-cpu --scenes-dir scenes --scenes bunny --methods reference,afsm \
    --spp "$spp" -o "$out/afsm-$spp" -q "$@"
done
step crt-tile-8 90 "$pen" bench --suite gpu --no-cpu --runs 1 --warmup 0 --scenes-dir scenes --scenes bunny,plant --methods coherent-rt \
  -p coherent-rt.tile=8 -o "$out/crt-tile-8" -q "$@"
# lam's display target (<= 1 ms) is the paper's display: the lookup alone, no point traced
# (docs/methods/lam.md "Points the LDI does not resolve"); the suites above time the default.
step lam-paper-display 90 "$pen" bench --suite gpu --no-cpu --scenes-dir scenes --scenes bunny,plant --methods lam \
  -p lam.unresolved=umbra -o "$out/lam-paper-display" -q "$@"
for s in 0.25 0.5 1 2 4; do
  step "ot-light-$s" 60 "$pen" bench --suite gpu --no-cpu --scenes-dir scenes --scenes bunny,plant \
    --methods occlusion-textures -p "light.size_scale=$s" -o "$out/ot-light-$s" -q "$@"
done
# Issue 34's wide scenes on the GPU (last: it only informs): the forest and the street beside
# the bunny, GPU side alone.
step wide 120 "$pen" bench --suite gpu --no-cpu --runs 3 --scenes-dir scenes --scenes bunny,forest,street \
  --methods "$list" -o "$out/wide" -q "$@"

exit 0
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
