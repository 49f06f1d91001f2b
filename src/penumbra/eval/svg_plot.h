// A small SVG line-plot writer for sweeps (error and time against a parameter): axes with
// "nice" ticks (linear or log10), one coloured polyline with markers per series, a legend.
// The output is a standalone SVG 1.1 document with no scripts and no external resources.
#pragma once

#include <string>
#include <vector>

namespace penumbra {

struct PlotSeries {
  std::string name;
  std::vector<double> x, y;  // equal lengths; NaN y values leave a gap in the line
  std::vector<std::string> labels;  // optional: a small text beside each point (empty: none)
  bool line = true;                 // false: markers only
};

struct Plot {
  std::string title, x_label, y_label;
  bool log_x = false, log_y = false;  // log10 axes (non-positive values are dropped)
  bool y_from_zero = true;            // linear y: start the axis at 0 when all values are >= 0
  // Non-empty: a categorical x axis; series x values are indices into it.
  std::vector<std::string> x_categories;
  std::vector<PlotSeries> series;
  int width = 720, height = 440;
};

std::string plot_svg(const Plot& plot);

// Tick positions for [lo, hi]: about `target` "nice" values (1, 2, 5 x 10^k steps).
std::vector<double> nice_ticks(double lo, double hi, int target = 6);
// Powers of ten (and 2 and 5 times them when the range spans few decades) in [lo, hi].
std::vector<double> log_ticks(double lo, double hi);

}  // namespace penumbra
