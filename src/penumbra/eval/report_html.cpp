// The comparison page (index.html): one self-contained file (images as PNG data URIs,
// inline CSS and JS, nothing fetched) that reads at a glance: a table of every method
// sorted by error with the best value of each column highlighted, then each method's image
// beside its signed and absolute V error maps on one shared scale, and a zoom that shows
// the same crop of every image magnified.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <sstream>

#include <fmt/format.h>

#include "penumbra/eval/comparison.h"
#include "penumbra/eval/heatmap.h"
#include "penumbra/eval/metrics.h"
#include "penumbra/eval/report_util.h"
#include "penumbra/eval/svg_plot.h"

namespace penumbra {

using nlohmann::json;

namespace {

// 1, 2 or 5 x 10^k, the smallest such at or above v.
float nice_ceiling(float v) {
  if (!(v > 0)) return 1.0f;
  double e = std::floor(std::log10(v));
  double base = std::pow(10.0, e);
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (m * base >= v * (1 - 1e-6)) return static_cast<float>(m * base);
  return static_cast<float>(10 * base);
}

std::string css_gradient(ColorMap map) {
  std::string stops;
  for (int i = 0; i <= 10; ++i) {
    Vec3f c = colormap_srgb(map, i / 10.0f);
    auto b = [](float x) { return static_cast<int>(std::lround(clamp01(x) * 255)); };
    stops += fmt::format("{}#{:02x}{:02x}{:02x} {}%", i ? ", " : "", b(c.x), b(c.y), b(c.z), i * 10);
  }
  return "linear-gradient(to right, " + stops + ")";
}

struct Column {
  std::string key, header, tip;
  enum class Better { kNone, kLower, kHigher, kLowerAbs } better = Better::kNone;
  bool needs_truth = false;
  bool needs_ladder = false;  // the equal-quality columns
  bool needs_frames = false;  // the sequence's columns (compare --frame-range)
};

const std::vector<Column>& columns() {
  using B = Column::Better;
  static const std::vector<Column> cols = {
      {"light_samples", "spp", "light samples per shading point (— : the method does not sample the light)"},
      {"v_mae", "mean |ΔV|", "mean absolute error of the visibility V against the ground truth", B::kLower, true},
      {"v_rmse", "RMSE ΔV", "root mean square error of V", B::kLower, true},
      {"v_max", "max |ΔV|", "largest absolute error of V in any pixel", B::kLower, true},
      {"v_mean_signed", "mean ΔV", "bias: mean of (method − ground truth); negative = too dark", B::kLowerAbs, true},
      {"color_psnr", "PSNR dB", "PSNR of the colour image as displayed (sRGB, clamped), peak 1", B::kHigher, true},
      {"flip", "FLIP", "mean FLIP (Andersson et al. 2020) of the colour image; 0 = identical", B::kLower, true},
      {"shadow_ms", "shadow ms", "the method's own time: total − camera pass − compose (median of the runs)",
       B::kLower},
      {"speedup", "speed-up", "time of the basis (see above) / this method's shadow time", B::kHigher},
      {"frames_v_mae", "mean |ΔV| over frames",
       "the mean over the sequence's frames of mean |ΔV| against each frame's own ground truth", B::kLower, true,
       false, true},
      {"temporal_instability", "temporal instability",
       "mean over frames t > A and pixels of |(V_t − V_t−1) − (G_t − G_t−1)|, G the ground truth: flicker the "
       "ground truth does not have (issue 18)",
       B::kLower, true, false, true},
      {"ms_per_frame_reuse", "ms/frame reuse",
       "mean shadow time per frame, one renderer over the sequence keeping what stays valid across frames",
       B::kLower, false, false, true},
      {"ms_per_frame_fresh", "ms/frame fresh", "mean shadow time per frame, every frame rendered from nothing",
       B::kLower, false, false, true},
      {"eq_v_spp", "ref. spp at equal |ΔV|",
       "light samples the reference needs for this method's mean |ΔV| (reference ladder 1, 2, 4, ..., interpolated "
       "log-log); ≥: the method beats every rung; ≤: worse than the reference at 1 sample",
       B::kNone, true, true},
      {"eq_v_speedup", "speed-up at equal |ΔV|",
       "the reference's shadow time at that many samples (interpolated from the ladder's times) / this method's",
       B::kHigher, true, true},
      {"eq_flip_spp", "ref. spp at equal FLIP", "as for mean |ΔV|, with FLIP", B::kNone, true, true},
      {"eq_flip_speedup", "speed-up at equal FLIP", "as for mean |ΔV|, with FLIP", B::kHigher, true, true},
      {"camera_pass_ms", "camera ms", "camera pass (primary rays on Embree), the same work for every method"},
      {"total_ms", "total ms", "the whole render: camera pass, every phase, compose"},
      {"rays_traced", "rays", "shadow rays traced through geometry or depth images"},
      {"memory_bytes", "memory", "peak size of the method's light-space structures"},
  };
  return cols;
}

// `f`: the method's sequence (compare --frame-range), or null.
double run_value(const MethodRun& r, const std::string& key, const MethodFrames* f = nullptr) {
  if (f && key == "frames_v_mae") return f->v_mae_mean;
  if (f && key == "temporal_instability") return f->temporal_instability;
  if (f && key == "ms_per_frame_reuse") return f->ms_per_frame_reuse;
  if (f && key == "ms_per_frame_fresh") return f->ms_per_frame_fresh;
  if (key == "light_samples") return r.light_samples;
  if (key == "v_mae") return r.v.mae;
  if (key == "v_rmse") return r.v.rmse;
  if (key == "v_max") return r.v.max_abs;
  if (key == "v_mean_signed") return r.v.mean_signed;
  if (key == "color_psnr") return r.color_psnr;
  if (key == "flip") return r.flip;
  if (key == "shadow_ms") return r.times.shadow_ms;
  if (key == "speedup") return r.speedup;
  if (key == "eq_v_spp") return r.eq_v.samples;
  if (key == "eq_v_speedup") return r.eq_v.speedup;
  if (key == "eq_flip_spp") return r.eq_flip.samples;
  if (key == "eq_flip_speedup") return r.eq_flip.speedup;
  if (key == "camera_pass_ms") return r.times.camera_pass_ms;
  if (key == "total_ms") return r.times.total_ms;
  if (key == "rays_traced") return static_cast<double>(r.stats.rays_traced);
  if (key == "memory_bytes") return static_cast<double>(r.stats.memory_bytes);
  return std::numeric_limits<double>::quiet_NaN();
}

// The exact value, as results.json holds it.
json run_json_value(const MethodRun& r, const std::string& key, const MethodFrames* f = nullptr) {
  if (key == "light_samples") return r.light_samples;
  if (key == "rays_traced") return r.stats.rays_traced;
  if (key == "memory_bytes") return r.stats.memory_bytes;
  return json_number(run_value(r, key, f));
}

// The sequence of a method that ran over every frame of it (null: no sequence, or it failed).
const MethodFrames* frames_of(const Comparison& c, const MethodRun& r) {
  if (!c.has_frames) return nullptr;
  for (const MethodFrames& f : c.frames.methods)
    if (f.method == r.method) return f.ok ? &f : nullptr;
  return nullptr;
}

// The equal-quality point a column shows (null for other columns).
const EqualQuality* equal_quality_of(const MethodRun& r, const std::string& key) {
  if (key.rfind("eq_v_", 0) == 0) return &r.eq_v;
  if (key.rfind("eq_flip_", 0) == 0) return &r.eq_flip;
  return nullptr;
}

// Whether a value may be the best of its column: an equal-quality speed-up that is only an
// upper bound (the method is worse than the reference at 1 sample) is not.
bool rankable(const MethodRun& r, const std::string& key) {
  const EqualQuality* q = equal_quality_of(r, key);
  return !q || q->bound != QualityBound::kAtMost;
}

std::string display(const MethodRun& r, const std::string& key, const MethodFrames* f = nullptr) {
  double v = run_value(r, key, f);
  if (key == "light_samples") return r.light_samples > 0 ? std::to_string(r.light_samples) : "—";
  if (std::isnan(v)) return "—";
  if (const EqualQuality* q = equal_quality_of(r, key)) {
    const std::string bound = q->bound == QualityBound::kAtLeast ? "≥ " : q->bound == QualityBound::kAtMost ? "≤ " : "";
    const bool speedup = key.size() > 8 && key.substr(key.size() - 8) == "_speedup";
    return bound + (speedup ? format_significant(v, 3) + "×" : format_light_samples(v));
  }
  if (key == "color_psnr") return std::isinf(v) ? "∞" : fmt::format("{:.2f}", v);
  if (key == "speedup") return format_significant(v, 3) + "×";
  if (key == "rays_traced") return format_grouped(r.stats.rays_traced);
  if (key == "memory_bytes") return format_bytes(r.stats.memory_bytes);
  return format_significant(v, 3);
}

const char* kStyle = R"CSS(
:root { --thumb: 256px; color-scheme: light; }
body { font: 14px/1.45 system-ui, -apple-system, "Segoe UI", sans-serif; margin: 24px; color: #1d1d1f; background: #fafafa; }
h1 { font-size: 22px; margin: 0 0 4px; } h2 { font-size: 17px; margin: 28px 0 8px; }
.meta { color: #555; margin: 2px 0; } .meta code { color: #333; }
table { border-collapse: collapse; background: #fff; box-shadow: 0 1px 2px #0002; }
th, td { padding: 5px 9px; border-bottom: 1px solid #e3e3e3; text-align: right; white-space: nowrap; }
th { background: #f0f0f3; cursor: pointer; user-select: none; position: sticky; top: 0; }
th.sorted-asc::after { content: " ▲"; font-size: 10px; } th.sorted-desc::after { content: " ▼"; font-size: 10px; }
td.name, th.name { text-align: left; font-weight: 600; }
td.best { background: #d8f3dc; font-weight: 700; }
td.phases { text-align: left; color: #555; font-size: 12px; }
tr.failed td { background: #fde8e8; } td.error { text-align: left; color: #a00; white-space: normal; max-width: 60em; }
.legend { display: inline-flex; align-items: center; gap: 8px; margin: 4px 24px 4px 0; }
.bar { width: 220px; height: 12px; border: 1px solid #999; }
.toolbar { position: sticky; top: 0; z-index: 5; background: #fafafaee; padding: 6px 0; border-bottom: 1px solid #ddd; }
.toolbar button { margin-left: 8px; }
.cards { display: flex; flex-direction: column; gap: 14px; }
.card { background: #fff; box-shadow: 0 1px 2px #0002; padding: 10px 12px; }
.card h3 { margin: 0 0 4px; font-size: 15px; } .card .sub { color: #555; font-size: 12px; margin-bottom: 6px; }
.card.failed { background: #fde8e8; } .card.failed .error { color: #a00; }
.row { display: flex; flex-wrap: wrap; gap: 10px; }
figure { margin: 0; } figcaption { font-size: 12px; color: #555; margin-top: 3px; }
.view { position: relative; display: inline-block; line-height: 0; cursor: crosshair; touch-action: none; }
.view img, .view canvas { width: var(--thumb); height: auto; }
.view img.up, .view canvas { image-rendering: pixelated; }
.view img { outline: 1px solid #d0d0d0; }
.view canvas { position: absolute; left: 0; top: 0; }
.band { position: absolute; border: 1px dashed #fff; outline: 1px dashed #000; pointer-events: none; display: none; }
)CSS";

const char* kScript = R"JS(
(() => {
  'use strict';
  const root = document.documentElement;
  const views = Array.from(document.querySelectorAll('.view'));
  const status = document.getElementById('zoom-status');
  const thumb = document.getElementById('thumb');
  let crop = null;  // {x, y, s}: top-left and side, as fractions of the image's width and height

  function natural() {
    const img = views.length ? views[0].querySelector('img') : null;
    return img && img.naturalWidth ? [img.naturalWidth, img.naturalHeight] : [1, 1];
  }
  function clampCrop(c) {
    const [nw, nh] = natural();
    const minS = Math.min(1, 4 / Math.min(nw, nh));
    let s = Math.max(minS, Math.min(1, c.s));
    if (s >= 1) return null;
    let x = Math.max(0, Math.min(1 - s, c.x)), y = Math.max(0, Math.min(1 - s, c.y));
    // Whole pixels: a magnified crop shows square, unblended pixels.
    x = Math.round(x * nw) / nw; y = Math.round(y * nh) / nh;
    return {x, y, s};
  }
  function draw() {
    for (const v of views) {
      const img = v.querySelector('img'), cv = v.querySelector('canvas');
      img.classList.toggle('up', img.clientWidth > img.naturalWidth);
      if (!crop || !img.naturalWidth) { cv.hidden = true; continue; }
      const w = img.clientWidth, h = img.clientHeight, d = window.devicePixelRatio || 1;
      cv.width = Math.max(1, Math.round(w * d));
      cv.height = Math.max(1, Math.round(h * d));
      cv.style.width = w + 'px';
      cv.style.height = h + 'px';
      const g = cv.getContext('2d');
      g.imageSmoothingEnabled = false;
      const nw = img.naturalWidth, nh = img.naturalHeight;
      g.drawImage(img, crop.x * nw, crop.y * nh, Math.max(1, crop.s * nw), Math.max(1, crop.s * nh),
                  0, 0, cv.width, cv.height);
      cv.hidden = false;
    }
    // The crop in the address (#zoom=x,y,side): a zoomed view can be bookmarked or shared.
    if (location.hash !== '#selftest') {
      const h = crop ? `#zoom=${crop.x.toFixed(4)},${crop.y.toFixed(4)},${crop.s.toFixed(4)}` : ' ';
      try { history.replaceState(null, '', h); } catch (err) { /* file:// may refuse; the zoom still works */ }
    }
    if (status) {
      if (!crop) {
        status.textContent = 'Click an image to zoom every image to the same spot; drag to choose the crop; ' +
                             'wheel or +/− to change the magnification; Esc to reset.';
      } else {
        const [nw, nh] = natural();
        status.textContent = `Zoom ${(1 / crop.s).toFixed(1)}×: pixels x ${Math.round(crop.x * nw)}–` +
          `${Math.round((crop.x + crop.s) * nw)}, y ${Math.round(crop.y * nh)}–${Math.round((crop.y + crop.s) * nh)}` +
          ' (Esc to reset)';
      }
    }
  }
  // The image point under the pointer, in fractions of the whole image.
  function point(v, e) {
    const r = v.getBoundingClientRect();
    let u = (e.clientX - r.left) / r.width, w = (e.clientY - r.top) / r.height;
    if (crop) { u = crop.x + u * crop.s; w = crop.y + w * crop.s; }
    return [u, w];
  }
  function zoomAt(u, w, factor) {
    const s0 = crop ? crop.s : 1, x0 = crop ? crop.x : 0, y0 = crop ? crop.y : 0;
    const s = s0 * factor;
    crop = clampCrop({x: u - (u - x0) * (s / s0), y: w - (w - y0) * (s / s0), s});
    draw();
  }
  for (const v of views) {
    const band = v.querySelector('.band');
    let start = null;
    v.addEventListener('pointerdown', e => {
      e.preventDefault();
      start = {p: point(v, e), cx: e.clientX, cy: e.clientY};
      v.setPointerCapture(e.pointerId);
    });
    v.addEventListener('pointermove', e => {
      if (!start) return;
      const r = v.getBoundingClientRect();
      const dx = e.clientX - start.cx, dy = e.clientY - start.cy, side = Math.max(Math.abs(dx), Math.abs(dy));
      if (side < 4) { band.style.display = 'none'; return; }
      band.style.display = 'block';
      band.style.left = (dx < 0 ? start.cx - side : start.cx) - r.left + 'px';
      band.style.top = (dy < 0 ? start.cy - side : start.cy) - r.top + 'px';
      band.style.width = band.style.height = side + 'px';
    });
    v.addEventListener('pointerup', e => {
      if (!start) return;
      band.style.display = 'none';
      const p = point(v, e);
      const moved = Math.max(Math.abs(e.clientX - start.cx), Math.abs(e.clientY - start.cy));
      if (moved < 4) {
        const s = crop ? crop.s : 0.25;
        crop = clampCrop({x: p[0] - s / 2, y: p[1] - s / 2, s});
      } else {
        const s = Math.max(Math.abs(p[0] - start.p[0]), Math.abs(p[1] - start.p[1]));
        crop = clampCrop({x: p[0] < start.p[0] ? start.p[0] - s : start.p[0],
                          y: p[1] < start.p[1] ? start.p[1] - s : start.p[1], s});
      }
      start = null;
      draw();
    });
    v.addEventListener('wheel', e => {
      e.preventDefault();
      const p = point(v, e);
      zoomAt(p[0], p[1], e.deltaY > 0 ? 1.25 : 0.8);
    }, {passive: false});
  }
  document.addEventListener('keydown', e => {
    if (e.key === 'Escape') { crop = null; draw(); }
    const c = crop ? [crop.x + crop.s / 2, crop.y + crop.s / 2] : [0.5, 0.5];
    if (e.key === '+' || e.key === '=') zoomAt(c[0], c[1], 0.8);
    if (e.key === '-') zoomAt(c[0], c[1], 1.25);
  });
  const reset = document.getElementById('zoom-reset');
  if (reset) reset.addEventListener('click', () => { crop = null; draw(); });
  if (thumb) thumb.addEventListener('input', () => {
    root.style.setProperty('--thumb', thumb.value + 'px');
    draw();
  });

  // Sortable table: click a header to sort by its column (failed methods stay last).
  const table = document.getElementById('results');
  if (table) {
    const heads = Array.from(table.tHead.rows[0].cells);
    heads.forEach((th, col) => th.addEventListener('click', () => {
      const asc = !th.classList.contains('sorted-asc');
      heads.forEach(h => h.classList.remove('sorted-asc', 'sorted-desc'));
      th.classList.add(asc ? 'sorted-asc' : 'sorted-desc');
      const body = table.tBodies[0];
      const rows = Array.from(body.rows);
      const key = r => {
        if (r.classList.contains('failed')) return null;
        const cell = r.cells[col];
        if (col === 0) return cell.textContent;
        const v = cell ? cell.dataset.value : undefined;
        if (v === undefined || v === 'null') return null;
        if (v === '"inf"') return Infinity;
        return Number(v);
      };
      rows.sort((a, b) => {
        const ka = key(a), kb = key(b);
        if (ka === null) return kb === null ? 0 : 1;
        if (kb === null) return -1;
        const d = typeof ka === 'string' ? ka.localeCompare(kb) : ka - kb;
        return asc ? d : -d;
      });
      rows.forEach(r => body.appendChild(r));
    }));
  }

  window.addEventListener('load', () => {
    const imgs = Array.from(document.images);
    document.body.dataset.imagesTotal = imgs.length;
    document.body.dataset.imagesLoaded = imgs.filter(i => i.complete && i.naturalWidth > 0).length;
    const z = /^#zoom=([0-9.]+),([0-9.]+),([0-9.]+)$/.exec(location.hash);
    if (z) crop = clampCrop({x: Number(z[1]), y: Number(z[2]), s: Number(z[3])});
    draw();
    // file:///.../index.html#selftest: zoom programmatically and check that every canvas
    // shows pixels (the end-to-end test reads data-selftest back from the DOM).
    if (location.hash === '#selftest') {
      let result = 'ok';
      try {
        crop = clampCrop({x: 0.25, y: 0.25, s: 0.5});
        draw();
        for (const v of views) {
          const cv = v.querySelector('canvas');
          if (cv.hidden || cv.width === 0) { result = 'canvas not shown'; break; }
          const px = cv.getContext('2d').getImageData(cv.width >> 1, cv.height >> 1, 1, 1).data;
          if (px[3] !== 255) { result = 'canvas empty'; break; }
        }
        crop = null;
        draw();
        if (views.some(v => !v.querySelector('canvas').hidden)) result = 'reset failed';
      } catch (err) {
        result = 'exception: ' + err.message;
      }
      document.body.dataset.selftest = result;
    }
  });
})();
)JS";

}  // namespace

std::string error_time_svg(const Comparison& c, const std::string& metric) {
  const bool v = metric != "flip";
  Plot p;
  p.title = v ? "mean |ΔV| against time" : "FLIP against time";
  p.x_label = "shadow time (ms)";
  p.y_label = v ? "mean |ΔV|" : "mean FLIP";
  p.log_x = p.log_y = true;
  if (c.has_ladder && !c.ladder.rungs.empty()) {
    PlotSeries ladder;
    ladder.name = fmt::format("reference, 1–{} spp", c.ladder.rungs.back().light_samples);
    for (const LadderRung& r : c.ladder.rungs) {
      ladder.x.push_back(r.shadow_ms);
      ladder.y.push_back(v ? r.v_mae : r.flip);
      ladder.labels.push_back(std::to_string(r.light_samples));
    }
    p.series.push_back(std::move(ladder));
  }
  for (const MethodRun& r : c.runs) {
    if (!r.ok) continue;
    PlotSeries s;
    s.name = r.method;
    s.x = {r.times.shadow_ms};
    s.y = {v ? r.v.mae : r.flip};
    s.line = false;
    p.series.push_back(std::move(s));
  }
  return plot_svg(p);
}

namespace {

// The sequence playable in the page: the ground truth's and every method's colour frames side
// by side, a slider and a play button at the animation's rate (the frames are PNG data URIs
// in one script object; the images show the first frame until the script swaps them).
void sequence_player(std::ostringstream& h, const Comparison& c) {
  const size_t frames = static_cast<size_t>(c.frames.end - c.frames.begin);
  std::vector<std::pair<std::string, const std::vector<Image>*>> rows;
  if (c.frames.truth_color.size() == frames) rows.emplace_back("ground truth", &c.frames.truth_color);
  for (const MethodFrames& m : c.frames.methods)
    if (m.ok && m.color.size() == frames) rows.emplace_back(m.method, &m.color);
  if (rows.empty() || frames == 0) return;
  h << "<div class=\"toolbar\"><button id=\"seq-play\" type=\"button\">play</button> <input id=\"seq-frame\" "
       "type=\"range\" min=\"0\" max=\""
    << frames - 1 << "\" value=\"0\"> <span id=\"seq-label\">frame " << c.frames.begin << "</span></div>\n<div class=\"row\">";
  std::string data = fmt::format("window.penumbraSequence = {{first: {}, fps: {}, frames: [", c.frames.begin,
                                 c.frames.fps);
  for (size_t i = 0; i < rows.size(); ++i) {
    const std::vector<Image>& images = *rows[i].second;
    h << "<figure><img class=\"seq\" data-seq=\"" << i << "\" alt=\"" << xml_escape(rows[i].first) << "\" src=\""
      << png_data_uri(images.front()) << "\"><figcaption>" << xml_escape(rows[i].first) << "</figcaption></figure>";
    data += i ? ",[" : "[";
    for (size_t t = 0; t < images.size(); ++t) data += (t ? ",\"" : "\"") + png_data_uri(images[t]) + "\"";
    data += "]";
  }
  h << "</div>\n<script>" << data << "]};\n" << R"JS((() => {
  const s = window.penumbraSequence;
  const slider = document.getElementById('seq-frame'), label = document.getElementById('seq-label');
  const play = document.getElementById('seq-play'), images = document.querySelectorAll('img.seq');
  let timer = null;
  const show = (i) => {
    slider.value = i;
    label.textContent = 'frame ' + (s.first + i);
    images.forEach((im) => { im.src = s.frames[+im.dataset.seq][i]; });
  };
  slider.addEventListener('input', () => show(+slider.value));
  play.addEventListener('click', () => {
    if (timer) { clearInterval(timer); timer = null; play.textContent = 'play'; return; }
    play.textContent = 'pause';
    timer = setInterval(() => show((+slider.value + 1) % s.frames[0].length), 1000 / s.fps);
  });
})();
)JS" << "</script>\n";
}

}  // namespace

std::string frames_svg(const Comparison& c, const std::string& what) {
  const bool error = what == "v_mae";
  Plot p;
  p.title = error ? "mean |ΔV| per frame" : "shadow time per frame";
  p.x_label = "frame";
  p.y_label = error ? "mean |ΔV|" : "shadow time (ms)";
  p.log_y = !error;  // methods' costs span orders of magnitude
  auto add = [&](const std::string& name, const std::vector<double>& y, bool line) {
    PlotSeries s;
    s.name = name;
    s.line = line;
    for (size_t i = 0; i < y.size(); ++i) {
      s.x.push_back(c.frames.begin + static_cast<double>(i));
      s.y.push_back(y[i]);
    }
    p.series.push_back(std::move(s));
  };
  for (const MethodFrames& m : c.frames.methods) {
    if (error) {
      add(m.method, m.v_mae, true);
    } else {
      // With reuse a line, from nothing markers: where they part is what reuse saves.
      add(m.method + " (reuse)", m.shadow_ms_reuse, true);
      add(m.method + " (fresh)", m.shadow_ms_fresh, false);
    }
  }
  return plot_svg(p);
}

float comparison_heatmap_scale(const Comparison& c, const ReportOptions& options) {
  if (options.heatmap_scale > 0) return options.heatmap_scale;
  // Each method's 99th percentile of |dV|; the scale is the lower median of these, so
  // that the better half of the methods shows its error structure and the worse half
  // saturates (one bad method would otherwise wash out every other map).
  std::vector<float> p99s;
  for (const MethodRun& r : c.runs) {
    if (!r.ok || r.visibility.empty() || !c.has_ground_truth) continue;
    std::vector<float> d;
    const auto& a = r.visibility.data();
    const auto& b = c.truth.visibility.data();
    for (size_t i = 0; i < a.size() && i < b.size(); ++i) {
      float e = std::abs(a[i] - b[i]);
      if (std::isfinite(e)) d.push_back(e);
    }
    if (d.empty()) continue;
    size_t k = static_cast<size_t>(0.99 * (d.size() - 1));
    std::nth_element(d.begin(), d.begin() + k, d.end());
    float p = d[k] > 0 ? d[k] : *std::max_element(d.begin(), d.end());
    if (p > 0) p99s.push_back(p);
  }
  if (p99s.empty()) return 1.0f;
  std::sort(p99s.begin(), p99s.end());
  return std::min(1.0f, nice_ceiling(p99s[(p99s.size() - 1) / 2]));
}

std::string comparison_html(const Comparison& c, const ReportOptions& options) {
  std::ostringstream h;
  const bool truth = c.has_ground_truth;
  const float scale = comparison_heatmap_scale(c, options);
  std::string scene_name = std::filesystem::path(c.scene).stem().string();

  h << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
    << "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
    << "<link rel=\"icon\" href=\"data:,\">\n"
    << "<title>penumbra compare: " << xml_escape(scene_name) << "</title>\n<style>" << kStyle << "</style>\n</head>\n"
    << "<body>\n";

  // --- header
  h << "<h1>" << xml_escape(scene_name) << ": every method against the ground truth</h1>\n";
  if (!c.description.empty()) h << "<p class=\"meta\">" << xml_escape(c.description) << "</p>\n";
  h << "<p class=\"meta\">Scene <code>" << xml_escape(c.scene) << "</code>: " << c.width << "×" << c.height
    << (c.pixel_samples > 1 ? fmt::format(", {} samples per pixel", c.pixel_samples) : std::string()) << ", "
    << format_grouped(c.triangles) << " triangles, " << c.lights << (c.lights == 1 ? " light" : " lights")
    << ". Methods that sample the light use <b>" << c.light_samples << "</b> light samples; seed " << c.seed
    << ".</p>\n";
  if (!c.params.empty()) {
    std::string p;
    for (const auto& kv : c.params) {
      if (!p.empty()) p += ' ';
      p += "<code>";
      p += xml_escape(kv);
      p += "</code>";
    }
    h << "<p class=\"meta\">Parameters: " << p << "</p>\n";
  }
  if (truth) {
    h << "<p class=\"meta\">Ground truth: <b>reference</b> (ray tracing the real geometry) at <b>"
      << c.truth.light_samples << "</b> light samples (with a seed of its own)"
      << (c.truth.from_cache ? ", loaded from the reference cache" : "") << "; its render takes "
      << format_significant(c.truth.total_ms / 1000.0, 3) << " s (time " << time_basis_text(c.truth.time_basis)
      << ").</p>\n";
  } else {
    h << "<p class=\"meta\">No ground truth (timings only).</p>\n";
  }
  if (!c.speedup_basis.empty())
    h << "<p class=\"meta\">Speed-up = shadow time of the "
      << (c.speedup_basis == "reference"
              ? std::string("<b>reference</b> method at the same light samples, in this run")
              : std::string("<b>ground-truth</b> render (the reference at ") + std::to_string(c.truth.light_samples) +
                    " light samples)")
      << " (" << format_significant(c.speedup_basis_ms, 3) << " ms) / the method's shadow time. <span id=\"speedup-basis\">"
      << "Reference time: " << time_basis_text(c.speedup_time_basis)
      << (c.speedup_time_basis == TimeBasis::kCachedElsewhere ? ", so no speed-ups are given" : "")
      << ".</span></p>\n";
  h << "<p class=\"meta\">Machine: " << xml_escape(c.machine.value("cpu", "?")) << ", "
    << c.machine.value("threads", 0) << " threads, " << xml_escape(c.machine.value("compiler", "")) << ", "
    << xml_escape(c.machine.value("build", "")) << ". Started " << xml_escape(c.started) << ", took "
    << format_significant(c.wall_ms / 1000.0, 3) << " s.</p>\n";
  if (!c.command.empty()) h << "<p class=\"meta\">Command: <code>" << xml_escape(c.command) << "</code></p>\n";

  // --- table, sorted by mean |dV| (or time without a ground truth); failures last
  std::vector<const MethodRun*> order;
  for (const MethodRun& r : c.runs) order.push_back(&r);
  const std::string sort_key = truth ? "v_mae" : "shadow_ms";
  std::stable_sort(order.begin(), order.end(), [&](const MethodRun* a, const MethodRun* b) {
    if (a->ok != b->ok) return a->ok;
    if (!a->ok) return false;
    double va = run_value(*a, sort_key), vb = run_value(*b, sort_key);
    if (std::isnan(va) != std::isnan(vb)) return !std::isnan(va);
    return va < vb;
  });
  std::vector<const Column*> cols;
  for (const Column& col : columns())
    if ((!col.needs_truth || truth) && (!col.needs_ladder || c.has_ladder) && (!col.needs_frames || c.has_frames))
      cols.push_back(&col);
  // The best value of each column among the methods that ran.
  std::map<std::string, double> best;
  for (const Column* col : cols) {
    if (col->better == Column::Better::kNone) continue;
    double b = std::numeric_limits<double>::quiet_NaN();
    for (const MethodRun& r : c.runs) {
      if (!r.ok || !rankable(r, col->key)) continue;
      double v = run_value(r, col->key, frames_of(c, r));
      if (std::isnan(v)) continue;
      if (col->better == Column::Better::kLowerAbs) v = std::abs(v);
      if (std::isnan(b) || (col->better == Column::Better::kHigher ? v > b : v < b)) b = v;
    }
    best[col->key] = b;
  }

  h << "<h2>Results</h2>\n";
  h << "<p class=\"meta\">ΔV = V<sub>method</sub> − V<sub>ground truth</sub> per pixel (V: the fraction of the light "
       "a pixel sees). Best value of each column in green; click a header to sort.</p>\n";
  h << "<div style=\"overflow-x: auto\"><table id=\"results\">\n<thead><tr><th class=\"name\" title=\"shadow method\">method</th>";
  for (const Column* col : cols) h << "<th title=\"" << xml_escape(col->tip) << "\">" << xml_escape(col->header) << "</th>";
  h << "<th class=\"name\" title=\"time per phase (ms) of the median run\">phases (ms)</th></tr></thead>\n<tbody>\n";
  for (const MethodRun* r : order) {
    if (!r->ok) {
      h << "<tr class=\"failed\" data-method=\"" << xml_escape(r->method) << "\"><td class=\"name\">"
        << xml_escape(r->method) << "</td><td class=\"error\" colspan=\"" << cols.size() + 1 << "\">failed: "
        << xml_escape(r->error) << "</td></tr>\n";
      continue;
    }
    h << "<tr data-method=\"" << xml_escape(r->method) << "\"><td class=\"name\">" << xml_escape(r->method) << "</td>";
    for (const Column* col : cols) {
      const MethodFrames* f = frames_of(c, *r);
      double v = run_value(*r, col->key, f);
      bool is_best = false;
      if (col->better != Column::Better::kNone && !std::isnan(v) && !std::isnan(best[col->key]) &&
          rankable(*r, col->key)) {
        double cmp = col->better == Column::Better::kLowerAbs ? std::abs(v) : v;
        is_best = cmp == best[col->key];
      }
      h << "<td data-key=\"" << col->key << "\" data-value=\"" << xml_escape(run_json_value(*r, col->key, f).dump())
        << "\"" << (is_best ? " class=\"best\"" : "") << ">" << xml_escape(display(*r, col->key, f)) << "</td>";
    }
    std::string phases;
    for (const auto& [n, t] : r->stats.phases_ms)
      phases += (phases.empty() ? "" : " · ") + xml_escape(n) + " " + format_significant(t, 3);
    h << "<td class=\"phases\">" << phases << "</td></tr>\n";
  }
  h << "</tbody>\n</table></div>\n";

  // --- error by object (compare --objects): where each method's error lives
  if (truth && !c.object_groups.empty()) {
    h << "<h2>Error by object</h2>\n<p class=\"meta\">Mean |ΔV| and mean signed ΔV over the pixels whose first "
         "camera ray hits an object a pattern names (<code>--objects</code>; the whole image's in the table above, "
         "background pixels included); the same rows as above.</p>\n<div style=\"overflow-x: auto\"><table "
         "id=\"objects\">\n<thead><tr><th class=\"name\">method</th>";
    for (const ObjectGroup& g : c.object_groups)
      h << "<th colspan=\"2\" title=\"" << g.objects << " objects, " << g.pixels << " pixels\"><code>"
        << xml_escape(g.pattern) << "</code> (" << g.pixels << " px)</th>";
    h << "</tr>\n<tr><th></th>";
    for (size_t g = 0; g < c.object_groups.size(); ++g) h << "<th>mean |ΔV|</th><th>signed</th>";
    h << "</tr></thead>\n<tbody>\n";
    for (const MethodRun* r : order) {
      if (!r->ok) continue;
      h << "<tr data-method=\"" << xml_escape(r->method) << "\"><td class=\"name\">" << xml_escape(r->method) << "</td>";
      for (size_t g = 0; g < c.object_groups.size(); ++g) {
        const bool has = g < r->v_objects.size() && !std::isnan(r->v_objects[g].mae);
        h << "<td>" << (has ? format_significant(r->v_objects[g].mae, 3) : "-") << "</td><td>"
          << (has ? format_significant(r->v_objects[g].mean_signed, 2) : "-") << "</td>";
      }
      h << "</tr>\n";
    }
    h << "</tbody>\n</table></div>\n";
  }

  // --- equal quality: the ladder and the error-time charts
  if (c.has_ladder && !c.ladder.rungs.empty()) {
    const LadderRung& last = c.ladder.rungs.back();
    h << "<h2>Equal quality</h2>\n<p class=\"meta\">The <b>reference ladder</b>: the reference at 1, 2, 4, …, "
      << last.light_samples << " light samples (with a seed of its own; rendered as far as the best method needed, at "
      << "most the ground truth's " << c.ladder.max_samples << "), measured against the ground truth like every "
      << "method. A method's <i>equal-quality</i> point is where the ladder's error equals the method's: the first "
      << "rung at least as good as the method and the one before it bracket it, and the light samples and the "
      << "reference's shadow time are interpolated between them, straight lines in log-log. ≥ N: the method is "
      << "better than every rung; ≤ 1: the reference at one sample is already as good. The speed-up at equal "
      << "quality is that reference time / the method's shadow time. <span id=\"ladder-basis\">Reference times: "
      << ladder_time_basis_text(c.ladder) << ".</span>"
      << "</p>\n<table id=\"ladder\"><thead><tr><th>light samples</th><th>mean |ΔV|</th><th>FLIP</th>"
      << "<th>shadow ms</th><th>time</th></tr></thead>\n<tbody>\n";
    for (const LadderRung& r : c.ladder.rungs)
      h << "<tr><td>" << r.light_samples << "</td><td>" << format_significant(r.v_mae, 3) << "</td><td>"
        << format_significant(r.flip, 3) << "</td><td>" << format_significant(r.shadow_ms, 3) << "</td><td>"
        << time_basis_text(r.time_basis) << "</td></tr>\n";
    h << "</tbody></table>\n";
  }
  // Inline SVG (without its XML declaration): the page stays one file.
  auto inline_svg = [](std::string svg) {
    if (svg.rfind("<?xml", 0) == 0) svg.erase(0, svg.find('\n') + 1);
    // HTML knows <svg> without its namespace attribute (and the page names no URL).
    const std::string ns = " xmlns=\"http://www.w3.org/2000/svg\"";
    if (size_t p = svg.find(ns); p != std::string::npos) svg.erase(p, ns.size());
    return svg;
  };
  if (truth) {
    h << "<h2>Error against time</h2>\n<p class=\"meta\">Every method a point (its shadow time and error against "
         "the ground truth), the reference ladder a curve labelled with its light samples: for a time budget, the "
         "lowest point left of it is the best method. Also <code>error-time.svg</code> and "
         "<code>flip-time.svg</code>.</p>\n<div class=\"row\">"
      << inline_svg(error_time_svg(c, "v_mae")) << inline_svg(error_time_svg(c, "flip")) << "</div>\n";
  }
  if (c.has_frames) {
    // The sequence (issue 18): error and cost frame by frame.
    h << "<h2>Sequence</h2>\n<p class=\"meta\">Frames " << c.frames.begin << " to " << c.frames.end - 1
      << " of the animation, each against its own ground truth (the table and the images above are frame "
      << c.frames.begin << "'s). <i>Temporal instability</i>: the mean over frames t &gt; " << c.frames.begin
      << " and pixels of |(V<sub>t</sub> − V<sub>t−1</sub>) − (G<sub>t</sub> − G<sub>t−1</sub>)|, flicker the "
         "ground truth does not have. Shadow time per frame with reuse (one renderer over the sequence, keeping "
         "what stays valid when only the camera or the lights change) and from nothing. Also "
         "<code>frames-error.svg</code> and <code>frames-time.svg</code>. Below them the sequence itself: the "
         "ground truth and every method, frame by frame (play, or drag the slider).</p>\n<div class=\"row\">"
      << inline_svg(frames_svg(c, "v_mae")) << inline_svg(frames_svg(c, "shadow_ms")) << "</div>\n";
    sequence_player(h, c);
  }

  // --- images
  h << "<h2>Images</h2>\n<div class=\"toolbar\"><span id=\"zoom-status\"></span>"
    << "<button id=\"zoom-reset\" type=\"button\">reset zoom</button>"
    << " <label>size <input id=\"thumb\" type=\"range\" min=\"64\" max=\"1024\" step=\"32\" value=\"256\"></label>";
  if (truth) {
    h << "<br><span class=\"legend\">signed ΔV <span>" << format_significant(-scale, 3) << "</span><span class=\"bar\" "
      << "style=\"background: " << css_gradient(ColorMap::kDiverging) << "\"></span><span>+"
      << format_significant(scale, 3) << "</span> (blue: darker than the ground truth, red: brighter)</span>"
      << "<span class=\"legend\">|ΔV| <span>0</span><span class=\"bar\" style=\"background: "
      << css_gradient(ColorMap::kMagma) << "\"></span><span>" << format_significant(scale, 3)
      << "</span></span>";
  }
  h << "</div>\n<div class=\"cards\">\n";
  auto figure = [&](const Image& img, bool linear, const std::string& caption, const std::string& alt) {
    h << "<figure><div class=\"view\"><img alt=\"" << xml_escape(alt) << "\" src=\"" << png_data_uri(img, linear)
      << "\"><canvas hidden></canvas><div class=\"band\"></div></div><figcaption>" << caption
      << "</figcaption></figure>";
  };
  if (truth && !c.truth.color.empty()) {
    h << "<div class=\"card\" data-method=\"ground-truth\"><h3>ground truth</h3><div class=\"sub\">reference, "
      << c.truth.light_samples << " light samples</div><div class=\"row\">";
    figure(c.truth.color, false, "colour", "ground truth colour");
    figure(c.truth.visibility, true, "V (white: fully lit)", "ground truth V");
    h << "</div></div>\n";
  }
  for (const MethodRun* r : order) {
    if (!r->ok) {
      h << "<div class=\"card failed\" data-method=\"" << xml_escape(r->method) << "\"><h3>" << xml_escape(r->method)
        << "</h3><div class=\"error\">failed: " << xml_escape(r->error) << "</div></div>\n";
      continue;
    }
    std::string sub = fmt::format("{} ms", format_significant(r->times.shadow_ms, 3));
    if (!std::isnan(r->speedup)) sub += fmt::format(" ({}× the {})", format_significant(r->speedup, 3),
                                                    c.speedup_basis == "reference" ? "reference's speed" : "ground truth's speed");
    if (truth) sub = fmt::format("mean |ΔV| {} · RMSE {} · FLIP {} · ", format_significant(r->v.mae, 3),
                                 format_significant(r->v.rmse, 3), format_significant(r->flip, 3)) + sub;
    if (r->light_samples > 0) sub += fmt::format(" · {} light samples", r->light_samples);
    h << "<div class=\"card\" data-method=\"" << xml_escape(r->method) << "\"><h3>" << xml_escape(r->method)
      << "</h3><div class=\"sub\">" << xml_escape(sub) << "</div><div class=\"row\">";
    if (r->color.empty()) {
      h << "<p>(images not kept)</p>";
    } else {
      figure(r->color, false, "colour", r->method + " colour");
      if (truth) {
        Image d = difference_map(r->visibility, c.truth.visibility);
        figure(signed_heatmap(d, scale).image, false, "signed ΔV", r->method + " signed V error");
        for (float& x : d.data()) x = std::abs(x);
        figure(absolute_heatmap(d, scale).image, false, "|ΔV|", r->method + " absolute V error");
      }
    }
    h << "</div></div>\n";
  }
  h << "</div>\n<script>" << kScript << "</script>\n</body>\n</html>\n";
  return h.str();
}

}  // namespace penumbra
