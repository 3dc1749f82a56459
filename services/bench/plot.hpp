#pragma once
/// Small native plots for the bench report, drawn with OpenCV only (cv::line, cv::putText,
/// cv::fillPoly): a data→pixel mapping, axes with "nice" ticks and labels, legends, line plots
/// and grouped bar plots. No plotting dependency; the figures are plain BGR images.
#include <functional>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace planecell::services::bench {

/// One axis: its data range, scale and label. Tick labels come from `format` when given
/// (e.g. bytes as "1 MB"), else from the tick step.
struct Axis {
  double min = 0.0;
  double max = 1.0;
  bool log10 = false;  ///< logarithmic scale (needs 0 < min < max)
  std::string label;
  std::function<std::string(double value)> format;
  std::vector<double> ticks;  ///< explicit tick values (those inside the range); empty = nice_ticks
  double min_step = 0.0;      ///< linear axes: smallest tick step (1 for counts such as frames)
};

/// A linear axis over [min, max] named `label`.
Axis linear_axis(double min, double max, std::string label);

/// Maps data coordinates into a pixel rectangle of an image. With s(x) = x (or log10 x):
///   px = left + (s(x) − s(x_min)) / (s(x_max) − s(x_min)) · (width − 1)
///   py = bottom − (s(y) − s(y_min)) / (s(y_max) − s(y_min)) · (height − 1),  bottom = top + height
///   − 1
/// so x_min lands on the left edge, x_max on the right edge, y grows upwards.
class PlotArea {
 public:
  /// Throws ConfigError on an empty rectangle, max ≤ min, or a log axis with min ≤ 0.
  PlotArea(cv::Rect area_px, Axis x, Axis y);

  cv::Point2d to_pixel(double x, double y) const;
  /// Same, rounded to the nearest pixel.
  cv::Point to_point(double x, double y) const;
  const cv::Rect& rect() const { return rect_; }
  const Axis& x() const { return x_; }
  const Axis& y() const { return y_; }

 private:
  double fraction(const Axis& axis, double value) const;
  cv::Rect rect_;
  Axis x_, y_;
};

/// Tick values of an axis: axis.ticks inside the range when given; else linear axes step by 1, 2
/// or 5 × 10^k (at least axis.min_step) so that about `target` ticks cover [min, max] (ticks lie
/// inside the range); log axes use the powers of ten inside it (plus 2× and 5× when there are
/// fewer than three decades).
std::vector<double> nice_ticks(const Axis& axis, int target = 6);

/// Text of a tick: axis.format(value) when set, else fixed notation with as many decimals as
/// the tick step needs ("0.25" for a 0.05 step, "20" for a 10 step).
std::string tick_label(const Axis& axis, double value, const std::vector<double>& ticks);

/// Colour of the k-th series (a fixed, colour-blind-friendly palette, BGR).
cv::Scalar series_colour(std::size_t k);

/// Writes `text` with the report font (Hershey simplex, anti-aliased). `anchor` 0 = left,
/// 1 = centred, 2 = right-aligned at `origin` (baseline).
void draw_text(cv::Mat& image, const std::string& text, cv::Point origin, double scale,
               const cv::Scalar& colour, int anchor = 0, int thickness = 1);

/// Text rotated by 90° counter-clockwise (reading upwards), centred at `centre`.
void draw_vertical_text(cv::Mat& image, const std::string& text, cv::Point centre, double scale);

/// Frame, grid, ticks, tick labels, axis labels (y label rotated) and a title above the area.
/// `x_ticks` = false leaves the x axis without ticks (categorical axes label their own groups).
void draw_axes(cv::Mat& image, const PlotArea& area, const std::string& title, bool grid = true,
               bool x_ticks = true);

/// A legend box with a colour swatch per name, its top-right corner at `top_right`.
void draw_legend(cv::Mat& image, cv::Point top_right, const std::vector<std::string>& names,
                 const std::vector<cv::Scalar>& colours);

/// One line of a line plot (x and y of equal length; NaN points break the line).
struct Series {
  std::string name;
  std::vector<double> x, y;
  cv::Scalar colour = cv::Scalar(0, 0, 0);
  int thickness = 2;
  bool markers = false;  ///< small filled circles at the data points
};

/// Where a line plot's legend goes.
enum class LegendPlace { kBottomRight, kTopLeft, kOutsideRight };

struct LinePlot {
  std::string title;
  Axis x, y;
  std::vector<Series> series;
  cv::Size size{960, 600};
  LegendPlace legend = LegendPlace::kBottomRight;  ///< inside the area, or in a right margin
};

/// The plot area render_line_plot uses for `plot` (margins for labels and title, and for the
/// legend when it is outside).
PlotArea line_plot_area(const LinePlot& plot);

/// Renders a line plot on white: axes, grid, the series (clipped to the area), legend, title.
/// Throws ConfigError when a series' x and y differ in length (and as PlotArea).
cv::Mat render_line_plot(const LinePlot& plot);

/// Grouped bars: one group per label, one bar per series in each group.
struct BarPlot {
  std::string title;
  Axis y;                                   ///< x is categorical (the group labels)
  std::vector<std::string> groups;          ///< x labels
  std::vector<std::string> series;          ///< legend names
  std::vector<std::vector<double>> values;  ///< values[group][series]; NaN = no bar
  cv::Size size{960, 600};
};

/// The plot area of a bar plot (x axis runs over [0, groups]: group g spans [g, g + 1]).
PlotArea bar_plot_area(const BarPlot& plot);

/// Renders the bar plot: bars from the axis bottom to the value, value axis with ticks, group
/// labels under the groups, legend, title. Throws ConfigError when values do not match groups ×
/// series.
cv::Mat render_bar_plot(const BarPlot& plot);

}  // namespace planecell::services::bench
