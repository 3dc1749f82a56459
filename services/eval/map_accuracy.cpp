#include "services/eval/map_accuracy.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>
#include <unordered_set>

#include "core/error.hpp"
#include "mapping/map/coverage.hpp"
#include "mapping/map/geometry.hpp"

namespace planecell::services::eval {

std::vector<GtPolygon> gt_polygons(std::span<const io::SyntheticSurface> surfaces) {
  std::vector<GtPolygon> out;
  out.reserve(surfaces.size());
  for (const auto& s : surfaces) {
    if (s.polygon.size() < 3) continue;
    GtPolygon g{s.plane, {}, {}};
    for (const Eigen::Vector3d& c : s.corners_world()) g.corners.push_back(c.cast<float>());
    g.box = map::bounds_of(g.corners);
    out.push_back(std::move(g));
  }
  return out;
}

double distance_to_gt_polygon(const Eigen::Vector3d& point, const GtPolygon& gt) {
  return map::distance_to_polygon(point, gt.plane, gt.corners);
}

namespace {

/// An integer cell index packed into 64 bits (21 bits an axis: ±2²⁰ cells, far beyond any map's
/// coordinates at the edges used here: 100 km at 10 cm).
std::int64_t pack(const Eigen::Vector3i& q) {
  const auto axis = [](int x) { return static_cast<std::int64_t>(x) + (std::int64_t{1} << 20); };
  return (axis(q.x()) << 42) | (axis(q.y()) << 21) | axis(q.z());
}

/// The integer cell of edge `edge_m` holding the finite point `p`: ⌊p / edge_m⌋ per axis.
Eigen::Vector3i cell_of(const Eigen::Vector3d& p, double edge_m) {
  return (p / edge_m).array().floor().cast<int>();
}

/// The GT polygons by the cubes of edge kBucketM their bounds, widened by the largest scored
/// distance, overlap: a point's bucket lists every polygon that can come within that distance.
class GtBuckets {
 public:
  static constexpr double kBucketM = 2.0;
  explicit GtBuckets(std::span<const GtPolygon> gt) : gt_(gt) {
    const double reach = kCompletenessDistancesM.back();
    for (std::uint32_t i = 0; i < gt.size(); ++i) {
      const Eigen::Vector3i lo = cell_of(gt[i].box.min.array() - reach, kBucketM);
      const Eigen::Vector3i hi = cell_of(gt[i].box.max.array() + reach, kBucketM);
      for (int x = lo.x(); x <= hi.x(); ++x)
        for (int y = lo.y(); y <= hi.y(); ++y)
          for (int z = lo.z(); z <= hi.z(); ++z) buckets_[pack({x, y, z})].push_back(i);
    }
  }
  /// Distance from `p` to the nearest GT polygon, +∞ when none lies within the largest scored distance.
  double nearest(const Eigen::Vector3d& p) const {
    double best = std::numeric_limits<double>::infinity();
    if (const auto it = buckets_.find(pack(cell_of(p, kBucketM))); it != buckets_.end())
      for (std::uint32_t i : it->second) best = std::min(best, distance_to_gt_polygon(p, gt_[i]));
    return best;
  }

