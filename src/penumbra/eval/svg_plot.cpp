#include "penumbra/eval/svg_plot.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include <fmt/format.h>

#include "penumbra/eval/report_util.h"

namespace penumbra {

std::vector<double> nice_ticks(double lo, double hi, int target) {
  std::vector<double> ticks;
  if (!(hi > lo) || !std::isfinite(lo) || !std::isfinite(hi)) return {lo};
  double raw = (hi - lo) / std::max(1, target);
  double mag = std::pow(10.0, std::floor(std::log10(raw)));
  double step = mag;
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (m * mag >= raw) {
      step = m * mag;
      break;
    }
  double first = std::ceil(lo / step - 1e-9) * step;
  for (double t = first; t <= hi + step * 1e-9; t += step) ticks.push_back(std::abs(t) < step * 1e-9 ? 0.0 : t);
  return ticks;
}

std::vector<double> log_ticks(double lo, double hi) {
  std::vector<double> ticks;
  if (!(lo > 0) || !(hi >= lo)) return ticks;
  int e0 = static_cast<int>(std::floor(std::log10(lo))), e1 = static_cast<int>(std::ceil(std::log10(hi)));
  const bool few = e1 - e0 <= 2;
  for (int e = e0; e <= e1; ++e)
    for (double m : few ? std::vector<double>{1, 2, 5} : std::vector<double>{1}) {
      double t = m * std::pow(10.0, e);
      if (t >= lo * (1 - 1e-9) && t <= hi * (1 + 1e-9)) ticks.push_back(t);
    }
  return ticks;
}

namespace {

// Okabe & Ito's colour-blind-safe palette, then a few more distinct colours.
const char* kColors[] = {"#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9",
                         "#000000", "#F0E442", "#7f3c8d", "#11a579", "#e73f74", "#3969ac"};
const char* kMarkers[] = {"circle", "square", "diamond", "triangle"};

std::string tick_label(double v) {
  if (std::abs(v) < 1e-12) return "0";
  return fmt::format("{:.6g}", v);
}

}  // namespace

std::string plot_svg(const Plot& p) {
  const double W = p.width, H = p.height;
  const double left = 78, right = 190, top = p.title.empty() ? 20 : 44, bottom = 58;
  const double pw = W - left - right, ph = H - top - bottom;
  const bool categorical = !p.x_categories.empty();

  auto usable = [](double v, bool log) { return std::isfinite(v) && (!log || v > 0); };
  double xmin = std::numeric_limits<double>::infinity(), xmax = -xmin, ymin = xmin, ymax = -xmin;
  for (const PlotSeries& s : p.series)
    for (size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
      if (!usable(s.x[i], p.log_x && !categorical) || !usable(s.y[i], p.log_y)) continue;
      xmin = std::min(xmin, s.x[i]);
      xmax = std::max(xmax, s.x[i]);
      ymin = std::min(ymin, s.y[i]);
      ymax = std::max(ymax, s.y[i]);
    }
  if (categorical) {
    xmin = -0.5;
    xmax = static_cast<double>(p.x_categories.size()) - 0.5;
  }
  const bool empty = !(xmax >= xmin) || !(ymax >= ymin);
  if (empty) xmin = 0, xmax = 1, ymin = 0, ymax = 1;
  // Axis ranges with a little room.
  std::vector<double> xt, yt;
  auto pad_range = [](double& lo, double& hi, bool log) {
    if (log) {
      if (hi <= lo) lo /= 2, hi *= 2;
      double f = std::pow(hi / lo, 0.04);
      lo /= f;
      hi *= f;
    } else {
      if (hi <= lo) {
        double d = lo == 0 ? 1 : std::abs(lo) * 0.1;
        lo -= d;
        hi += d;
      }
      double d = (hi - lo) * 0.04;
      lo -= d;
      hi += d;
    }
  };
  if (!categorical) {
    pad_range(xmin, xmax, p.log_x);
    xt = p.log_x ? log_ticks(xmin, xmax) : nice_ticks(xmin, xmax);
  }
  if (!p.log_y && p.y_from_zero && ymin >= 0) {
    ymin = 0;
    if (ymax <= 0) ymax = 1;
    ymax += (ymax - ymin) * 0.05;
  } else {
    pad_range(ymin, ymax, p.log_y);
  }
  yt = p.log_y ? log_ticks(ymin, ymax) : nice_ticks(ymin, ymax);

  auto tx = [&](double x) {
    double t = p.log_x && !categorical ? (std::log10(x) - std::log10(xmin)) / (std::log10(xmax) - std::log10(xmin))
                                       : (x - xmin) / (xmax - xmin);
    return left + t * pw;
  };
  auto ty = [&](double y) {
    double t = p.log_y ? (std::log10(y) - std::log10(ymin)) / (std::log10(ymax) - std::log10(ymin))
                       : (y - ymin) / (ymax - ymin);
    return top + (1 - t) * ph;
  };

  std::ostringstream s;
  s << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
    << fmt::format("<svg xmlns=\"http://www.w3.org/2000/svg\" version=\"1.1\" width=\"{}\" height=\"{}\" "
                   "viewBox=\"0 0 {} {}\" font-family=\"Helvetica, Arial, sans-serif\" font-size=\"12\">\n",
                   p.width, p.height, p.width, p.height)
    << fmt::format("<rect x=\"0\" y=\"0\" width=\"{}\" height=\"{}\" fill=\"#ffffff\"/>\n", p.width, p.height);
  if (!p.title.empty())
    s << fmt::format("<text x=\"{:.1f}\" y=\"26\" font-size=\"15\" font-weight=\"bold\" text-anchor=\"middle\">{}</text>\n",
                     left + pw / 2, xml_escape(p.title));
  // Grid and ticks.
  s << "<g stroke=\"#e4e4e4\" stroke-width=\"1\">\n";
  for (double y : yt) s << fmt::format("<line x1=\"{:.1f}\" y1=\"{:.1f}\" x2=\"{:.1f}\" y2=\"{:.1f}\"/>\n", left, ty(y), left + pw, ty(y));
  if (categorical) {
    for (size_t i = 0; i < p.x_categories.size(); ++i)
      s << fmt::format("<line x1=\"{:.1f}\" y1=\"{:.1f}\" x2=\"{:.1f}\" y2=\"{:.1f}\"/>\n", tx(i), top, tx(i), top + ph);
  } else {
    for (double x : xt) s << fmt::format("<line x1=\"{:.1f}\" y1=\"{:.1f}\" x2=\"{:.1f}\" y2=\"{:.1f}\"/>\n", tx(x), top, tx(x), top + ph);
  }
  s << "</g>\n";
  s << fmt::format("<rect x=\"{:.1f}\" y=\"{:.1f}\" width=\"{:.1f}\" height=\"{:.1f}\" fill=\"none\" stroke=\"#333333\"/>\n",
                   left, top, pw, ph);
  s << "<g fill=\"#333333\">\n";
  for (double y : yt)
    s << fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" text-anchor=\"end\">{}</text>\n", left - 6, ty(y) + 4,
                     xml_escape(tick_label(y)));
  if (categorical) {
    for (size_t i = 0; i < p.x_categories.size(); ++i)
      s << fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" text-anchor=\"middle\">{}</text>\n", tx(i), top + ph + 16,
                       xml_escape(p.x_categories[i]));
  } else {
    for (double x : xt)
      s << fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" text-anchor=\"middle\">{}</text>\n", tx(x), top + ph + 16,
                       xml_escape(tick_label(x)));
  }
  s << fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" text-anchor=\"middle\" font-size=\"13\">{}</text>\n", left + pw / 2,
                   H - 14, xml_escape(p.x_label + (p.log_x && !categorical ? " (log)" : "")));
  s << fmt::format("<text x=\"16\" y=\"{:.1f}\" text-anchor=\"middle\" font-size=\"13\" transform=\"rotate(-90 16 {:.1f})\">{}</text>\n",
                   top + ph / 2, top + ph / 2, xml_escape(p.y_label + (p.log_y ? " (log)" : "")));
  s << "</g>\n";
  if (empty)
    s << fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" text-anchor=\"middle\" fill=\"#999999\">no data</text>\n",
                     left + pw / 2, top + ph / 2);

  // Series.
  for (size_t k = 0; k < p.series.size(); ++k) {
    const PlotSeries& ser = p.series[k];
    const char* color = kColors[k % std::size(kColors)];
    const char* marker = kMarkers[(k / std::size(kColors)) % std::size(kMarkers)];
    s << fmt::format("<g class=\"series\" data-name=\"{}\" stroke=\"{}\" fill=\"{}\">\n", xml_escape(ser.name), color, color);
    std::vector<std::pair<double, double>> pts;
    auto flush = [&] {
      if (pts.size() >= 2) {
        s << "<polyline fill=\"none\" stroke-width=\"2\" points=\"";
        for (size_t i = 0; i < pts.size(); ++i) s << (i ? " " : "") << fmt::format("{:.1f},{:.1f}", pts[i].first, pts[i].second);
        s << "\"/>\n";
      }
      pts.clear();
    };
    std::vector<std::pair<double, double>> marks;
    std::vector<std::string> mark_labels;
    for (size_t i = 0; i < ser.x.size() && i < ser.y.size(); ++i) {
      if (!usable(ser.x[i], p.log_x && !categorical) || !usable(ser.y[i], p.log_y)) {
        flush();
        continue;
      }
      pts.emplace_back(tx(ser.x[i]), ty(ser.y[i]));
      marks.push_back(pts.back());
      mark_labels.push_back(i < ser.labels.size() ? ser.labels[i] : std::string());
      if (!ser.line) pts.clear();
    }
    flush();
    for (auto [x, y] : marks) {
      std::string m = marker;
      if (m == "circle") s << fmt::format("<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"3.5\"/>\n", x, y);
      else if (m == "square") s << fmt::format("<rect x=\"{:.1f}\" y=\"{:.1f}\" width=\"7\" height=\"7\"/>\n", x - 3.5, y - 3.5);
      else if (m == "diamond") s << fmt::format("<polygon points=\"{:.1f},{:.1f} {:.1f},{:.1f} {:.1f},{:.1f} {:.1f},{:.1f}\"/>\n", x, y - 4.5, x + 4.5, y, x, y + 4.5, x - 4.5, y);
      else s << fmt::format("<polygon points=\"{:.1f},{:.1f} {:.1f},{:.1f} {:.1f},{:.1f}\"/>\n", x, y - 4.5, x + 4.5, y + 4, x - 4.5, y + 4);
    }
    for (size_t i = 0; i < marks.size(); ++i)
      if (!mark_labels[i].empty())
        s << fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" font-size=\"10\" stroke=\"none\">{}</text>\n",
                         marks[i].first + 5, marks[i].second - 5, xml_escape(mark_labels[i]));
    s << "</g>\n";
  }
  // Legend.
  double ly = top + 8;
  for (size_t k = 0; k < p.series.size(); ++k) {
    const char* color = kColors[k % std::size(kColors)];
    double lx = left + pw + 16;
    s << fmt::format("<line x1=\"{:.1f}\" y1=\"{:.1f}\" x2=\"{:.1f}\" y2=\"{:.1f}\" stroke=\"{}\" stroke-width=\"2\"/>\n", lx,
                     ly, lx + 22, ly, color);
    s << fmt::format("<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"3.5\" fill=\"{}\"/>\n", lx + 11, ly, color);
    s << fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" fill=\"#222222\">{}</text>\n", lx + 28, ly + 4, xml_escape(p.series[k].name));
    ly += 20;
  }
  s << "</svg>\n";
  return s.str();
}

}  // namespace penumbra
