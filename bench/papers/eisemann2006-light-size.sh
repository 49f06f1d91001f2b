#!/usr/bin/env bash
# eisemann2006: the cost of occlusion textures is nearly independent of the light size
# (and of scene complexity). Here: time against the light size (the rect's width, 0.25 to
# 3 scene units) on the plant, 512^2, 256 light samples for the methods that sample the
# light, timings only.
source "$(dirname "$0")/common.sh"
methods_available occlusion-textures,pcss,single-sample,reference
run_sweep eisemann2006-light-size scenes/plant.json --methods "$methods" \
  --param light.size=0.25,0.5,1,1.5,2,3 --resolution 512 --spp 256 --no-reference --runs 3 --warmup 1 \
  --x-scale linear
