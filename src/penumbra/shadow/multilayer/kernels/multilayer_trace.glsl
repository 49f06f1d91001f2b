// What mlsm_trace and mtsm_trace share (multilayer_kernels_shared.h): one thread per view-sample
// slot draws the CPU's light samples (this dispatch's part of them: first_sample, sample_count) (the `reference` stream: seed, light, camera ray, frame, so
// at equal seed the difference to `reference` is the map's error), traces each segment to its
// light point with the including kernel's
//   float trace_ray(MlTraceBlock b, DepthPyramidRef pyr, vec3 p, vec3 ng, bool closed, vec3 q,
//                   inout MlTraceCounters c)
// and writes V = sum T a / sum a (multilayer.cpp evaluate). With a near field (ml_near_fraction)
// the first part of each ray is traced through the scene's BVH as the CPU's fan traces it and
// combined with the map's answer by the kernel's
//   float combine_near(float t_map, float t_near)
// and a ray the map cannot answer for (kMlUnresolved: behind a full texel) is traced whole
// through the BVH.
// Counters per subgroup, then one atomic each.
#ifndef PENUMBRA_SHADOW_MULTILAYER_KERNELS_MULTILAYER_TRACE_GLSL
#define PENUMBRA_SHADOW_MULTILAYER_KERNELS_MULTILAYER_TRACE_GLSL

void main() {
  uint i = pn_thread_index();
  MlTraceCounters c;
  c.rays = 0u;
  c.nodes = 0u;
  c.texels = 0u;
  c.tested = 0u;
  c.hits = 0u;
  uint unresolved = 0u;
  if (i < pc.p.slots) {
    GpuViewSample s = ViewSamplesIn(pc.p.samples).v[i];
    if (s.object != kMissObject) {
      float v = 0.0f;
      bool last = true;
      if (pc.p.has_map != 0u) {
        MlTraceFrame f = TraceFrameRef(pc.p.trace_frame).f;
        scene_bind(pc.p.scene);
        GpuLight light = LightRef(pc.p.light).v;
        RngState rng = rng_keyed(f.seed, uint64_t(0x52454600u + uint(f.light_index)), gpu_sample_key(s),
                                 uint64_t(f.frame));
        LightSampler S = light_sampler_init(light.geometry, light.textured != 0u, s.p);
        if (S.mode != kSamplerNone) {  // else p sees no part of the emitting side: V = 0
          MlTraceBlock b = TraceBlockRef(pc.p.block).b;
          DepthPyramidRef pyr = depth_pyramid_ref(pc.p.nodes, b.levels, b.level_count);
          bool closed = (g_objects.v[s.object].flags & kObjectClosed) != 0u;
          // This dispatch's samples: the stream skipped to the first, the sums carried over.
          for (int k = 0; k < pc.p.first_sample; ++k) rng_next_2d(rng);
          vec2 acc = pc.p.first_sample == 0 ? vec2(0.0f) : Vec2s(f.sums).v[i];
          float sum = acc.x, wsum = acc.y;
          int end = min(f.n, pc.p.first_sample + pc.p.sample_count);
          for (int k = pc.p.first_sample; k < end; ++k) {
            vec2 u = stratified_cell(k, f.grid_cols, f.inv_cols, f.inv_rows, rng_next_2d(rng));
            vec3 dir;
            float dist, pdf, a;
            if (!gpu_light_sample(light, S, u, dir, dist, pdf, a)) continue;
            vec3 q = s.p + dir * dist;
            float t = trace_ray(b, pyr, s.p, s.ng, closed, q, c);
            if (t == kMlUnresolved) {  // multilayer.cpp trace_near_fields: the whole ray
              vec3 org, seg;
              fan_segment(s.p, offset_normal(s.ng), ray_offset_epsilon(s.p), q - s.p, org, seg);
              t = combine_near(1.0f, trace_transmittance(org, seg, kFanTfar));
              unresolved += 1u;
            } else if (t > 0.0f && b.setup.near_field > 0.0f) {  // multilayer.cpp trace_near_fields
              vec3 org, seg;
              fan_segment(s.p, offset_normal(s.ng), ray_offset_epsilon(s.p),
                          (q - s.p) * ml_near_fraction(b.view, b.setup, s.p, q), org, seg);
              t = combine_near(t, trace_transmittance(org, seg, kFanTfar));
            }
            sum += t * a;
            wsum += a;
          }
          last = end >= f.n;
          if (!last) Vec2s(f.sums).v[i] = vec2(sum, wsum);
          v = wsum > 0.0f ? sum / wsum : 0.0f;
        }
      }
      if (last) Floats(pc.p.visibility).v[i] = v;
    }
  }
  uint limited = subgroupMax(pn_loop_limit_hit(pc.p.canary) ? 1u : 0u);  // gpu/loop_limit.h
  uint rays = subgroupAdd(c.rays), nodes = subgroupAdd(c.nodes), texels = subgroupAdd(c.texels);
  uint tested = subgroupAdd(c.tested), hits = subgroupAdd(c.hits), unresolved_rays = subgroupAdd(unresolved);
  if (subgroupElect() && limited != 0u) atomicMax(CountersRef(pc.p.counters).c.limited, uint64_t(1));
  if (subgroupElect() && rays > 0u) {
    CountersRef counters = CountersRef(pc.p.counters);
    atomicAdd(counters.c.rays, uint64_t(rays));
    atomicAdd(counters.c.nodes, uint64_t(nodes));
    atomicAdd(counters.c.texels, uint64_t(texels));
    atomicAdd(counters.c.tested, uint64_t(tested));
    atomicAdd(counters.c.hits, uint64_t(hits));
    atomicAdd(counters.c.unresolved, uint64_t(unresolved_rays));
  }
}

#endif
