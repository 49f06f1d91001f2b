#include "penumbra/eval/temporal.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "penumbra/core/error.h"
#include "penumbra/core/interrupt.h"
#include "penumbra/core/progress.h"
#include "penumbra/core/timer.h"
#include "penumbra/render/renderer.h"
#include "penumbra/render/sequence_renderer.h"
#include "penumbra/scene/animation.h"

namespace penumbra {

double frame_flicker(const Image& v_prev, const Image& v, const Image& g_prev, const Image& g) {
  for (const Image* im : {&v, &g_prev, &g})
    if (im->width() != v_prev.width() || im->height() != v_prev.height() || im->channels() != v_prev.channels())
      throw Error("temporal instability: the frames differ in size ({}x{}x{} and {}x{}x{})", v_prev.width(),
                  v_prev.height(), v_prev.channels(), im->width(), im->height(), im->channels());
  const std::vector<float>&a = v_prev.data(), &b = v.data(), &c = g_prev.data(), &d = g.data();
  if (a.empty()) return std::numeric_limits<double>::quiet_NaN();
  double sum = 0;
  for (size_t i = 0; i < a.size(); ++i)
    sum += std::abs((static_cast<double>(b[i]) - a[i]) - (static_cast<double>(d[i]) - c[i]));
  return sum / static_cast<double>(a.size());
}

double temporal_instability(const std::vector<Image>& v, const std::vector<Image>& g) {
  if (v.size() != g.size())
    throw Error("temporal instability: {} frames of the method and {} of the ground truth", v.size(), g.size());
  if (v.size() < 2) return std::numeric_limits<double>::quiet_NaN();
  double sum = 0;
  for (size_t t = 1; t < v.size(); ++t) sum += frame_flicker(v[t - 1], v[t], g[t - 1], g[t]);
  return sum / static_cast<double>(v.size() - 1);
}

namespace {

double mean_of(const std::vector<double>& v) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  double s = 0;
  for (double x : v) s += x;
  return s / static_cast<double>(v.size());
}

void fail(MethodFrames& m, int frame, const std::string& what) {
  m.ok = false;
  m.error = fmt::format("frame {}: {}", frame, what);
}

// The method's shadow time per frame with reuse: one SequenceRenderer over the frames (it
// keeps what stays valid between frames, as `render --frame-range` and `bench --suite walk`
// do). Appends to `ms` frame by frame (a failure leaves the frames done).
void reuse_times(const Scene& base, const RunSetup& setup, const std::string& label, int begin, int end, Progress* bar,
                 std::vector<double>& ms) {
  RenderSettings settings = method_render_settings(setup, label);
  settings.progress_bar = bar;
  SequenceRenderer sequence(base, settings);
  for (int t = begin; t < end; ++t) ms.push_back(shadow_time_ms(sequence.render(t).result));
}

}  // namespace

