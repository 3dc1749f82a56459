#include "services/bench/plot.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <opencv2/imgproc.hpp>

#include "core/error.hpp"

namespace planecell::services::bench {
namespace {

constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
constexpr double kTickScale = 0.45;
constexpr double kLabelScale = 0.55;
constexpr double kTitleScale = 0.7;
constexpr int kShift = 4;  // sub-pixel bits of cv::line / cv::circle coordinates
const cv::Scalar kBlack(0, 0, 0);
const cv::Scalar kGrid(225, 225, 225);
const cv::Scalar kWhite(255, 255, 255);

// Margins around the plot area: left (tick labels + rotated y label), right, top (title),
// bottom (tick labels + x label).
constexpr int kPlotLeft = 96, kPlotRight = 28, kPlotTop = 52, kPlotBottom = 72;

void check_axis(const Axis& axis, const char* which) {
  if (!(axis.max > axis.min) || !std::isfinite(axis.min) || !std::isfinite(axis.max))
    throw ConfigError(std::string("plot: ") + which + " axis '" + axis.label +
                      "' has an empty range [" + std::to_string(axis.min) + ", " +
                      std::to_string(axis.max) + "]");
  if (axis.log10 && !(axis.min > 0.0))
    throw ConfigError(std::string("plot: log ") + which + " axis '" + axis.label +
                      "' needs min > 0, got " + std::to_string(axis.min));
}

cv::Point sub_pixel(const cv::Point2d& p, const cv::Point& origin) {
  return {static_cast<int>(std::lround((p.x - origin.x) * (1 << kShift))),
          static_cast<int>(std::lround((p.y - origin.y) * (1 << kShift)))};
}

PlotArea area_with_margins(cv::Size size, const Axis& x, const Axis& y) {
  return PlotArea(cv::Rect(kPlotLeft, kPlotTop, size.width - kPlotLeft - kPlotRight,
                           size.height - kPlotTop - kPlotBottom),
                  x, y);
}

}  // namespace

Axis linear_axis(double min, double max, std::string label) {
  Axis axis;
  axis.min = min;
  axis.max = max;
  axis.label = std::move(label);
  return axis;
}

PlotArea::PlotArea(cv::Rect area_px, Axis x, Axis y)
    : rect_(area_px), x_(std::move(x)), y_(std::move(y)) {
  if (rect_.width < 2 || rect_.height < 2)
    throw ConfigError("plot: the plot area " + std::to_string(rect_.width) + "x" +
                      std::to_string(rect_.height) +
                      " px is too small (image too small for its margins)");
  check_axis(x_, "x");
  check_axis(y_, "y");
}

double PlotArea::fraction(const Axis& axis, double value) const {
  if (axis.log10)
    return (std::log10(value) - std::log10(axis.min)) /
           (std::log10(axis.max) - std::log10(axis.min));
  return (value - axis.min) / (axis.max - axis.min);
}

cv::Point2d PlotArea::to_pixel(double x, double y) const {
  return {rect_.x + fraction(x_, x) * (rect_.width - 1),
          rect_.y + rect_.height - 1 - fraction(y_, y) * (rect_.height - 1)};
}

cv::Point PlotArea::to_point(double x, double y) const {
  const cv::Point2d p = to_pixel(x, y);
  return {static_cast<int>(std::lround(p.x)), static_cast<int>(std::lround(p.y))};
}

std::vector<double> nice_ticks(const Axis& axis, int target) {
  check_axis(axis, "tick");
  std::vector<double> ticks;
  if (!axis.ticks.empty()) {
    const double eps = 1e-9 * (axis.max - axis.min);
    for (double v : axis.ticks)
      if (v >= axis.min - eps && v <= axis.max + eps) ticks.push_back(v);
    return ticks;
  }
  if (axis.log10) {
    const int first = static_cast<int>(std::ceil(std::log10(axis.min) - 1e-9));
    const int last = static_cast<int>(std::floor(std::log10(axis.max) + 1e-9));
    const bool fine = last - first < 2;
    for (int e = first - 1; e <= last; ++e)
      for (double m : fine ? std::vector<double>{1, 2, 5} : std::vector<double>{1}) {
        const double v = m * std::pow(10.0, e);
        if (v >= axis.min * (1 - 1e-9) && v <= axis.max * (1 + 1e-9)) ticks.push_back(v);
      }
    return ticks;
  }
  const double raw = (axis.max - axis.min) / std::max(target, 1);
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  double step = 10.0 * magnitude;
  for (double m : {1.0, 2.0, 5.0})
    if (m * magnitude >= raw * (1 - 1e-9)) {
      step = m * magnitude;
      break;
    }
  step = std::max(step, axis.min_step);
  const double eps = 1e-9 * step;
  for (auto k = static_cast<long long>(std::ceil((axis.min - eps) / step));
       k * step <= axis.max + eps; ++k)
    ticks.push_back(std::abs(k * step) < eps ? 0.0 : static_cast<double>(k) * step);
  return ticks;
}

std::string tick_label(const Axis& axis, double value, const std::vector<double>& ticks) {
  if (axis.format) return axis.format(value);
  char text[64];
  if (axis.log10) {
    std::snprintf(text, sizeof(text), "%g", value);
    return text;
  }
  const double step = ticks.size() >= 2 ? ticks[1] - ticks[0] : std::abs(value);
  const int decimals =
      step > 0.0 ? std::max(0, -static_cast<int>(std::floor(std::log10(step) + 1e-9))) : 0;
  std::snprintf(text, sizeof(text), "%.*f", decimals, value);
  return text;
}

cv::Scalar series_colour(std::size_t k) {
  // Okabe–Ito palette (BGR): blue, orange, bluish green, vermillion, reddish purple, sky blue,
  // yellow.
  static const std::array<cv::Scalar, 7> palette = {
      cv::Scalar(178, 114, 0), cv::Scalar(0, 159, 230),   cv::Scalar(115, 158, 0),
      cv::Scalar(0, 94, 213),  cv::Scalar(167, 121, 204), cv::Scalar(233, 180, 86),
      cv::Scalar(66, 228, 240)};
  return palette[k % palette.size()];
}

void draw_text(cv::Mat& image, const std::string& text, cv::Point origin, double scale,
               const cv::Scalar& colour, int anchor, int thickness) {
  int baseline = 0;
  const cv::Size size = cv::getTextSize(text, kFont, scale, thickness, &baseline);
  if (anchor == 1) origin.x -= size.width / 2;
  if (anchor == 2) origin.x -= size.width;
  cv::putText(image, text, origin, kFont, scale, colour, thickness, cv::LINE_AA);
}

void draw_vertical_text(cv::Mat& image, const std::string& text, cv::Point centre, double scale) {
  int baseline = 0;
  const cv::Size size = cv::getTextSize(text, kFont, scale, 1, &baseline);
  cv::Mat patch(size.height + baseline + 4, size.width + 4, image.type(), kWhite);
  cv::putText(patch, text, {2, size.height + 2}, kFont, scale, kBlack, 1, cv::LINE_AA);
  cv::Mat rotated;
  cv::rotate(patch, rotated, cv::ROTATE_90_COUNTERCLOCKWISE);
  cv::Rect target(centre.x - rotated.cols / 2, centre.y - rotated.rows / 2, rotated.cols,
                  rotated.rows);
  target &= cv::Rect(0, 0, image.cols, image.rows);
  if (target.empty()) return;
  rotated(cv::Rect(target.x - (centre.x - rotated.cols / 2),
                   target.y - (centre.y - rotated.rows / 2), target.width, target.height))
      .copyTo(image(target));
}

void draw_axes(cv::Mat& image, const PlotArea& area, const std::string& title, bool grid,
               bool x_ticks) {
  const cv::Rect& r = area.rect();
  const int bottom = r.y + r.height - 1, right = r.x + r.width - 1;
  const auto yt = nice_ticks(area.y());
  for (double v : yt) {
    const int py = area.to_point(area.x().min, v).y;
    if (grid) cv::line(image, {r.x + 1, py}, {right - 1, py}, kGrid, 1);
    cv::line(image, {r.x - 6, py}, {r.x, py}, kBlack, 1);
    draw_text(image, tick_label(area.y(), v, yt), {r.x - 10, py + 5}, kTickScale, kBlack, 2);
  }
  if (x_ticks) {
    const auto xt = nice_ticks(area.x());
    for (double v : xt) {
      const int px = area.to_point(v, area.y().min).x;
      if (grid) cv::line(image, {px, r.y + 1}, {px, bottom - 1}, kGrid, 1);
      cv::line(image, {px, bottom}, {px, bottom + 6}, kBlack, 1);
      draw_text(image, tick_label(area.x(), v, xt), {px, bottom + 24}, kTickScale, kBlack, 1);
    }
  }
  cv::rectangle(image, {r.x, r.y}, {right, bottom}, kBlack, 1);
  if (!area.x().label.empty())
    draw_text(image, area.x().label, {r.x + r.width / 2, bottom + 54}, kLabelScale, kBlack, 1);
  if (!area.y().label.empty())
    draw_vertical_text(image, area.y().label, {20, r.y + r.height / 2}, kLabelScale);
  if (!title.empty())
    draw_text(image, title, {r.x + r.width / 2, r.y - 20}, kTitleScale, kBlack, 1, 2);
}

void draw_legend(cv::Mat& image, cv::Point top_right, const std::vector<std::string>& names,
                 const std::vector<cv::Scalar>& colours) {
  if (names.empty()) return;
  int text_width = 0;
  for (const auto& name : names) {
    int baseline = 0;
    text_width = std::max(text_width, cv::getTextSize(name, kFont, kTickScale, 1, &baseline).width);
  }
  const int row = 22, width = text_width + 52, height = row * static_cast<int>(names.size()) + 10;
  const cv::Rect box(top_right.x - width, top_right.y, width, height);
  cv::rectangle(image, box, kWhite, cv::FILLED);
  cv::rectangle(image, box, cv::Scalar(160, 160, 160), 1);
  for (std::size_t i = 0; i < names.size(); ++i) {
    const int y = box.y + 5 + row * static_cast<int>(i) + row / 2;
    const cv::Scalar c = i < colours.size() ? colours[i] : kBlack;
    cv::rectangle(image, {box.x + 8, y - 5}, {box.x + 34, y + 5}, c, cv::FILLED);
    draw_text(image, names[i], {box.x + 42, y + 5}, kTickScale, kBlack);
  }
}

/// Width of the legend box of `names` (as draw_legend draws it).
int legend_width(const std::vector<std::string>& names) {
  int text_width = 0;
  for (const auto& name : names) {
    int baseline = 0;
    text_width = std::max(text_width, cv::getTextSize(name, kFont, kTickScale, 1, &baseline).width);
  }
  return text_width + 52;
}

std::vector<std::string> series_names(const LinePlot& plot) {
  std::vector<std::string> names;
  for (const Series& s : plot.series)
    if (!s.name.empty()) names.push_back(s.name);
  return names;
}

PlotArea line_plot_area(const LinePlot& plot) {
  if (plot.legend != LegendPlace::kOutsideRight)
    return area_with_margins(plot.size, plot.x, plot.y);
  const int right = kPlotRight + legend_width(series_names(plot)) + 12;
  return PlotArea(cv::Rect(kPlotLeft, kPlotTop, plot.size.width - kPlotLeft - right,
                           plot.size.height - kPlotTop - kPlotBottom),
                  plot.x, plot.y);
}

cv::Mat render_line_plot(const LinePlot& plot) {
  const PlotArea area = line_plot_area(plot);
  cv::Mat image(plot.size, CV_8UC3, kWhite);
  draw_axes(image, area, plot.title);
  // Series are drawn into the area's view so that cv::line clips them to it.
  cv::Mat inside = image(area.rect());
  const cv::Point origin = area.rect().tl();
  std::vector<std::string> names;
  std::vector<cv::Scalar> colours;
  for (const Series& s : plot.series) {
    if (s.x.size() != s.y.size())
      throw ConfigError("plot '" + plot.title + "': series '" + s.name + "' has " +
                        std::to_string(s.x.size()) + " x values but " + std::to_string(s.y.size()) +
                        " y values");
    auto valid = [&](std::size_t i) {
      return std::isfinite(s.x[i]) && std::isfinite(s.y[i]) && (!plot.x.log10 || s.x[i] > 0) &&
             (!plot.y.log10 || s.y[i] > 0);
    };
    for (std::size_t i = 0; i + 1 < s.x.size(); ++i)
      if (valid(i) && valid(i + 1))
        cv::line(inside, sub_pixel(area.to_pixel(s.x[i], s.y[i]), origin),
                 sub_pixel(area.to_pixel(s.x[i + 1], s.y[i + 1]), origin), s.colour, s.thickness,
                 cv::LINE_AA, kShift);
    if (s.markers)
      for (std::size_t i = 0; i < s.x.size(); ++i)
        if (valid(i))
          cv::circle(inside, sub_pixel(area.to_pixel(s.x[i], s.y[i]), origin),
                     (s.thickness + 2) << kShift, s.colour, cv::FILLED, cv::LINE_AA, kShift);
    if (!s.name.empty()) {
      names.push_back(s.name);
      colours.push_back(s.colour);
    }
  }
  const cv::Rect& r = area.rect();
  const int legend_rows = static_cast<int>(names.size());
  switch (plot.legend) {
    case LegendPlace::kBottomRight:
      draw_legend(image, {r.x + r.width - 10, r.y + r.height - 20 - 22 * legend_rows}, names,
                  colours);
      break;
    case LegendPlace::kTopLeft:
      draw_legend(image, {r.x + 10 + legend_width(names), r.y + 10}, names, colours);
      break;
    case LegendPlace::kOutsideRight:
      draw_legend(image, {plot.size.width - kPlotRight, r.y}, names, colours);
      break;
  }
  return image;
}

PlotArea bar_plot_area(const BarPlot& plot) {
  Axis x;
  x.min = 0.0;
  x.max = static_cast<double>(std::max<std::size_t>(plot.groups.size(), 1));
  return area_with_margins(plot.size, x, plot.y);
}

cv::Mat render_bar_plot(const BarPlot& plot) {
  if (plot.values.size() != plot.groups.size())
    throw ConfigError("bar plot '" + plot.title + "': " + std::to_string(plot.values.size()) +
                      " value rows for " + std::to_string(plot.groups.size()) + " groups");
  for (const auto& row : plot.values)
    if (row.size() != plot.series.size())
      throw ConfigError("bar plot '" + plot.title + "': a group has " + std::to_string(row.size()) +
                        " values for " + std::to_string(plot.series.size()) + " series");
  const PlotArea area = bar_plot_area(plot);
  cv::Mat image(plot.size, CV_8UC3, kWhite);
  draw_axes(image, area, plot.title, /*grid=*/true, /*x_ticks=*/false);
  const double slot = 0.8 / static_cast<double>(std::max<std::size_t>(plot.series.size(), 1));
  std::vector<cv::Scalar> colours;
  for (std::size_t s = 0; s < plot.series.size(); ++s) colours.push_back(series_colour(s));
  const cv::Rect& r = area.rect();
  for (std::size_t g = 0; g < plot.groups.size(); ++g) {
    for (std::size_t s = 0; s < plot.series.size(); ++s) {
      const double v = plot.values[g][s];
      if (!std::isfinite(v)) continue;
      const double x0 = static_cast<double>(g) + 0.1 + slot * static_cast<double>(s);
      const double top = std::clamp(v, plot.y.min, plot.y.max);
      cv::Point a = area.to_point(x0, top), b = area.to_point(x0 + slot, plot.y.min);
      b.x = std::max(b.x - 1, a.x);  // a one-pixel gap between neighbouring bars
      cv::rectangle(image, a, b, colours[s], cv::FILLED);
    }
    const int cx = area.to_point(static_cast<double>(g) + 0.5, plot.y.min).x;
    const int bottom = r.y + r.height - 1;
    cv::line(image, {cx, bottom}, {cx, bottom + 6}, kBlack, 1);
    draw_text(image, plot.groups[g], {cx, bottom + 24}, kTickScale, kBlack, 1);
  }
  draw_legend(image, {r.x + r.width - 10, r.y + 10}, plot.series, colours);
  return image;
}

}  // namespace planecell::services::bench
