# Shared by the paper-figure scripts (sourced, not run).
#   PENUMBRA   the penumbra binary (default: build/penumbra of this checkout)
#   OUT        where the figures go (default: out/papers of this checkout)
#   CACHE_DIR  the reference cache (default: penumbra's, ~/.cache/penumbra)
# Each script sweeps the methods of its paper that exist in this build and says which
# are still missing: their rows are simply absent until the method lands.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
penumbra=${PENUMBRA:-$root/build/penumbra}
out_root=${OUT:-$root/out/papers}
cd "$root"
[ -x "$penumbra" ] || { echo "$penumbra not found: build penumbra first (scripts/setup.sh)" >&2; exit 1; }
cache_args=()
[ -n "${CACHE_DIR:-}" ] && cache_args=(--cache-dir "$CACHE_DIR")

# methods_available a,b,c: sets $methods to the registered ones (comma-separated) and
# $missing to the others, and names those on stderr.
methods=""
missing=""
methods_available() {
  local registered m
  registered=$("$penumbra" methods | awk 'NF && $1 !~ /^`/ {print $1}')
  IFS=, read -ra want <<< "$1"
  for m in "${want[@]}"; do
    # A method spec ("pcss:variant=xie2007") exists when its method does.
    if grep -qxF "${m%%:*}" <<< "$registered"; then
      methods+="${methods:+,}$m"
    else
      missing+="${missing:+, }$m"
    fi
  done
  if [ -n "$missing" ]; then echo "note: not implemented yet (pending): $missing" >&2; fi
  if [ -z "$methods" ]; then echo "none of $1 exists yet: nothing to run" >&2; exit 0; fi
}

# run_sweep NAME ARGS...: penumbra sweep into $out_root/NAME, recording the command and
# the pending methods beside the results.
run_sweep() {
  local name=$1; shift
  local dir="$out_root/$name"
  mkdir -p "$dir"
  echo "+ penumbra sweep $* -o $dir" >&2
  "$penumbra" sweep "$@" "${cache_args[@]}" -o "$dir"
  { echo "command: penumbra sweep $* -o $dir"; echo "pending methods: ${missing:-none}"; } > "$dir/README.txt"
}
