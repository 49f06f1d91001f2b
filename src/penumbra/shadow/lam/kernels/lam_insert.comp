#version 460
// `lam`'s insertion on the GPU (agrawala2000 §4, procedure Precompute, line 6; attenuation_map.cpp
// Builder's insert): one thread per texel of the reference view (the LDI at the light centre), for
// one light sample. The splats lam_scatter.comp listed for the texel are sorted by the pixel they
// came from and inserted in that order, exactly as the CPU inserts each texel's splats in the
// sample's scan order: the layer within epsilon nearest to the depth counts the sample (once per
// sample; a weighted layer adds the splats' weights, lam_shared.h "Counting a layer"), its depth
// the running mean; else a new layer, up to max_layers (more are dropped and
// counted). So the layers are the CPU's. A texel whose list overflowed gathers instead: the pixels
// that can reach it lie along a segment of the sample's map (the disparity bx/z, by/z over the
// depth range), walked row by row in scan order.
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "penumbra/gpu/raster/raster_access.glsl"
#include "penumbra/shadow/lam/lam_access.glsl"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { LamInsertParams p; } pc;
layout(buffer_reference, scalar) readonly buffer SampleViewRef { LamSampleView v; };
layout(buffer_reference, scalar) buffer BuildLayers { LamBuildLayer v[]; };
layout(buffer_reference, scalar) buffer SplatLists { LamSplatEntry v[]; };
layout(buffer_reference, scalar) buffer SampleCounts { LamSampleCounts v[]; };
layout(buffer_reference, scalar) buffer CountersRef { LamCounters c; };

// This thread's texel and what it counts.
uint g_texel, g_texels, g_count, g_splats, g_dropped, g_new_layers, g_new_nonempty;
BuildLayers g_layers;

// Whether pixel `pixel` of the sample's map shows an open surface (its triangle's object is not
// closed; lam_shared.h lam_epsilon), as the CPU's splats record it.
bool pixel_open(uint pixel) {
  // One tolerance for all and no weights: no need to know.
  if (pc.p.open_epsilon == pc.p.epsilon && pc.p.weighted == 0u) return false;
  uint object, prim;
  raster_source(uint(Uint64s(pc.p.keys).v[pixel] & 0xffffffffUL), object, prim);
  return (g_objects.v[object].flags & kObjectClosed) == 0u;
}

// attenuation_map.cpp Builder::build's insert: depth z of light sample `stamp` - 1, from an open
// surface or not, weight w at this texel (lam_shared.h, "Counting a layer").
void insert(float z, uint stamp, bool open, float w) {
  bool by_weight = pc.p.weighted != 0u && open;
  if (by_weight && !(w > 0.0f)) return;  // lands on no part of this texel
  float tol = lam_depth_tolerance(open ? pc.p.open_epsilon : pc.p.epsilon, z);
  int best = -1;
  float bestd = tol;
  for (uint i = 0u; i < g_count; ++i) {
    float dd = abs(g_layers.v[i * g_texels + g_texel].z - z);
    if (dd <= bestd) {
      bestd = dd;
      best = int(i);
    }
  }
  ++g_splats;
  if (best >= 0) {
    uint slot = uint(best) * g_texels + g_texel;
    LamBuildLayer l = g_layers.v[slot];
    if ((l.hits_stamp >> 16) != stamp) {  // the running mean and the paper's count: once per light sample
      uint hits = (l.hits_stamp & 0xffffu) + 1u;
      precise float mean = l.z + (z - l.z) * (1.0f / float(hits));
      l.z = mean;
      l.hits_stamp = hits | (stamp << 16);
      if (l.peak < 0.0f) l.count += 1.0f;
    }
    if (l.peak >= 0.0f) l.weight += w;
    g_layers.v[slot] = l;
  } else if (g_count < pc.p.max_layers) {
    // A layer is weighted by the kind of the splat that opened it.
    g_layers.v[g_count * g_texels + g_texel] =
        by_weight ? LamBuildLayer(z, 0.0f, w, 0.0f, 1u | (stamp << 16)) : LamBuildLayer(z, 1.0f, 0.0f, -1.0f, 1u | (stamp << 16));
    ++g_count;
    ++g_new_layers;
    if (g_count == 1u) ++g_new_nonempty;
  } else {
    ++g_dropped;
  }
}

