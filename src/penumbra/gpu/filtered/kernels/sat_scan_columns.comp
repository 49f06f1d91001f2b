#version 460
// A summed-area table's columns (gpu/filtered/filtered_layout_shared.h): one thread per (table
// column x in [0, width], channel c) adds each row's entry to the one below, top to bottom (the
// CPU's order: SummedAreaTable::build's second pass).
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/core/shader_compat_math.h"
#include "penumbra/gpu/filtered/filtered_layout_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { SatBuildParams p; } pc;

void main() {
  SatTableLayout l = pc.p.table_layout;
  uint columns = uint(l.width) + 1u;
  uint i = pn_thread_index();
  if (i >= columns * uint(l.channels)) return;
  uint x = i % columns, c = i / columns;
  uint at = c * l.channel_stride + x * l.x_stride;
  if (pc.p.entry_kind == kSatEntriesUint) {
    Uints t = Uints(pc.p.table);
    uint above = t.v[at];
    for (int y = 1; y <= l.height; ++y) {
      at += l.row_stride;
      above += t.v[at];
      t.v[at] = above;
    }
  } else {
    Doubles t = Doubles(pc.p.table);
    double above = t.v[at];
    for (int y = 1; y <= l.height; ++y) {
      at += l.row_stride;
      precise double sum = t.v[at] + above;
      t.v[at] = sum;
      above = sum;
    }
  }
}
