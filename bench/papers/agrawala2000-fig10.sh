#!/usr/bin/env bash
# agrawala2000 Fig. 10: (right) the LDI's average depth complexity against the number of
# light samples, growing very slowly after the first few; (middle) rays actually traced by
# coherence-based ray tracing, growing roughly with the square root of the sample count
# (88.74 of 256 on the plant). Here: the plant at 512^2, 4 to 1024 light samples, timings
# and counters only. extra.depth_complexity.depth_complexity.svg is lam's average depth
# complexity over non-empty LDI texels after all the light samples (its stats' curve,
# last point), extra.ldi.layers.svg the LDI's layers; rays_per_view_sample.svg is the
# paper's "average rays traced".
source "$(dirname "$0")/common.sh"
methods_available lam,coherent-rt,reference
run_sweep agrawala2000-fig10 scenes/plant.json --methods "$methods" \
  --param spp=4,16,64,256,1024 --resolution 512 --no-reference --plot rays_per_view_sample \
  --plot extra.depth_complexity.depth_complexity --plot extra.ldi.layers