// The splats of sample view sv into texel (tx, ty), in scan order, found from the map itself.
void gather(Uint64s keys, LamSampleView sv, int tx, int ty, uint stamp) {
  int W = pc.p.width, H = pc.p.height;
  // 1/z of every pixel lies in [1/far, 1/near]: fy = y + oy - by/z and fx = x + ox + bx/z reach
  // [ty - 1, ty + 1) and [tx - 1, tx + 1) only on a segment of rows and columns (one texel of
  // slack each side against rounding).
  float s0 = 1.0f / pc.p.far, s1 = 1.0f / pc.p.near;
  float bx = sv.bx, by = sv.by;
  int y_lo = max(0, int(floor(float(ty - 1 - sv.oy) + min(by * s0, by * s1))) - 1);
  int y_hi = min(sv.height - 1, int(ceil(float(ty + 1 - sv.oy) + max(by * s0, by * s1))) + 1);
  for (int y = y_lo; y <= y_hi; ++y) {
    float sa = s0, sb = s1;
    if (abs(by) > 1e-3f) {
      // The depths for which this row's fy can land in [ty - 1, ty + 1), half a texel wider.
      float c = float(y + sv.oy - ty);
      float r0 = (c - 1.5f) / by, r1 = (c + 1.5f) / by;
      sa = max(s0, min(r0, r1));
      sb = min(s1, max(r0, r1));
      if (sa > sb) continue;
    }
    int x_lo = max(0, int(floor(float(tx - 1 - sv.ox) - max(bx * sa, bx * sb))) - 1);
    int x_hi = min(sv.width - 1, int(ceil(float(tx + 1 - sv.ox) - min(bx * sa, bx * sb))) + 1);
    for (int x = x_lo; x <= x_hi; ++x) {
      float z = lam_sample_depth(keys, sv, x, y);
      if (!(z < pn_inf())) continue;
      LamSplat s;
      if (!lam_pixel_splat(keys, sv, x, y, z, W, H, pc.p.slope != 0u, s)) continue;
      int i = tx - s.ix, j = ty - s.iy;
      if (i < 0 || i > 1 || j < 0 || j > 1) continue;
      insert(lam_splat_depth(s, i, j), stamp, pixel_open(uint(y) * uint(sv.width) + uint(x)), lam_splat_weight(s, i, j));
    }
  }
}

void main() {
  uint t = pn_thread_index();
  g_texels = uint(pc.p.width) * uint(pc.p.height);
  g_texel = t;
  g_layers = BuildLayers(pc.p.layers);
  g_splats = 0u;
  g_dropped = 0u;
  g_new_layers = 0u;
  g_new_nonempty = 0u;
  uint stamp = pc.p.index + 1u;
  scene_bind(pc.p.scene);
  if (t < g_texels) {
    g_count = Uints(pc.p.counts).v[t];
    Uints list_counts = Uints(pc.p.list_counts);
    uint n = list_counts.v[t];
    list_counts.v[t] = 0u;  // ready for the next sample's scatter
    uint cap = pc.p.list_capacity;
    if (n <= cap) {
      // Insertion sort of the list by pixel (a handful of splats), then the inserts in that order.
      SplatLists lists = SplatLists(pc.p.lists);
      uint base = t * cap;
      for (uint i = 1u; i < n; ++i) {
        LamSplatEntry e = lists.v[base + i];
        uint j = i;
        for (; j > 0u && lists.v[base + j - 1u].pixel > e.pixel; --j) lists.v[base + j] = lists.v[base + j - 1u];
        lists.v[base + j] = e;
      }
      for (uint i = 0u; i < n; ++i)
        insert(lists.v[base + i].z, stamp, pixel_open(lists.v[base + i].pixel), lists.v[base + i].weight);
    } else {
      gather(Uint64s(pc.p.keys), SampleViewRef(pc.p.view).v, int(t % uint(pc.p.width)), int(t / uint(pc.p.width)),
             stamp);
    }
    // This sample's splats here are all in: its weighted layers add what it gave them (the CPU does
    // it at the texel's next sample, in the same order).
    if (pc.p.weighted != 0u && n > 0u)
      for (uint i = 0u; i < g_count; ++i) {
        uint slot = i * g_texels + t;
        LamBuildLayer l = g_layers.v[slot];
        if ((l.hits_stamp >> 16) == stamp && l.peak >= 0.0f) {
          lam_flush_layer(l.count, l.weight, l.peak);
          g_layers.v[slot] = l;
        }
      }
    Uints(pc.p.counts).v[t] = g_count;
  }
  uint layers = subgroupAdd(g_new_layers);
  uint nonempty = subgroupAdd(g_new_nonempty);
  uint splats = subgroupAdd(g_splats);
  uint dropped = subgroupAdd(g_dropped);
  if (subgroupElect() && splats > 0u) {
    SampleCounts sample_counts = SampleCounts(pc.p.sample_counts);
    atomicAdd(sample_counts.v[pc.p.index].layers, layers);
    atomicAdd(sample_counts.v[pc.p.index].nonempty, nonempty);
    CountersRef c = CountersRef(pc.p.counters);
    atomicAdd(c.c.splats, uint64_t(splats));
    atomicAdd(c.c.dropped, uint64_t(dropped));
  }
}
