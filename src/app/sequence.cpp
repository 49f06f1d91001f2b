#include "app/sequence.h"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <regex>

#include <fmt/format.h>

#include "app/process.h"
#include "penumbra/core/error.h"
#include "penumbra/core/file_util.h"

namespace penumbra::app {

namespace fs = std::filesystem;

FrameRange parse_frame_range(const std::string& text, int frames, const std::string& option) {
  static const std::regex kRange(R"(([0-9]{0,9}):([0-9]{0,9}))");
  std::smatch m;
  FrameRange r{0, frames};
  if (std::regex_match(text, m, kRange)) {
    if (m[1].length() > 0) r.begin = std::stoi(m[1]);
    if (m[2].length() > 0) r.end = std::stoi(m[2]);
    if (r.begin < r.end && r.end <= frames) return r;
  }
  throw Error("{} {}: expected A:B, the frames A to B-1 with 0 <= A < B <= {} (the scene's animation.frames); "
              "A or B left out: from the first or to the last",
              option, text, frames);
}

namespace {
// The first run of '#' in the file name part of `pattern`: its start and length (0 if none).
std::pair<size_t, size_t> hash_run(const std::string& pattern, size_t from = 0) {
  const size_t start = pattern.find('#', from);
  if (start == std::string::npos) return {pattern.size(), 0};
  const size_t end = pattern.find_first_not_of('#', start);
  return {start, (end == std::string::npos ? pattern.size() : end) - start};
}
}  // namespace

void check_frame_pattern(const std::string& pattern, const std::string& option) {
  const auto [start, length] = hash_run(pattern);
  if (length == 0)
    throw Error("{} {}: a frame sequence needs a run of # for the frame number (e.g. out/frame_####.exr), or a .mp4",
                option, pattern);
  if (hash_run(pattern, start + length).second != 0)
    throw Error("{} {}: more than one run of #; the frame number has one place", option, pattern);
}

std::string frame_path(const std::string& pattern, int frame) {
  const auto [start, length] = hash_run(pattern);
  return pattern.substr(0, start) + fmt::format("{:0{}d}", frame, length) + pattern.substr(start + length);
}

bool is_mp4(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext == ".mp4";
}

void require_ffmpeg(const std::string& option, const std::string& path) {
  if (!on_path("ffmpeg"))
    throw Error("{} {}: writing an MP4 needs ffmpeg, which is not on PATH (Debian package ffmpeg; scripts/setup.sh "
                "installs it), or write frames with -o out/frame_####.png",
                option, path);
}

std::string mp4_frame_name(int frame) { return frame_path("frame_######.png", frame); }

void encode_mp4(const std::string& folder, int first_frame, float fps, const std::string& out) {
  // ffmpeg writes the temporary file (the format given, as its name does not end in .mp4);
  // the rename makes the movie appear whole or not at all.
  AtomicFile file(out);
  const std::string rate = fmt::format("{}", fps);
  const int status = run_program({"ffmpeg", "-nostdin", "-hide_banner", "-loglevel", "error", "-y", "-framerate", rate,
                                  "-start_number", std::to_string(first_frame), "-i",
                                  (fs::path(folder) / "frame_%06d.png").string(),
                                  // yuv420p halves the chroma resolution: libx264 needs even sides.
                                  "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2", "-c:v", "libx264", "-pix_fmt", "yuv420p",
                                  "-r", rate, "-f", "mp4", file.tmp()});
  if (status != 0) throw Error("{}: ffmpeg failed to encode the frames (exit status {})", out, status);
  file.commit();
}

}  // namespace penumbra::app
