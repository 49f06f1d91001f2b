#!/usr/bin/env bash
# xie2007 Fig. 4: error growth with the light radius. The paper: the error of PCF-based
# soft shadows grows fast with the light radius while ray-traced MLSM/MTSM stays nearly
# flat. Here: mean |dV| against a 1024-sample reference on the bunny (the paper used a
# character model, Shrek), 256 light samples, 256^2, light radius 0.1 to 1.06 (the
# scene's own 1.5 x 1.5 light). `reference` at 256 samples shows the noise floor that a
# method as good as the paper's ray-traced MLSM should approach. The paper's baseline,
# "PCF based soft shadows" (§3, eq. 1), is pcss:variant=xie2007; pcss is Fernando's PCSS.
source "$(dirname "$0")/common.sh"
methods_available mlsm,mtsm,pcss:variant=xie2007,pcss,hard,single-sample,reference
run_sweep xie2007-fig4 scenes/bunny.json --methods "$methods" \
  --param light.radius=0.1,0.2,0.3,0.45,0.6,0.8,1.06 \
  --resolution 256 --spp 256 --reference-spp 1024 --x-scale linear --y-scale linear --plot flip