 private:
  std::span<const GtPolygon> gt_;
  std::unordered_map<std::int64_t, std::vector<std::uint32_t>> buckets_;
};

}  // namespace

MapAccuracy map_accuracy(const map::GlobalMap& map, std::span<const GtPolygon> gt) {
  MapAccuracy acc;
  std::array<double, kCompletenessDistancesM.size()> area_within{};
  const GtBuckets buckets(gt);
  std::vector<Eigen::Vector3f> vertices;
  for (const auto& [id, cell] : map.cells()) {
    cell.vertices_m.vertices_into(vertices);
    const double area = map::polygon_area_m2(vertices);
    const map::CoverageGrid grid = map::coverage_grid(cell.plane, vertices);
    if (!(area > 0.0) || grid.points.empty()) continue;
    ++acc.cells;
    acc.area_m2 += area;
    std::array<std::size_t, kCompletenessDistancesM.size()> hits{};
    for (const Eigen::Vector2d& st : grid.points) {
      const double d = buckets.nearest(grid.basis.to_3d(st));
      for (std::size_t i = 0; i < hits.size(); ++i)
        if (d <= kCompletenessDistancesM[i]) ++hits[i];
    }
    for (std::size_t i = 0; i < hits.size(); ++i)
      area_within[i] += area * static_cast<double>(hits[i]) / static_cast<double>(grid.points.size());
  }
  if (acc.area_m2 > 0.0)
    for (std::size_t i = 0; i < area_within.size(); ++i) acc.within[i] = area_within[i] / acc.area_m2;
  return acc;
}

VoxelAccuracy voxel_accuracy(std::span<const Eigen::Vector3d> centres, std::span<const GtPolygon> gt) {
  VoxelAccuracy acc;
  acc.voxels = centres.size();
  if (centres.empty()) return acc;
  const GtBuckets buckets(gt);
  std::array<std::size_t, kCompletenessDistancesM.size()> hits{};
  for (const Eigen::Vector3d& c : centres) {
    const double d = buckets.nearest(c);
    for (std::size_t i = 0; i < hits.size(); ++i)
      if (d <= kCompletenessDistancesM[i]) ++hits[i];
  }
  for (std::size_t i = 0; i < hits.size(); ++i)
    acc.within[i] = static_cast<double>(hits[i]) / static_cast<double>(centres.size());
  return acc;
}

MapCompleteness voxel_completeness(std::span<const Eigen::Vector3d> centres, double resolution_m,
                                   std::span<const Eigen::Vector3d> points) {
  if (!(resolution_m > 0.0))
    throw InputError("voxel completeness: resolution must be > 0 m, got " + std::to_string(resolution_m));
  MapCompleteness c;
  c.points = points.size();
  if (points.empty()) return c;
  std::unordered_set<std::int64_t> occupied;
  occupied.reserve(centres.size());
  for (const Eigen::Vector3d& centre : centres) occupied.insert(pack(cell_of(centre, resolution_m)));
  const double reach = kCompletenessDistancesM.back();
  const int shells = static_cast<int>(std::ceil(reach / resolution_m)) + 1;
  std::array<std::size_t, kCompletenessDistancesM.size()> hits{};
  for (const Eigen::Vector3d& p : points) {
    if (!p.allFinite()) continue;  // scored, held by nothing
    const Eigen::Vector3i home = cell_of(p, resolution_m);
    // Shell r (Chebyshev distance r in voxels) lies at least (r − 1)·resolution from p, which is
    // inside voxel `home`: stop once that exceeds the best distance found or the reach.
    double best = std::numeric_limits<double>::infinity();
    for (int r = 0; r <= shells && (r - 1) * resolution_m <= std::min(best, reach); ++r)
      for (int i = -r; i <= r; ++i)
        for (int j = -r; j <= r; ++j)
          for (int k = -r; k <= r; ++k) {
            if (std::max({std::abs(i), std::abs(j), std::abs(k)}) != r) continue;
            const Eigen::Vector3i q = home + Eigen::Vector3i(i, j, k);
            if (!occupied.contains(pack(q))) continue;
            const Eigen::Vector3d lo = q.cast<double>() * resolution_m;
            const Eigen::Vector3d gap = (lo - p).cwiseMax(p - (lo.array() + resolution_m).matrix()).cwiseMax(0.0);
            best = std::min(best, gap.norm());
          }
    for (std::size_t i = 0; i < hits.size(); ++i)
      if (best <= kCompletenessDistancesM[i]) ++hits[i];
  }
  for (std::size_t i = 0; i < hits.size(); ++i)
    c.within[i] = static_cast<double>(hits[i]) / static_cast<double>(points.size());
  return c;
}

}  // namespace planecell::services::eval
