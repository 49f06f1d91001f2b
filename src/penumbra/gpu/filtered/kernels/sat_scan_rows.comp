#version 460
// A summed-area table's rows (gpu/filtered/filtered_layout_shared.h): one thread per (map row y,
// channel c) runs along the row and writes the running sums into table row y + 1, the CPU's
// additions in the CPU's order (SummedAreaTable::build: double + float, left to right; the
// occlusion textures' counts: exact). The thread of row 0 also zeroes table row 0.
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/core/shader_compat_math.h"
#include "penumbra/gpu/filtered/filtered_layout_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { SatBuildParams p; } pc;

// Channel c of map texel (x, y).
float source_value(int x, int y, int c) {
  SatTableLayout l = pc.p.table_layout;
  uint texel = uint(y) * uint(l.width) + uint(x);
  if (pc.p.source_kind == kSatSourceBits) return float((Uints(pc.p.source).v[texel] >> uint(c)) & 1u);
  return Floats(pc.p.source).v[texel * uint(l.channels) + uint(c)];
}

void main() {
  SatTableLayout l = pc.p.table_layout;
  uint i = pn_thread_index();
  if (i >= uint(l.height) * uint(l.channels)) return;
  int y = int(i / uint(l.channels)), c = int(i % uint(l.channels));
  uint row = uint(c) * l.channel_stride + uint(y + 1) * l.row_stride;
  uint top = uint(c) * l.channel_stride;
  if (pc.p.entry_kind == kSatEntriesUint) {
    Uints t = Uints(pc.p.table);
    uint run = 0u;
    t.v[row] = 0u;
    if (y == 0)
      for (int x = 0; x <= l.width; ++x) t.v[top + uint(x) * l.x_stride] = 0u;
    for (int x = 0; x < l.width; ++x) {
      run += uint(source_value(x, y, c));
      t.v[row + uint(x + 1) * l.x_stride] = run;
    }
  } else {
    Doubles t = Doubles(pc.p.table);
    double run = 0.0lf;
    t.v[row] = 0.0lf;
    if (y == 0)
      for (int x = 0; x <= l.width; ++x) t.v[top + uint(x) * l.x_stride] = 0.0lf;
    for (int x = 0; x < l.width; ++x) {
      run += double(source_value(x, y, c));
      t.v[row + uint(x + 1) * l.x_stride] = run;
    }
  }
}
