/// The bench's native plots: the data→pixel mapping, ticks, and that a drawn curve or bar lands on
/// the pixels the mapping names (and nowhere else).
#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/core.hpp>

#include "core/error.hpp"
#include "services/bench/plot.hpp"

namespace planecell::services::bench {
namespace {

/// True when `pixel` is within `tolerance` of `colour` in every channel.
bool near_colour(const cv::Vec3b& pixel, const cv::Scalar& colour, int tolerance = 40) {
  for (int c = 0; c < 3; ++c)
    if (std::abs(pixel[c] - static_cast<int>(colour[c])) > tolerance) return false;
  return true;
}

Axis linear(double lo, double hi) {
  Axis a;
  a.min = lo;
  a.max = hi;
  return a;
}

TEST(BenchPlot, AreaMapsTheRangeOntoItsEdgesWithYUp) {
  const PlotArea area(cv::Rect(100, 50, 401, 201), linear(0, 4), linear(-1, 1));
  EXPECT_EQ(area.to_point(0, -1), cv::Point(100, 250));  // bottom-left
  EXPECT_EQ(area.to_point(4, 1), cv::Point(500, 50));    // top-right
  EXPECT_EQ(area.to_point(1, 0), cv::Point(200, 150));   // a quarter across, half up
  const cv::Point2d p = area.to_pixel(3, 0.5);
  EXPECT_DOUBLE_EQ(p.x, 100 + 0.75 * 400);
  EXPECT_DOUBLE_EQ(p.y, 250 - 0.75 * 200);
}

TEST(BenchPlot, LogAxisPutsDecadesAtEqualSteps) {
  Axis y = linear(1, 1000);
  y.log10 = true;
  const PlotArea area(cv::Rect(0, 0, 101, 301), linear(0, 1), y);
  EXPECT_NEAR(area.to_pixel(0, 1).y, 300, 1e-9);
  EXPECT_NEAR(area.to_pixel(0, 10).y, 200, 1e-9);
  EXPECT_NEAR(area.to_pixel(0, 100).y, 100, 1e-9);
  EXPECT_NEAR(area.to_pixel(0, 1000).y, 0, 1e-9);
}

TEST(BenchPlot, RejectsEmptyRangesAndNonPositiveLogMinimum) {
  EXPECT_THROW(PlotArea(cv::Rect(0, 0, 100, 100), linear(1, 1), linear(0, 1)), ConfigError);
  Axis log_axis = linear(0, 10);
  log_axis.log10 = true;
  EXPECT_THROW(PlotArea(cv::Rect(0, 0, 100, 100), linear(0, 1), log_axis), ConfigError);
  EXPECT_THROW(PlotArea(cv::Rect(0, 0, 1, 100), linear(0, 1), linear(0, 1)), ConfigError);
}

TEST(BenchPlot, NiceTicksStepBy125TimesAPowerOfTen) {
  const auto unit = nice_ticks(linear(0, 1), 5);
  ASSERT_EQ(unit.size(), 6u);
  for (std::size_t i = 0; i < unit.size(); ++i) EXPECT_NEAR(unit[i], 0.2 * i, 1e-12);
  const auto pct = nice_ticks(linear(0, 100), 6);  // raw step 16.7 → 20
  ASSERT_EQ(pct.size(), 6u);
  EXPECT_DOUBLE_EQ(pct[1], 20.0);
  EXPECT_DOUBLE_EQ(pct.back(), 100.0);
  const auto odd = nice_ticks(linear(0.3, 2.7), 6);  // raw step 0.4 → 0.5, ticks inside the range
  ASSERT_EQ(odd.size(), 5u);
  EXPECT_DOUBLE_EQ(odd.front(), 0.5);
  EXPECT_DOUBLE_EQ(odd.back(), 2.5);
  Axis bytes = linear(1e3, 1e7);
  bytes.log10 = true;
  const auto decades = nice_ticks(bytes);
  ASSERT_EQ(decades.size(), 5u);
  EXPECT_DOUBLE_EQ(decades[2], 1e5);
  EXPECT_EQ(tick_label(linear(0, 1), 0.4, unit), "0.4");
  EXPECT_EQ(tick_label(linear(0, 100), 60, pct), "60");
}

TEST(BenchPlot, ACurveIsDrawnWhereTheMappingSays) {
  // y = x² on [0, 1]: every sample's pixel is the series colour; points off the curve stay blank.
  LinePlot plot;
  plot.x = linear(0, 1);
  plot.y = linear(0, 1);
  Series s;
  s.name = "x^2";
  s.colour = series_colour(0);
  s.thickness = 3;
  for (int i = 0; i <= 100; ++i) {
    s.x.push_back(i / 100.0);
    s.y.push_back((i / 100.0) * (i / 100.0));
  }
  plot.series.push_back(s);
  plot.legend = LegendPlace::kTopLeft;  // away from the curve's samples checked below
  const cv::Mat image = render_line_plot(plot);
  ASSERT_EQ(image.size(), plot.size);
  ASSERT_EQ(image.type(), CV_8UC3);
  const PlotArea area = line_plot_area(plot);
  for (double x : {0.2, 0.35, 0.5, 0.65, 0.8}) {
    const cv::Point on = area.to_point(x, x * x);
    EXPECT_TRUE(near_colour(image.at<cv::Vec3b>(on), s.colour)) << "x = " << x << " at " << on;
    // The same x, 0.3 higher: no curve there (white or light grid).
    const cv::Point off = area.to_point(x, x * x + 0.3 > 0.95 ? x * x - 0.3 : x * x + 0.3);
    EXPECT_FALSE(near_colour(image.at<cv::Vec3b>(off), s.colour, 80))
        << "x = " << x << " at " << off;
  }
  // The frame of the axes is black at the corners the curve does not pass through.
  const cv::Rect r = area.rect();
  EXPECT_EQ(image.at<cv::Vec3b>(r.y, r.x), cv::Vec3b(0, 0, 0));
  EXPECT_EQ(image.at<cv::Vec3b>(r.y + r.height - 1, r.x + r.width - 1), cv::Vec3b(0, 0, 0));
}

TEST(BenchPlot, NaNBreaksALineAndLengthsMustMatch) {
  LinePlot plot;
  Series s;
  s.colour = cv::Scalar(0, 0, 255);
  s.thickness = 3;
  s.x = {0.0, 0.5, 1.0};
  s.y = {0.5, NAN, 0.5};  // no valid neighbours: nothing is drawn at y = 0.5
  plot.series.push_back(s);
  const cv::Mat image = render_line_plot(plot);
  EXPECT_FALSE(
      near_colour(image.at<cv::Vec3b>(line_plot_area(plot).to_point(0.25, 0.5)), s.colour));
  plot.series[0].y.pop_back();
  EXPECT_THROW(render_line_plot(plot), ConfigError);
}

TEST(BenchPlot, BarsRiseFromTheAxisToTheirValue) {
  BarPlot plot;
  plot.y = linear(0, 100);
  plot.groups = {"a", "b"};
  plot.series = {"only"};
  plot.values = {{50.0}, {90.0}};
  const cv::Mat image = render_bar_plot(plot);
  ASSERT_EQ(image.size(), plot.size);
  const PlotArea area = bar_plot_area(plot);
  const cv::Scalar colour = series_colour(0);
  // Group 0 spans x ∈ [0, 1]; its single bar covers [0.1, 0.9] up to 50.
  EXPECT_TRUE(near_colour(image.at<cv::Vec3b>(area.to_point(0.5, 45)), colour, 0));
  EXPECT_TRUE(near_colour(image.at<cv::Vec3b>(area.to_point(0.5, 5)), colour, 0));
  EXPECT_FALSE(near_colour(image.at<cv::Vec3b>(area.to_point(0.5, 55)), colour, 40));
  EXPECT_TRUE(near_colour(image.at<cv::Vec3b>(area.to_point(1.5, 85)), colour, 0));
  plot.values = {{1.0}};
  EXPECT_THROW(render_bar_plot(plot), ConfigError);
}

}  // namespace
}  // namespace planecell::services::bench
