// Frame sequences of animated scenes (docs/scene-format.md, "Animation"): the frame range and
// output patterns of `penumbra render --frame-range`, and MP4 encoding with ffmpeg.
#pragma once

#include <string>

namespace penumbra::app {

// Frames [begin, end) of an animation: half-open, as the scene file's [0, frames).
struct FrameRange {
  int begin = 0, end = 0;
  int count() const { return end - begin; }
};

// "A:B" (frames A to B-1), "A:" (A to the last), ":B" or ":" (all) over an animation of
// `frames` frames, 0 <= A < B <= frames. Throws an Error naming `option` and the text.
FrameRange parse_frame_range(const std::string& text, int frames, const std::string& option);

// Throws an Error naming `option` unless `pattern` has exactly one run of '#' (the place of
// the frame number: out/frame_####.exr).
void check_frame_pattern(const std::string& pattern, const std::string& option);
// `pattern` with its run of '#' replaced by `frame`, zero-padded to the run's length
// (frame_####.exr, 7: frame_0007.exr; a longer number keeps all its digits).
std::string frame_path(const std::string& pattern, int frame);

// Whether `path` names an MP4 file (.mp4, any case).
bool is_mp4(const std::string& path);
// Throws an Error naming `option`, `path` and ffmpeg when ffmpeg is not on $PATH: checked
// before anything is rendered.
void require_ffmpeg(const std::string& option, const std::string& path);
// Encodes the PNG frames `folder`/frame_NNNNNN.png, numbered from `first_frame` on, to an
// H.264 MP4 at `fps` frames per second (libx264, yuv420p: what players read; odd sizes are
// padded by a pixel), written atomically to `out`. Throws an Error naming `out` when ffmpeg
// fails (it prints its own error first).
void encode_mp4(const std::string& folder, int first_frame, float fps, const std::string& out);
// The name of frame `frame` in encode_mp4's folder.
std::string mp4_frame_name(int frame);

}  // namespace penumbra::app
