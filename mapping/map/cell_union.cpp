#include "mapping/map/cell_union.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <string>

#include "core/error.hpp"

namespace planecell::map {
namespace {

constexpr int kUnionShift = 8;     // fillPoly fixed-point bits
constexpr int kMaxSide = 4000;     // bits per side of the union's raster

/// A polygon's bits: its own mask over `box` of the union's raster.
struct CellRaster {
  cv::Rect box;
  cv::Mat mask;  ///< CV_8U, box.size(), 1 = bit held
};

/// The 4-connected regions of `mask` (CV_8U, non-zero = set), each as a mask of mask's size.
std::vector<cv::Mat> regions_of(const cv::Mat& mask) {
  cv::Mat labels;
  const int count = cv::connectedComponents(mask, labels, 4, CV_32S);
  std::vector<cv::Mat> out;
  for (int l = 1; l < count; ++l) out.push_back(labels == l);
  return out;
}

}  // namespace

std::vector<CellUnion> unite_cells(std::span<const std::span<const Eigen::Vector3f>> polygons,
                                   const PlaneBasis& basis, const Plane3& plane,
                                   const CellUnionSettings& settings) {
  const double res = settings.resolution_m;
  if (!(res > 0.0) || !std::isfinite(res))
    throw InputError("cell union: resolution must be a finite number > 0 m, got " + std::to_string(res));
  if (!(settings.tolerance_m >= 0.0) || !std::isfinite(settings.tolerance_m))
    throw InputError("cell union: tolerance must be a finite number ≥ 0 m, got " +
                     std::to_string(settings.tolerance_m));
  if (!(settings.max_hole_m2 >= 0.0) || !std::isfinite(settings.max_hole_m2))
    throw InputError("cell union: max hole area must be a finite number ≥ 0 m², got " +
                     std::to_string(settings.max_hole_m2));
  if (settings.max_vertices < 3)
    throw InputError("cell union: max vertices must be at least 3, got " + std::to_string(settings.max_vertices));
  const std::size_t n = polygons.size();
  // Rings in bit units, pixel centres at integers: bit i covers [i·res, (i + 1)·res).
  std::vector<std::vector<Eigen::Vector2d>> rings(n);
  double lo_s = std::numeric_limits<double>::infinity(), lo_t = lo_s, hi_s = -lo_s, hi_t = -lo_s;
  for (std::size_t i = 0; i < n; ++i) {
    for (const Eigen::Vector2d& st : project_to_basis(polygons[i], basis)) {
      const Eigen::Vector2d p = st / res - Eigen::Vector2d::Constant(0.5);
      if (!p.allFinite()) return {};
      lo_s = std::min(lo_s, p.x()), hi_s = std::max(hi_s, p.x());
      lo_t = std::min(lo_t, p.y()), hi_t = std::max(hi_t, p.y());
      rings[i].push_back(p);
    }
  }
  if (!(hi_s - lo_s < kMaxSide && hi_t - lo_t < kMaxSide)) return {};
  // The union's raster: one free bit around everything.
  const double i0 = std::floor(lo_s) - 1.0, j0 = std::floor(lo_t) - 1.0;
  const cv::Size size(static_cast<int>(std::ceil(hi_s) - i0) + 2, static_cast<int>(std::ceil(hi_t) - j0) + 2);
  cv::Mat all = cv::Mat::zeros(size, CV_8U);
  std::vector<CellRaster> cells(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (rings[i].size() < 3) continue;
    double a0 = std::numeric_limits<double>::infinity(), b0 = a0, a1 = -a0, b1 = -a0;
    for (const auto& p : rings[i])
      a0 = std::min(a0, p.x() - i0), a1 = std::max(a1, p.x() - i0), b0 = std::min(b0, p.y() - j0),
      b1 = std::max(b1, p.y() - j0);
    CellRaster& cell = cells[i];
    cell.box = cv::Rect(cv::Point(static_cast<int>(std::floor(a0)), static_cast<int>(std::floor(b0))),
                        cv::Point(static_cast<int>(std::ceil(a1)) + 1, static_cast<int>(std::ceil(b1)) + 1)) &
               cv::Rect(cv::Point(0, 0), size);
    cell.mask = cv::Mat::zeros(cell.box.size(), CV_8U);
    std::vector<cv::Point> points;
    for (const auto& p : rings[i])
      points.emplace_back(
          static_cast<int>(std::lround((p.x() - i0 - cell.box.x) * (1 << kUnionShift))),
          static_cast<int>(std::lround((p.y() - j0 - cell.box.y) * (1 << kUnionShift))));
    cv::fillPoly(cell.mask, std::vector<std::vector<cv::Point>>{points}, cv::Scalar(1), cv::LINE_8,
                 kUnionShift);
    cv::Mat roi = all(cell.box);
    cv::bitwise_or(roi, cell.mask, roi);
  }

  // Hole-free regions: small holes filled, each region with a larger hole cut along the bit row
  // above that hole (the hole then opens onto the lower part's edge).
  const double max_hole_bits = settings.max_hole_m2 / (res * res);
  std::vector<cv::Mat> todo = regions_of(all);
  std::reverse(todo.begin(), todo.end());
  std::vector<cv::Mat> regions;
  std::vector<std::vector<cv::Point>> outlines;
  while (!todo.empty()) {
    cv::Mat region = std::move(todo.back());
    todo.pop_back();
    std::vector<std::vector<cv::Point>> contours;
    std::vector<cv::Vec4i> hierarchy;
    cv::findContours(region.clone(), contours, hierarchy, cv::RETR_CCOMP, cv::CHAIN_APPROX_SIMPLE);
    int cut_row = -1;
    for (std::size_t c = 0; c < contours.size(); ++c) {
      if (hierarchy[c][3] < 0) continue;  // an outer boundary
      cv::Mat hole = cv::Mat::zeros(region.size(), CV_8U);
      cv::drawContours(hole, contours, static_cast<int>(c), cv::Scalar(255), cv::FILLED);
      const cv::Mat open = hole & ~region;  // the hole's own bits
      if (cv::countNonZero(open) <= max_hole_bits) {
        region |= open;
      } else if (cut_row < 0) {
        cut_row = cv::boundingRect(contours[c]).y;  // the region's row just above the hole
      }
    }
    if (cut_row >= 0) {
      cv::Mat upper = region.clone(), lower = region.clone();
      upper.rowRange(cut_row + 1, upper.rows).setTo(0);
      lower.rowRange(0, cut_row + 1).setTo(0);
      if (cv::countNonZero(upper) > 0 && cv::countNonZero(lower) > 0) {
        for (cv::Mat* part : {&lower, &upper})
          for (cv::Mat& piece : regions_of(*part)) todo.push_back(std::move(piece));
        continue;
      }
      contours.clear();  // a cut that splits nothing off (never seen): no outline, no union
    }
    std::vector<cv::Point> outline;
    if (cut_row < 0) {
      contours.clear();
      cv::findContours(region.clone(), contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_SIMPLE);
    }
    if (contours.size() == 1) {
      for (double epsilon = std::max(settings.tolerance_m / res, 1e-3);; epsilon *= 2.0) {
        cv::approxPolyDP(contours.front(), outline, epsilon, true);
        if (outline.size() <= settings.max_vertices) break;
      }
      if ((outline.size() < 3 || cv::contourArea(outline) <= 0.0) && contours.front().size() <= settings.max_vertices)
        outline = contours.front();
      if (outline.size() < 3 || cv::contourArea(outline) <= 0.0) outline.clear();  // thinner than two bits
    }
    regions.push_back(std::move(region));
    outlines.push_back(std::move(outline));
  }

  // Which regions each polygon lies in; a region with an outline and two or more polygons is a
  // union candidate; then, until nothing changes, members are the polygons lying wholly in
  // candidates, and a candidate keeps its place only while it has a member.
  const std::size_t m = regions.size();
  cv::Mat owner = cv::Mat::zeros(size, CV_32S);  // region index + 1
  for (std::size_t r = 0; r < m; ++r) owner.setTo(static_cast<int>(r + 1), regions[r]);
  std::vector<std::vector<std::size_t>> in_regions(n);
  std::vector<std::size_t> polygon_count(m, 0);
  for (std::size_t i = 0; i < n; ++i) {
    if (cells[i].mask.empty()) continue;
    const cv::Mat own = owner(cells[i].box);
    std::vector<std::size_t>& list = in_regions[i];
    for (int y = 0; y < own.rows; ++y) {
      const auto* held = cells[i].mask.ptr<std::uint8_t>(y);
      const auto* region_of_bit = own.ptr<int>(y);
      for (int x = 0; x < own.cols; ++x)
        if (held[x]) {
          const auto r = static_cast<std::size_t>(region_of_bit[x] - 1);
          if (std::find(list.begin(), list.end(), r) == list.end()) list.push_back(r);
        }
    }
    for (std::size_t r : list) ++polygon_count[r];
  }
  std::vector<bool> candidate(m), member(n, false);
  for (std::size_t r = 0; r < m; ++r) candidate[r] = !outlines[r].empty() && polygon_count[r] >= 2;
  for (bool changed = true; changed;) {
    changed = false;
    for (std::size_t i = 0; i < n; ++i)
      member[i] = !in_regions[i].empty() &&
                  std::all_of(in_regions[i].begin(), in_regions[i].end(), [&](std::size_t r) { return candidate[r]; });
    std::vector<bool> has_member(m, false);
    for (std::size_t i = 0; i < n; ++i)
      if (member[i])
        for (std::size_t r : in_regions[i]) has_member[r] = true;
    for (std::size_t r = 0; r < m; ++r)
      if (candidate[r] && !has_member[r]) candidate[r] = false, changed = true;
  }

  const Eigen::Vector3d normal = plane.normal.normalized();
  const double offset = plane.offset / plane.normal.norm();
  std::vector<CellUnion> out;
  for (std::size_t r = 0; r < m; ++r) {
    if (!candidate[r]) continue;
    CellUnion united;
    for (const cv::Point& p : outlines[r]) {
      const Eigen::Vector3d x = basis.to_3d({(p.x + i0 + 0.5) * res, (p.y + j0 + 0.5) * res});
      united.vertices_m.push_back((x - (normal.dot(x) + offset) * normal).cast<float>());
    }
    for (std::size_t i = 0; i < n; ++i)
      if (member[i] && std::find(in_regions[i].begin(), in_regions[i].end(), r) != in_regions[i].end())
        united.members.push_back(i);
    out.push_back(std::move(united));
  }
  return out;
}

}  // namespace planecell::map
