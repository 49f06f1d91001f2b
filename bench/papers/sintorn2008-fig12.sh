#!/usr/bin/env bash
# sintorn2008 Fig. 12: time against the light radius at 256 light samples on a ~6K-triangle
# scene; the paper finds it linear. Here: the knot tessellated to 6,400 triangles
# (generator.segments=200), 512^2, timings only (median of 3 runs after a warm-up).
source "$(dirname "$0")/common.sh"
methods_available afsm,multi-view-sm,reference
run_sweep sintorn2008-fig12 scenes/knot.json --methods "$methods" \
  --param light.radius=0.2,0.4,0.6,0.8,1.06,1.4 --set generator.segments=200 \
  --resolution 512 --spp 256 --no-reference --runs 3 --warmup 1 --x-scale linear --y-scale linear
