#include "penumbra/eval/svg_plot.h"

#include <gtest/gtest.h>

#include <cmath>
#include <regex>

#include "penumbra/testing/xml_check.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

int count(const std::string& s, const std::string& what) {
  int n = 0;
  for (size_t p = s.find(what); p != std::string::npos; p = s.find(what, p + 1)) ++n;
  return n;
}

TEST(SvgPlot, NiceTicks) {
  std::vector<double> a = nice_ticks(0, 1, 5);
  ASSERT_EQ(a.size(), 6u);
  for (size_t i = 0; i < a.size(); ++i) EXPECT_NEAR(a[i], 0.2 * i, 1e-12);
  std::vector<double> t = nice_ticks(3, 97, 6);
  ASSERT_FALSE(t.empty());
  EXPECT_DOUBLE_EQ(t.front(), 20);
  EXPECT_DOUBLE_EQ(t[1] - t[0], 20);
  EXPECT_LE(t.back(), 97);
  EXPECT_EQ(log_ticks(1, 1000), (std::vector<double>{1, 10, 100, 1000}));
  // Few decades: 1, 2 and 5 times the powers of ten.
  EXPECT_EQ(log_ticks(3, 40), (std::vector<double>{5, 10, 20}));
}

TEST(SvgPlot, WellFormedWithOnePolylinePerSeries) {
  Plot p;
  p.title = "error vs <light size> & more";
  p.x_label = "light.size";
  p.y_label = "mean |dV|";
  p.series = {{"reference", {0.5, 1, 2, 4}, {0.01, 0.012, 0.011, 0.013}},
              {"hard & co", {0.5, 1, 2, 4}, {0.05, 0.1, 0.2, 0.4}}};
  std::string svg = plot_svg(p);
  std::string problem;
  EXPECT_TRUE(testing::xml_well_formed(svg, &problem)) << problem;
  EXPECT_EQ(count(svg, "<polyline"), 2);
  EXPECT_NE(svg.find("hard &amp; co"), std::string::npos);
  EXPECT_NE(svg.find("&lt;light size&gt;"), std::string::npos);
  EXPECT_EQ(svg.find("NaN"), std::string::npos);
  EXPECT_EQ(svg.find("nan"), std::string::npos);
}

TEST(SvgPlot, NanLeavesAGapAndLogAxesDropNonPositive) {
  Plot p;
  p.log_x = p.log_y = true;
  p.series = {{"a", {1, 2, 4, 8, 16}, {1, 2, NAN, 8, 16}}, {"b", {1, 2, 4, 8, 16}, {0, 5, 6, 7, 8}}};
  std::string svg = plot_svg(p);
  std::string problem;
  EXPECT_TRUE(testing::xml_well_formed(svg, &problem)) << problem;
  // a: two segments of two points; b: the 0 is dropped, one segment of four.
  EXPECT_EQ(count(svg, "<polyline"), 3);
  EXPECT_EQ(svg.find("nan"), std::string::npos);
  EXPECT_EQ(svg.find("inf"), std::string::npos);
}

TEST(SvgPlot, CategoricalAndEmpty) {
  Plot p;
  p.x_categories = {"128x96", "256x192"};
  p.series = {{"m", {0, 1}, {3, 4}}};
  std::string svg = plot_svg(p);
  std::string problem;
  EXPECT_TRUE(testing::xml_well_formed(svg, &problem)) << problem;
  EXPECT_NE(svg.find(">128x96<"), std::string::npos);
  Plot empty;
  std::string e = plot_svg(empty);
  EXPECT_TRUE(testing::xml_well_formed(e, &problem)) << problem;
  EXPECT_NE(e.find("no data"), std::string::npos);
}

TEST(XmlCheck, CatchesBrokenDocuments) {
  std::string problem;
  EXPECT_TRUE(testing::xml_well_formed("<?xml version=\"1.0\"?>\n<a x=\"1\"><b/>t &amp; u</a>", &problem)) << problem;
  EXPECT_FALSE(testing::xml_well_formed("<a><b></a>", &problem));
  EXPECT_FALSE(testing::xml_well_formed("<a x=1></a>", &problem));
  EXPECT_FALSE(testing::xml_well_formed("<a>&</a>", &problem));
  EXPECT_FALSE(testing::xml_well_formed("<a></a><b></b>", &problem));
  EXPECT_FALSE(testing::xml_well_formed("<a>", &problem));
}

TEST(SvgPlot, PointLabelsAndMarkersOnlySeries) {
  Plot p;
  p.log_x = p.log_y = true;
  PlotSeries curve{"ladder", {1, 2, 4}, {0.1, 0.07, 0.05}};
  curve.labels = {"1", "2", "4 & more"};
  PlotSeries point{"method", {3}, {0.06}};
  point.line = false;
  PlotSeries scatter{"scatter", {1, 2}, {0.2, 0.3}};
  scatter.line = false;
  p.series = {curve, point, scatter};
  std::string svg = plot_svg(p), problem;
  EXPECT_TRUE(testing::xml_well_formed(svg, &problem)) << problem;
  EXPECT_EQ(count(svg, "<polyline"), 1);  // the curve only
  EXPECT_NE(svg.find(">4 &amp; more</text>"), std::string::npos);
  EXPECT_NE(svg.find(">2</text>"), std::string::npos);
  EXPECT_EQ(count(svg, "<circle"), 3 + 1 + 2 + 3);  // markers, then one per legend entry
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