Comparison run_sequence_comparison(const RunSetup& setup, const CompareOptions& options, int begin, int end) {
  Timer wall;
  RunSetup as_written = setup;
  as_written.frame = -1;
  const Scene base = as_written.load();
  if (!base.animation) throw Error("{}: the scene has no \"animation\" block", setup.scene_path.string());
  if (begin < 0 || end > base.animation->frames || begin >= end)
    throw Error("{}: frames {}:{} are not within the animation's frames [0, {})", setup.scene_path.string(), begin,
                end, base.animation->frames);

  // One bar over the sequence: per frame the ground truth (when not cached) and every run of
  // every method, then one render per method and frame with reuse.
  CompareOptions per_frame = options;
  per_frame.keep_images = true;  // V of each frame, for the flicker of the next
  CompareOptions one_render = options;
  one_render.runs = 1;
  one_render.warmup_runs = 0;
  one_render.ground_truth = false;
  uint64_t units = comparison_progress_units(setup, one_render) * (end - begin);
  for (int t = begin; t < end; ++t) {
    RunSetup at = setup;
    at.frame = t;
    units += comparison_progress_units(at, options);
  }
  Progress own("compare", units, options.progress && !options.progress_bar);
  Progress* bar = options.progress_bar ? options.progress_bar : &own;
  per_frame.progress_bar = bar;
  uint64_t target = 0;
  auto step_done = [&](uint64_t step) {  // what a render did not report is added when it ends
    target += step;
    if (bar->done() < target) bar->add(target - bar->done());
  };
  const uint64_t method_units = comparison_progress_units(setup, one_render) / std::max<size_t>(1, options.methods.size());

  // Frame `begin`: the whole comparison (the table, the images and the ladder are its).
  RunSetup at = setup;
  at.frame = begin;
  const uint64_t first_units = comparison_progress_units(at, options);  // before its ground truth is cached
  bar->set_label(fmt::format("compare: frame {}", begin));
  Comparison c = run_comparison(at, per_frame);
  step_done(first_units);

  FrameSequence& seq = c.frames;
  seq.begin = begin;
  seq.end = end;
  seq.fps = base.animation->fps;
  seq.truth_cached.push_back(c.truth.from_cache);
  // The colour frames, for playing the sequence in the page.
  auto keep_color = [&](std::vector<Image>& frames, const Image& color) {
    if (options.keep_images) frames.push_back(color);
  };
  keep_color(seq.truth_color, c.truth.color);
  std::vector<Image> v_prev(c.runs.size());
  Image g_prev = c.truth.visibility;
  for (size_t k = 0; k < c.runs.size(); ++k) {
    MethodFrames m;
    m.method = c.runs[k].method;
    m.ok = c.runs[k].ok;
    if (m.ok) {
      m.v_mae.push_back(c.runs[k].v.mae);
      m.shadow_ms_fresh.push_back(c.runs[k].times.shadow_ms);
      v_prev[k] = c.runs[k].visibility;
      keep_color(m.color, c.runs[k].color);
    } else {
      fail(m, begin, c.runs[k].error);
    }
    seq.methods.push_back(std::move(m));
  }

  for (int t = begin + 1; t < end; ++t) {
    at.frame = t;
    const Scene scene = scene_at_frame(base, t);
    const bool truth_cached = ground_truth_cached(at, options.cache_dir);
    bar->set_label(fmt::format("compare: frame {} ground truth", t));
    const GroundTruth truth = ground_truth(at, scene, options.cache_dir, bar);
    step_done(truth_cached ? 0 : method_units);
    seq.truth_cached.push_back(truth.from_cache);
    keep_color(seq.truth_color, truth.color);
    for (size_t k = 0; k < seq.methods.size(); ++k) {
      MethodFrames& m = seq.methods[k];
      if (m.ok) {
        bar->set_label(fmt::format("compare: frame {} {}", t, m.method));
        MethodRun r = compare_method(at, scene, m.method, &truth, per_frame, bar);
        if (r.ok) {
          m.v_mae.push_back(r.v.mae);
          m.shadow_ms_fresh.push_back(r.times.shadow_ms);
          m.flicker.push_back(frame_flicker(v_prev[k], r.visibility, g_prev, truth.visibility));
          v_prev[k] = std::move(r.visibility);
          keep_color(m.color, r.color);
        } else {
          fail(m, t, r.error);
        }
      }
      step_done(method_units * (std::max(1, options.runs) + std::max(0, options.warmup_runs)));
    }
    g_prev = truth.visibility;
  }

  for (MethodFrames& m : seq.methods) {
    if (m.ok) {
      bar->set_label(fmt::format("compare: {} with reuse", m.method));
      try {
        reuse_times(base, setup, m.method, begin, end, bar, m.shadow_ms_reuse);
      } catch (const Interrupted&) {
        throw;  // Ctrl-C ends the run, whatever this step would do with an error
      } catch (const std::exception& e) {
        fail(m, begin + static_cast<int>(m.shadow_ms_reuse.size()), e.what());
      }
    }
    step_done(method_units * (end - begin));
    if (!m.ok) continue;
    m.v_mae_mean = mean_of(m.v_mae);
    m.temporal_instability = mean_of(m.flicker);
    m.ms_per_frame_fresh = mean_of(m.shadow_ms_fresh);
    m.ms_per_frame_reuse = mean_of(m.shadow_ms_reuse);
  }
  own.finish();
  c.has_frames = true;
  c.wall_ms = wall.elapsed_ms();
  return c;
}

}  // namespace penumbra
