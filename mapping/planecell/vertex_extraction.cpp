/// Vertex extraction (paper §5): crack-following of each segment's outer boundary on the lattice
/// of pixel corners, keeping corners and junctions (see vertex_extraction.hpp).
#include "mapping/planecell/vertex_extraction.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "core/error.hpp"

namespace planecell::extraction {
namespace {

// Headings on the lattice, clockwise in image coordinates: E, S, W, N.
constexpr std::array<int, 4> kDx = {1, 0, -1, 0};
constexpr std::array<int, 4> kDy = {0, 1, 0, -1};

struct LatticeVertex {
  int x, y;       ///< lattice point = top-left corner of pixel (x, y)
  bool junction;  ///< three or more segments meet here (kept by the simplification)
};

/// Distance of p to the segment a–b.
double segment_distance(const Eigen::Vector2d& p, const Eigen::Vector2d& a,
                        const Eigen::Vector2d& b) {
  const Eigen::Vector2d ab = b - a;
  const double len2 = ab.squaredNorm();
  if (len2 == 0.0) return (p - a).norm();
  const double t = std::clamp((p - a).dot(ab) / len2, 0.0, 1.0);
  return (p - (a + t * ab)).norm();
}

/// Douglas–Peucker on chain[first..last] (both kept): marks the points to keep.
void douglas_peucker(const std::vector<Eigen::Vector2d>& chain, int first, int last,
                     double tolerance, std::vector<char>& keep) {
  if (last - first < 2) return;
  double worst = -1.0;
  int worst_index = -1;
  for (int k = first + 1; k < last; ++k) {
    const double d = segment_distance(chain[k], chain[first], chain[last]);
    if (d > worst) {
      worst = d;
      worst_index = k;
    }
  }
  if (worst <= tolerance) return;
  keep[worst_index] = 1;
  douglas_peucker(chain, first, worst_index, tolerance, keep);
  douglas_peucker(chain, worst_index, last, tolerance, keep);
}

/// Simplifies a closed polygon keeping junctions; chains between anchors go through DP.
std::vector<LatticeVertex> simplify(const std::vector<LatticeVertex>& polygon, double tolerance,
                                    bool junctions_only) {
  const int n = static_cast<int>(polygon.size());
  std::vector<int> anchors;
  for (int k = 0; k < n; ++k)
    if (polygon[k].junction) anchors.push_back(k);
  if (junctions_only && anchors.size() >= 3) {
    std::vector<LatticeVertex> out;
    for (int a : anchors) out.push_back(polygon[a]);
    return out;
  }
  if (junctions_only) tolerance = std::max(tolerance, 1.0);
  if (tolerance <= 0.0 || n <= 3) return polygon;
  if (anchors.empty()) {  // enclosed by one segment: anchor the first and the farthest point
    int far = 0;
    long best = -1;
    for (int k = 1; k < n; ++k) {
      const long dx = polygon[k].x - polygon[0].x, dy = polygon[k].y - polygon[0].y;
      if (dx * dx + dy * dy > best) {
        best = dx * dx + dy * dy;
        far = k;
      }
    }
    anchors = {0, far};
  }
  std::vector<char> keep(n, 0);
  for (int a : anchors) keep[a] = 1;
  std::vector<Eigen::Vector2d> chain;
  std::vector<int> chain_index;
  std::vector<char> chain_keep;
  for (std::size_t k = 0; k < anchors.size(); ++k) {
    const int from = anchors[k];
    const int to = anchors[(k + 1) % anchors.size()];
    const int length = ((to - from + n - 1) % n) + 1;  // to == from (single anchor): full loop
    chain.clear();
    chain_index.clear();
    for (int j = 0; j <= length; ++j) {
      const int idx = (from + j) % n;
      chain.emplace_back(polygon[idx].x, polygon[idx].y);
      chain_index.push_back(idx);
    }
    chain_keep.assign(chain.size(), 0);
    douglas_peucker(chain, 0, static_cast<int>(chain.size()) - 1, tolerance, chain_keep);
    for (std::size_t j = 0; j < chain.size(); ++j)
      if (chain_keep[j]) keep[chain_index[j]] = 1;
  }
  std::vector<LatticeVertex> out;
  for (int k = 0; k < n; ++k)
    if (keep[k]) out.push_back(polygon[k]);
  return out;
}

}  // namespace

std::vector<std::vector<Eigen::Vector2f>> extract_polygons(const cv::Mat& labels, int num_labels,
                                                           double tolerance_px,
                                                           bool junctions_only) {
  if (labels.empty() || labels.type() != CV_32SC1)
    throw InputError("extract_polygons: labels must be a non-empty CV_32S image");
  if (num_labels < 0) throw InputError("extract_polygons: num_labels must be >= 0");
  const int w = labels.cols, h = labels.rows;

  // Labels on a grid padded by one pixel of −1 (the outside), so that the four pixels around
  // lattice point (x, y), i.e. pixels (x−1, y−1), (x, y−1), (x−1, y), (x, y), sit at padded
  // indices p, p + 1, p + stride, p + stride + 1 with p = y·stride + x. The raster-first pixel
  // of each label starts its trace.
  const int stride = w + 2;
  std::vector<std::int32_t> padded(static_cast<std::size_t>(stride) * (h + 2), -1);
  std::vector<int> start(num_labels, -1);
  for (int v = 0; v < h; ++v) {
    const auto* row = labels.ptr<std::int32_t>(v);
    std::int32_t* out = padded.data() + static_cast<std::size_t>(v + 1) * stride + 1;
    for (int u = 0; u < w; ++u) {
      const int l = row[u];
      if (l < 0 || l >= num_labels)
        throw InputError("extract_polygons: label " + std::to_string(l) + " at (" +
                         std::to_string(u) + ", " + std::to_string(v) + ") outside [0, " +
                         std::to_string(num_labels) + ")");
      if (start[l] < 0) start[l] = v * w + u;
      out[u] = l;
    }
  }

  std::vector<std::vector<Eigen::Vector2f>> polygons(num_labels);
  std::vector<LatticeVertex> traced;
  for (int l = 0; l < num_labels; ++l) {
    if (start[l] < 0) continue;
    const int x0 = start[l] % w, y0 = start[l] / w;
    int x = x0, y = y0;
    int heading = 3;  // the closing edge arrives heading north
    traced.clear();
    do {
      const std::int32_t* p = padded.data() + static_cast<std::size_t>(y) * stride + x;
      // The four pixels around (x, y): NW, NE, SW, SE.
      const int nw = p[0], ne = p[1], sw = p[stride], se = p[stride + 1];
      // Front-right / front-left pixels of the edge leaving (x, y) along `heading` (E, S, W, N).
      const int front_right = heading == 0 ? se : heading == 1 ? sw : heading == 2 ? nw : ne;
      const int front_left = heading == 0 ? ne : heading == 1 ? se : heading == 2 ? sw : nw;
      int next = heading;
      if (front_right != l)
        next = (heading + 1) % 4;  // turn right
      else if (front_left == l)
        next = (heading + 3) % 4;  // turn left
      // Junction: ≥ 3 distinct segments (outside = −1) among the four pixels around (x, y).
      const int distinct =
          1 + (ne != nw) + (sw != nw && sw != ne) + (se != nw && se != ne && se != sw);
      const bool image_corner = (x == 0 || x == w) && (y == 0 || y == h);
      const bool junction = distinct >= 3 || image_corner;
      if (next != heading || junction) traced.push_back({x, y, junction});
      heading = next;
      x += kDx[heading];
      y += kDy[heading];
    } while (x != x0 || y != y0);
    const auto simplified = simplify(traced, tolerance_px, junctions_only);
    auto& polygon = polygons[l];
    polygon.reserve(simplified.size());
    for (const auto& p : simplified)
      polygon.emplace_back(static_cast<float>(p.x) - 0.5f, static_cast<float>(p.y) - 0.5f);
  }
  return polygons;
}

}  // namespace planecell::extraction
