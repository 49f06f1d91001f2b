// Temporal metrics of animated scenes (issue 18, part 5): `penumbra compare --frame-range A:B`
// measures every method on each frame of a sequence against that frame's ground truth, and
// how much it flickers where the ground truth does not (docs/compare.md, "Sequences").
#pragma once

#include <vector>

#include "penumbra/core/image.h"
#include "penumbra/eval/comparison.h"

namespace penumbra {

// The mean over the pixels of |(v - v_prev) - (g - g_prev)|: the change of V from one frame
// to the next that the ground truth's change does not have. A method whose error is the same
// in both frames (a bias that moves with the picture, or none) scores 0 however large the
// error; noise that changes from frame to frame does not. Throws unless the four images have
// one size and channel count.
double frame_flicker(const Image& v_prev, const Image& v, const Image& g_prev, const Image& g);

// Temporal instability of a sequence: the mean over t > 0 of frame_flicker(v[t-1], v[t],
// g[t-1], g[t]). NaN with fewer than two frames. Throws unless v and g have as many frames.
double temporal_instability(const std::vector<Image>& v, const std::vector<Image>& g);

// The comparison of frame `begin` (run_comparison on setup at that frame: the table, the
// images, the ladder) and, over frames [begin, end) of the scene's animation, each method's
// FrameSequence entry: its mean |dV| per frame against that frame's ground truth (each cached
// on its own), its temporal instability, and its shadow time per frame rendered from nothing
// (the median of options.runs) and with reuse (one SequenceRenderer over the sequence, as
// `render --frame-range` and `bench --suite walk` render one). A method that fails on some frame keeps its message there. Throws an Error naming
// the scene when it has no "animation" block or the range is not within its frames.
Comparison run_sequence_comparison(const RunSetup& setup, const CompareOptions& options, int begin, int end);

}  // namespace penumbra
