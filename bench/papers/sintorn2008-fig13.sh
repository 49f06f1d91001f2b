#!/usr/bin/env bash
# sintorn2008 Fig. 13: time against the number of light samples (128 to 1024) compared with
# one shadow map per light sample; the paper finds its cost roughly doubles from 128 to
# 1024 and is about an order of magnitude below the shadow maps. Here: the knot at 6,400
# triangles, 512^2, timings only.
source "$(dirname "$0")/common.sh"
methods_available afsm,multi-view-sm,reference
run_sweep sintorn2008-fig13 scenes/knot.json --methods "$methods" \
  --param spp=128,256,512,1024 --set generator.segments=200 \
  --resolution 512 --no-reference --runs 3 --warmup 1 --y-scale linear
